"""The sign of a surface's inside, end to end (mesh --sign, repair): constructed surfaces where the
nearest triangle's pseudonormal makes a valid mesh of the wrong solid (a folded-back spike, a third
of the faces flipped, holes, overlapping and nested shells), written as STL with tests/models.py
and judged against the clean solid by a brute-force numpy winding number (independent of the code
under test); the npm bunny (open) and gearwheel; and a model's scale (2^-30 .. 2^30)."""
import json
import os
import unittest

import meshio
import numpy as np

import models
from harness import STL_MODELS, ScratchTestCase, run

# Hex faces as corner indices (VTK / meshio hexahedron order), each listed once per hex.
HEX_FACES = np.array([[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]])


def surface_samples(verts, tris, per_edge=6):
    """Points on every triangle (a barycentric lattice with per_edge steps a side)."""
    k = [(i, j) for i in range(per_edge + 1) for j in range(per_edge + 1 - i)]
    w = np.array([(i / per_edge, j / per_edge, 1 - (i + j) / per_edge) for i, j in k])
    p = verts[tris]
    return np.einsum("kc,tcd->tkd", w, p).reshape(-1, 3)


def nearest_distance(points, samples, chunk=32):
    out = np.empty(len(points))
    for s in range(0, len(points), chunk):
        d = np.linalg.norm(points[s:s + chunk, None, :] - samples[None, :, :], axis=-1)
        out[s:s + chunk] = d.min(axis=1)
    return out


def hex_centres(mesh):
    return mesh.points[mesh.cells_dict["hexahedron"]].mean(axis=1)


def boundary_points(mesh):
    """The vertices of the faces that only one hex has."""
    hexes = mesh.cells_dict["hexahedron"]
    faces = hexes[:, HEX_FACES].reshape(-1, 4)
    key = np.sort(faces, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    once = faces[counts[inverse.ravel()] == 1]
    return mesh.points[np.unique(once)]


class SignTest(ScratchTestCase):
    rng = np.random.default_rng(16)

    def write(self, name, verts, tris):
        path = os.path.join(self.dir, name)
        models.write_binary_stl(path, verts, tris)
        return path

    def mesh(self, stl, *options):
        inside = os.path.join(self.dir, "inside.vtu")
        outside = os.path.join(self.dir, "outside.vtu")
        report = os.path.join(self.dir, "report.json")
        r = run("mesh", stl, "--depth", 4, *options, "-o", inside, "--outside", outside, "--report", report,
                "--quiet")
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(report) as f:
            rep = json.load(f)
        return rep, meshio.read(inside), meshio.read(outside), inside

    def sample(self, points, n=300):
        return points[self.rng.choice(len(points), min(n, len(points)), replace=False)]

    def iou(self, inside, clean_stl):
        r = run("check", inside, "--input", clean_stl, "--json")
        self.assertEqual(r.returncode, 0, r.stderr)
        return json.loads(r.stdout)["fidelity"]["iou"]

    def assert_solid(self, rep, inside, outside, winding, clean_samples, euler, components):
        """inside and outside hex centres against the clean solid's winding number (those farther
        than a finest cell from its surface), the inside boundary's topology, and its distance."""
        h = rep["grid"]["cell_size"]
        for mesh, want_inside in ((inside, True), (outside, False)):
            c = self.sample(hex_centres(mesh))
            c = c[nearest_distance(c, clean_samples) > h]
            self.assertGreater(len(c), 50)
            w = winding(c)
            if want_inside:
                self.assertTrue(np.all(w > 0.5), f"{np.sum(w <= 0.5)} of {len(w)} inside centres have w <= 1/2")
            else:
                self.assertTrue(np.all(w < 0.5), f"{np.sum(w >= 0.5)} of {len(w)} outside centres have w >= 1/2")
        b = rep["check"]["inside"]["boundary"]
        self.assertTrue(b["closed_manifold"])
        self.assertEqual((b["euler_characteristic"], b["components"]), (euler, components))
        d = nearest_distance(self.sample(boundary_points(inside), 600), clean_samples)
        self.assertLessEqual(d.max(), 2 * h)

    def torus(self):
        return models.bumpy_torus(48, 24)

    def test_folded_spike_pseudonormal_puts_hexes_outside_winding_does_not(self):
        v, t = models.folded_spike()
        stl = self.write("spike.stl", v, t)
        lo, hi = v.min(axis=0), v.max(axis=0)
        wind = lambda p: models.winding_numbers(v, t, p)
        rep, inside, _, _ = self.mesh(stl, "--sign", "pseudonormal")
        self.assertEqual(rep["input"]["sign"], "pseudonormal")
        c = hex_centres(inside)
        beyond = c[((c < lo) | (c > hi)).any(axis=1)]
        self.assertGreater(len(beyond), 1000)  # inside hexes beyond the surface's box
        self.assertTrue(np.all(wind(self.sample(beyond)) < 0.5))
        rep, inside, outside, _ = self.mesh(stl)
        self.assertEqual(rep["input"]["sign"], "winding")
        self.assertGreater(rep["input"]["repair"]["self_intersecting_pairs"], 0)
        c = hex_centres(inside)
        self.assertFalse(((c < lo) | (c > hi)).any())
        self.assert_solid(rep, inside, outside, wind, surface_samples(v, t), 2, 1)

    def test_a_third_of_the_faces_flipped(self):
        v, t = self.torus()
        clean = self.write("clean.stl", v, t)
        stl = self.write("flipped.stl", v, models.flip_every_third(t))
        rep, inside, outside, path = self.mesh(stl)
        self.assertGreater(rep["input"]["repair"]["flipped_triangles"], 0)
        self.assert_solid(rep, inside, outside, lambda p: models.winding_numbers(v, t, p), surface_samples(v, t), 0, 1)
        self.assertGreaterEqual(self.iou(path, clean), 0.99)

    def test_holes_punched(self):
        v, t = self.torus()
        clean = self.write("clean.stl", v, t)
        holes = models.punch_holes(v, t, [(1.4, 0, 0), (-0.7, 0.7, 0.3), (0, -1, -0.35)], 0.12)
        self.assertLess(len(holes), len(t))
        rep, inside, outside, path = self.mesh(self.write("holes.stl", v, holes))
        self.assertEqual(rep["input"]["repair"]["boundary_loops"], 3)
        self.assert_solid(rep, inside, outside, lambda p: models.winding_numbers(v, t, p), surface_samples(v, t), 0, 1)
        self.assertGreaterEqual(self.iou(path, clean), 0.95)

    def test_two_overlapping_shells(self):
        a = models.uv_sphere(32, 16, 1.0, (-0.5, 0, 0))
        b = models.uv_sphere(32, 16, 0.8, (0.6, 0.1, 0))
        v, t = models.merge(a, b)
        stl = self.write("overlap.stl", v, t)
        # The clean solid is the union: inside either shell; its surface, each sphere's part
        # outside the other.
        union = lambda p: np.maximum(models.winding_numbers(*a, p), models.winding_numbers(*b, p))
        sa, sb = surface_samples(*a), surface_samples(*b)
        samples = np.concatenate([sa[np.linalg.norm(sa - (0.6, 0.1, 0), axis=1) >= 0.8],
                                  sb[np.linalg.norm(sb - (-0.5, 0, 0), axis=1) >= 1.0]])
        rep, inside, outside, path = self.mesh(stl)
        self.assertGreater(rep["input"]["repair"]["self_intersecting_pairs"], 0)
        self.assert_solid(rep, inside, outside, union, samples, 2, 1)
        self.assertGreaterEqual(self.iou(path, stl), 0.99)

    def test_a_nested_shell_is_a_cavity(self):
        outer = models.uv_sphere(32, 16, 1.0)
        inner = models.uv_sphere(24, 12, 0.5, (0.1, 0, 0))
        inward = (inner[0], inner[1][:, ::-1])
        v, t = models.merge(outer, inner)  # both outward: repair must turn the inner one in
        vc, tc = models.merge(outer, inward)
        clean = self.write("clean.stl", vc, tc)
        rep, inside, outside, path = self.mesh(self.write("nested.stl", v, t))
        self.assertEqual(rep["input"]["repair"]["cavities"], 1)
        self.assert_solid(rep, inside, outside, lambda p: models.winding_numbers(vc, tc, p),
                          surface_samples(vc, tc), 4, 2)
        self.assertGreaterEqual(self.iou(path, clean), 0.99)


class ModelTest(ScratchTestCase):
    def test_npm_bunny_and_gearwheel_are_valid_and_certified(self):
        for name in ("bunny", "gearwheel"):
            stl = os.path.join(STL_MODELS, "objects", name + ".bin.stl")
            report = os.path.join(self.dir, name + ".json")
            r = run("mesh", stl, "--depth", 3, "--fidelity", "-o", os.path.join(self.dir, name + ".vtu"),
                    "--report", report)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertIn("repair:", r.stdout)
            with open(report) as f:
                rep = json.load(f)
            self.assertTrue(rep["check"]["ok"])
            q = rep["check"]["inside"]["quality"]
            self.assertEqual(q["certified"], q["count"])
            print(f"{name}: IoU {rep['fidelity']['iou']:.4f}, repair: {rep['input']['repair']['summary']}")
            self.assertGreater(rep["fidelity"]["iou"], 0.9)


class RepairOptionsTest(ScratchTestCase):
    def test_a_surface_repair_empties_is_one_line_and_exit_1(self):
        path = os.path.join(self.dir, "sheet.obj")  # a face and its opposite copy: no volume
        with open(path, "w") as f:
            f.write("v 0 0 0\nv 1 0 0\nv 0 1 1\nf 1 2 3\nf 1 3 2\n")
        out = os.path.join(self.dir, "x.mesh")
        r = run("mesh", path, "--depth", 1, "-o", out)
        self.assertEqual(r.returncode, 1)
        self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
        self.assertIn(path, r.stderr)
        self.assertIn("no face is left after repair", r.stderr)
        self.assertFalse(os.path.exists(out))

    def test_no_repair_meshes_the_surface_as_given(self):
        v, t = models.uv_sphere(24, 12)
        path = os.path.join(self.dir, "inverted.stl")
        models.write_binary_stl(path, v, t[:, ::-1])  # inside out
        report = os.path.join(self.dir, "r.json")
        for options, solid in ((("--no-repair", "--sign", "pseudonormal"), False), ((), True)):
            r = run("mesh", path, "--depth", 3, *options, "-o", os.path.join(self.dir, "x.vtu"), "--report", report,
                    "--quiet")
            self.assertEqual(r.returncode, 0, r.stderr)
            with open(report) as f:
                rep = json.load(f)
            self.assertEqual(rep["input"]["repair"] is not None, solid)
            # Inside out as given: the pseudonormal's inside is the outside of the ball.
            vol = rep["check"]["inside"]["quality"]["volume"]
            if solid:
                self.assertEqual(rep["input"]["repair"]["reversed_components"], 1)
                self.assertAlmostEqual(vol, models.signed_volume(v, t), delta=0.02)
            else:
                self.assertGreater(vol, 2 * 4 / 3 * np.pi)  # the padded box less the ball


class ScaleTest(ScratchTestCase):
    def test_a_sphere_meshes_alike_at_2_to_the_minus_30_1_and_2_to_the_30(self):
        # Scales by powers of two: the STL's float32 stores the scaled sphere exactly and every
        # rounding in the pipeline scales with it, so the meshes must be the same to the bit
        # (with 1e-9 and 1e9 the input's own rounding moved the snapped boundary's decisions).
        v, t = models.uv_sphere(32, 16)
        meshes = {}
        scales = (2.0**-30, 2.0**30)
        for scale in (scales[0], 1.0, scales[1]):
            stl = os.path.join(self.dir, f"s{scale}.stl")
            models.write_binary_stl(stl, v * scale, t)
            for grid in (("--depth", 3), ("--threshold", 0.05, "--max-depth", 3)):
                out = os.path.join(self.dir, f"s{scale}{grid[0]}.vtu")
                r = run("mesh", stl, *grid, "-o", out, "--quiet")
                self.assertEqual(r.returncode, 0, r.stderr)
                m = meshio.read(out)
                meshes[scale, grid[0]] = (m.points / scale, m.cells_dict["hexahedron"])
        for grid in ("--depth", "--threshold"):
            p1, h1 = meshes[1.0, grid]
            for scale in scales:
                p, h = meshes[scale, grid]
                np.testing.assert_array_equal(h, h1)
                np.testing.assert_array_equal(p, p1)


if __name__ == "__main__":
    unittest.main()
