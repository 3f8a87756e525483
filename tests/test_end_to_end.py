"""End to end on real models: closed models of 5k to 54k triangles at depth 4 (81^3 cells) with
MCHex (the default) and RO, the packages' test models (closed, open, broken), each meshed and
then checked by `mchex-gpu check`."""
import glob
import json
import os
import unittest

import meshio
import numpy as np

import models
from harness import STL_MODELS, ScratchTestCase, run





class EndToEnd(ScratchTestCase):

    def mesh_and_check(self, model, depth, *extra):
        inside = os.path.join(self.dir, "in.vtu")
        outside = os.path.join(self.dir, "out.vtu")
        report = os.path.join(self.dir, "report.json")
        r = run("mesh", model, "--depth", depth, "-o", inside, "--outside", outside, "--report", report,
                "--quiet", *extra)
        self.assertEqual(r.returncode, 0, r.stderr)
        c = run("check", inside, "--outside", outside, "--json")
        self.assertEqual(c.returncode, 0, c.stdout[-2000:] + c.stderr)
        return json.load(open(report)), json.loads(c.stdout), inside

    def test_closed_54k_triangle_model_at_depth_4(self):
        stl = os.path.join(self.dir, "bumpy_torus.stl")
        v, t = models.bumpy_torus(320, 84)
        models.write_binary_stl(stl, v, t)
        rep, chk, inside = self.mesh_and_check(stl, 4, "--method", "ro", "--fidelity", "--lattice", 96)
        self.assertEqual(rep["input"]["triangles"], 53760)
        self.assertTrue(rep["input"]["closed"])
        self.assertTrue(rep["input"]["consistently_oriented"])
        self.assertEqual(rep["grid"]["cells"], 81 ** 3)
        e = rep["elements"]
        self.assertEqual(e["inside_hexes"] + e["outside_hexes"], 81 ** 3)
        self.assertEqual(chk["check"]["inside"]["hexes"], e["inside_hexes"])
        self.assertGreater(rep["fidelity"]["iou"], 0.9)
        self.assertLess(rep["fidelity"]["hausdorff_ratio"], 0.02)
        # Independent reader and an independent inside test: the solid's volume by the divergence
        # theorem on the input triangles against the mesh volume.
        m = meshio.read(inside)
        p = m.points[m.cells_dict["hexahedron"]]
        mesh_volume = np.prod(p[:, 6] - p[:, 0], axis=1).sum()  # axis-aligned cells
        a, b, c = (v[t[:, k]] for k in range(3))
        solid_volume = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6
        cell = rep["grid"]["cell_size"]
        area = np.linalg.norm(np.cross(b - a, c - a), axis=1).sum() / 2
        self.assertLess(abs(mesh_volume - solid_volume), area * cell)

    def test_closed_models_at_depth_4_are_fully_certified(self):
        # Issue 5's bar: closed models of 5k-50k triangles at depth 4, MCHex, both meshes conform
        # and every hex is Bernstein-certified. A knotted tube (thin necks, near-tangent passes),
        # the package gearwheel split to 9,776 triangles (sharp teeth), a bumpy torus.
        gear_v, gear_t = models.read_ascii_stl(os.path.join(STL_MODELS, "objects", "gearwheel.ascii.stl"))
        cases = {"trefoil": models.trefoil_tube(300, 30), "gearwheel": models.split_triangles(gear_v, gear_t),
                 "bumpy": models.bumpy_torus(150, 150)}
        for name, (v, t) in cases.items():
            with self.subTest(model=name):
                self.assertTrue(5000 <= len(t) <= 50000)
                stl = os.path.join(self.dir, name + ".stl")
                models.write_binary_stl(stl, v, t)
                rep, chk, inside = self.mesh_and_check(stl, 4)
                self.assertEqual(rep["method"], "mchex")
                self.assertTrue(rep["input"]["closed"])
                for side in ("inside", "outside"):
                    q = chk["check"][side]["quality"]
                    self.assertEqual(q["certified"], q["count"], side)
                    self.assertGreater(q["min_scaled_jacobian"], 0, side)
                self.assertTrue(chk["check"]["ok"])
                b = chk["check"]["inside"]["boundary"]
                self.assertTrue(b["closed_manifold"])
                self.assertEqual(b["euler_characteristic"], 0)  # all three have genus 1
                # The solid's volume by the divergence theorem on the input triangles; MCHex cuts
                # at the trilinear isosurface, so the mesh volume is far closer to it than a
                # cell layer over the surface area.
                a, bb, c = (v[t[:, k]] for k in range(3))
                solid_volume = np.einsum("ij,ij->i", a, np.cross(bb, c)).sum() / 6
                area = np.linalg.norm(np.cross(bb - a, c - a), axis=1).sum() / 2
                cell = rep["grid"]["cell_size"]
                mesh_volume = chk["check"]["inside"]["quality"]["volume"]
                self.assertLess(abs(mesh_volume - solid_volume), 0.1 * area * cell)

    def test_adaptive_meshes_are_fully_certified(self):
        # Issue 6's bar on the adaptive grid (threshold 0.05, transition cells of every template):
        # both meshes conform and every hex is Bernstein-certified, on an analytic shape and on a
        # closed model (the bumpy torus's grid has face-template cells at depth 4).
        stl = os.path.join(self.dir, "bumpy.stl")
        models.write_binary_stl(stl, *models.bumpy_torus(150, 150))
        for name, source in (("sphere", ("--shape", "sphere")), ("bumpy", (stl,))):
            with self.subTest(model=name):
                inside = os.path.join(self.dir, name + ".mesh")
                outside = os.path.join(self.dir, name + "_out.mesh")
                report = os.path.join(self.dir, name + ".json")
                r = run("mesh", *source, "--threshold", 0.05, "--max-depth", 4, "-o", inside, "--outside", outside,
                        "--report", report, "--quiet")
                self.assertEqual(r.returncode, 0, r.stderr)
                rep = json.load(open(report))
                cells = rep["grid"]["cells_per_type"]
                self.assertGreater(sum(n for t, n in cells.items() if t != "cube"), 0, cells)
                self.assertEqual(rep["mchex"]["uncertified_polyhedra"], 0)
                c = run("check", inside, "--outside", outside, "--json")
                self.assertEqual(c.returncode, 0, c.stdout[-2000:] + c.stderr)
                chk = json.loads(c.stdout)
                self.assertTrue(chk["check"]["ok"])
                for side in ("inside", "outside"):
                    q = chk["check"][side]["quality"]
                    self.assertEqual(q["certified"], q["count"], side)

    def test_package_models(self):
        closed = [os.path.join(STL_MODELS, "objects", "gearwheel.bin.stl"),
                  os.path.join(STL_MODELS, "polytopes", "cube.ascii.stl"),
                  "/usr/share/assimp/models/OFF/Cube.off",
                  "/usr/share/assimp/models/PLY/cube_binary.ply"]
        for model in closed:
            with self.subTest(model=model):
                rep, chk, _ = self.mesh_and_check(model, 3)
                self.assertTrue(rep["input"]["closed"], model)
                self.assertGreater(rep["elements"]["inside_hexes"], 0)
        # Open surfaces (the npm bunny has holes in its base) mesh with a warning.
        bunny = os.path.join(STL_MODELS, "objects", "bunny.bin.stl")
        r = run("mesh", bunny, "--depth", 3, "-o", os.path.join(self.dir, "b.mesh"))
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("warning", r.stderr)
        self.assertIn("not a closed", r.stderr)

    def test_broken_package_files_never_crash(self):
        files = glob.glob("/usr/share/openscad/testdata/stl/*.stl") + glob.glob(os.path.join(STL_MODELS, "broken", "*.stl"))
        files += glob.glob("/usr/share/assimp/models/*/invalid*") + ["/usr/share/assimp/models/OFF/invalid.off"]
        self.assertGreater(len(files), 10)
        for i, f in enumerate(sorted(set(files))):
            with self.subTest(file=f):
                out = os.path.join(self.dir, f"x{i}.mesh")
                r = run("mesh", f, "--depth", 1, "-o", out, "--quiet")
                self.assertIn(r.returncode, (0, 1), r.stderr)
                if r.returncode == 1:
                    self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
                    self.assertIn(f, r.stderr)
                    self.assertFalse(os.path.exists(out))
                else:
                    self.assertTrue(os.path.exists(out))


if __name__ == "__main__":
    unittest.main()
