"""Several closed surfaces as the regions of one conforming hex mesh (core/pipeline/regions.h,
docs/regions.md), against references computed here: region volumes against the analytic balls
and lens (and the shells' own polyhedral volumes), convergence as the cells shrink, the labels
every writer carries as meshio reads them, region interfaces shared face for face (found by
brute force over the hexes' faces), --region-order, and bad input.

The shells are tests/models.py's uv spheres and boxes made here, written as binary STL.
"""

import json
import math
import os
import unittest

import meshio  # Debian's python3-meshio; tests/CMakeLists.txt runs /usr/bin/python3
import numpy as np

import models
from models import box_surface
from harness import ScratchTestCase, run

# The hex faces as corner positions of the .vtu/.mesh corner order (bottom 0-3, top 4-7).
HEX_FACES = [[0, 1, 2, 3], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]]


def lens_volume(r, d):
    """The intersection of two balls of radius r whose centres are d apart."""
    return math.pi * (4 * r + d) * (2 * r - d) ** 2 / 12


def hex_faces(cells):
    """Every face of every hex: sorted corner tuple -> list of hexes."""
    faces = {}
    for h, hexa in enumerate(cells):
        for f in HEX_FACES:
            faces.setdefault(tuple(sorted(hexa[f])), []).append(h)
    return faces


class Regions(ScratchTestCase):
    def write(self, name, surface):
        path = os.path.join(self.dir, name)
        models.write_binary_stl(path, *surface)
        return path

    def mesh(self, inputs, depth, *extra, out="in.vtu"):
        out = os.path.join(self.dir, out)
        report = os.path.join(self.dir, "report.json")
        r = run("mesh", *inputs, "--depth", depth, "-o", out, "--outside", os.path.join(self.dir, "out.vtu"),
                "--report", report, "--quiet", *extra)
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(report) as f:
            return out, json.load(f)

    def assert_valid(self, rep):
        """check passed, every hex certified, and check's per-region quality counts the regions' hexes."""
        self.assertTrue(rep["check"]["ok"], rep["check"]["errors"])
        for side in ("inside", "outside"):
            q = rep["check"][side]["quality"]
            self.assertEqual(q["certified"], q["count"], side)
            self.assertEqual(q["count"], rep["check"][side]["hexes"], side)
        per_region = {r["region"]: r["quality"]["count"] for r in rep["check"]["inside"]["regions"]}
        self.assertEqual(per_region, {r["label"]: r["hexes"] for r in rep["regions"]["regions"]})

    def test_nested_spheres_converge_to_the_shell_and_the_ball(self):
        outer = self.write("outer.stl", models.uv_sphere(96, 48, 1.0))
        inner = self.write("inner.stl", models.uv_sphere(96, 48, 0.5))
        v_outer = models.signed_volume(*models.uv_sphere(96, 48, 1.0))
        v_inner = models.signed_volume(*models.uv_sphere(96, 48, 0.5))
        errors = []
        for depth in (2, 3):
            path, rep = self.mesh([outer, inner], depth)
            self.assert_valid(rep)
            reg = rep["regions"]
            # The smaller enclosed volume wins a point inside both: the ball is region 2's.
            self.assertEqual(reg["priority"], [2, 1])
            self.assertEqual(reg["outside_label"], 3)
            volumes = [r["volume"] for r in reg["regions"]]
            errors.append([abs(volumes[0] - (v_outer - v_inner)) / (v_outer - v_inner),
                           abs(volumes[1] - v_inner) / v_inner])
            m = meshio.read(path)
            labels = m.cell_data["region"][0]
            self.assertEqual(sorted(set(labels.tolist())), [1, 2])
            self.assertEqual([int((labels == k).sum()) for k in (1, 2)], [r["hexes"] for r in reg["regions"]])
            self.assertEqual(len(labels), rep["check"]["inside"]["hexes"])
            # The ball's hexes meet the shell's face for face: every face of a region-2 hex that no
            # other region-2 hex has is a face of exactly one region-1 hex (the ball is enclosed).
            faces = hex_faces(m.cells_dict["hexahedron"])
            interface = 0
            for owners in faces.values():
                kinds = sorted(labels[h] for h in owners)
                self.assertLessEqual(len(owners), 2)
                if 2 in kinds and len(owners) == 1:
                    self.fail("a face of the ball lies on the mesh boundary")
                interface += kinds == [1, 2]
            self.assertGreater(interface, 0)
            # The outside mesh is the box less the outer ball, labelled outside.
            out = meshio.read(os.path.join(self.dir, "out.vtu"))
            self.assertEqual(set(out.cell_data["region"][0].tolist()), {3})
        self.assertLess(errors[1][0], errors[0][0])
        self.assertLess(errors[1][1], errors[0][1])
        self.assertLess(max(errors[1]), 0.03)

    def test_overlapping_spheres_give_the_lens_to_the_first_in_order(self):
        r, d = 0.6, 0.7
        a = self.write("a.stl", models.uv_sphere(96, 48, r, (-d / 2, 0, 0)))
        b = self.write("b.stl", models.uv_sphere(96, 48, r, (d / 2, 0, 0)))
        ball, lens = 4 / 3 * math.pi * r**3, lens_volume(r, d)
        for order, expected in (("", [ball, ball - lens]), ("2,1", [ball - lens, ball])):
            extra = ["--region-order", order] if order else []
            _, rep = self.mesh([a, b], 3, *extra)
            self.assert_valid(rep)
            reg = rep["regions"]
            self.assertEqual(reg["priority"], [2, 1] if order else [1, 2])  # equal volumes: input order
            for got, want in zip([x["volume"] for x in reg["regions"]], expected):
                self.assertLess(abs(got - want) / want, 0.03, (order, got, want))

    def test_junction_cells_of_crossing_spheres_are_well_shaped(self):
        # Two spheres of different radii crossing along a circle in no symmetry plane of the grid.
        # Without the lift around the junction curve (core/pipeline/regions.h JunctionLift) this
        # mesh's worst hex had scaled Jacobian 0.0009 (0.158 after the optimiser); with it the
        # junction cells are about as good as the rest (0.175), and the optimiser takes both meshes
        # past Awad et al.'s Table 1 for their two spheres (min scaled Jacobian 0.24, dihedral
        # angles 23.9 to 157.9 degrees). Measured there: 0.484, 31.8 to 150.3 degrees. With the cap
        # at 8.3 its last phase also meets Table 1's edge-length ratio (shortest over longest at
        # least 0.12; 11.9 before it, measured 8.3 after, min scaled Jacobian 0.472).
        (ca, ra), (cb, rb) = ((-0.35, 0, 0), 0.6), ((0.33, 0.05, 0.02), 0.5)
        a = self.write("a.stl", models.uv_sphere(96, 48, ra, ca))
        b = self.write("b.stl", models.uv_sphere(96, 48, rb, cb))
        d = math.dist(ca, cb)
        lens = math.pi * (ra + rb - d) ** 2 * (d * d + 2 * d * (ra + rb) - 3 * (ra - rb) ** 2) / (12 * d)
        capped = ["--optimize", "--optimize-max-edge-ratio", "8.3"]
        for extra, min_sj in (([], 0.15), (["--optimize"], 0.24), (capped, 0.24)):
            _, rep = self.mesh([a, b], 3, "--repel", *extra)
            self.assert_valid(rep)
            reg = rep["regions"]
            # 96 longitudes, each sphere's band triangles cut by the other: hundreds of pieces.
            self.assertGreater(reg["junction_segments"], 2 * 96)
            for end in ("min", "max"):
                self.assertAlmostEqual(reg["junction_lift_radius"][end], rep["grid"]["cell_size"], places=12)
            for side in ("inside", "outside"):
                q = rep["check"][side]["quality"]
                self.assertGreaterEqual(q["min_scaled_jacobian"], min_sj, (extra, side))
                if extra:
                    self.assertGreaterEqual(q["min_dihedral_angle"], 23.9, side)
                    self.assertLessEqual(q["max_dihedral_angle"], 157.9, side)
                if extra == capped:
                    self.assertLessEqual(q["max_edge_ratio"], 8.3 * (1 + 1e-9), side)
            # The shells' interface is snapped onto them where no hex loses quality (--repel),
            # never within the junction's margin (measured 2026-12-06: 506 of 7,044 points moved).
            snap = rep["snap"]
            self.assertEqual(snap["moved"] + snap["partly"] + snap["stayed"], snap["vertices"], extra)
            self.assertGreater(snap["moved"], 0, extra)
            self.assertGreater(snap["stayed"], 0, extra)
            if not extra:
                # The lift is what does it: off, the junction's neck gives the worst hex.
                _, off = self.mesh([a, b], 3, "--repel", "--junction-lift", "0")
                self.assert_valid(off)
                self.assertLess(off["check"]["inside"]["quality"]["min_scaled_jacobian"], 0.01)
                self.assertIsNone(off["regions"]["junction_lift_radius"])
            # The smaller ball comes first and keeps the lens.
            self.assertEqual(reg["priority"], [2, 1])
            volumes = [x["volume"] for x in reg["regions"]]
            for got, want in zip(volumes, [4 / 3 * math.pi * ra**3 - lens, 4 / 3 * math.pi * rb**3]):
                self.assertLess(abs(got - want) / want, 0.03, (extra, got, want))

    def test_three_crossing_spheres_on_the_fitted_grid(self):
        # Every pair crosses, and all three at two points. On the default fitted grid, without
        # the lift, a fit round's new leaves held a cell no certificate covered, and the remedy
        # only ran before the rounds: the mesh failed its own check (exit 3, nothing written).
        # With the lift the fit rounds leave the junctions alone (the lifted mesh lies off the
        # shells there by design) and the worst hex is 0.046 (0.0004 with them refined).
        o = np.array([0.013, 0.021, 0.007])
        shells = [((-0.35, 0, 0), 0.6), ((0.33, 0.05, 0.02), 0.5), ((0.0, 0.5, -0.1), 0.45)]
        paths = [self.write(f"s{i}.stl", models.uv_sphere(96, 48, r, o + c)) for i, (c, r) in enumerate(shells)]
        for lift, min_sj in (("0", 0.0), ("1", 0.04)):
            out = os.path.join(self.dir, "in.vtu")
            report = os.path.join(self.dir, "report.json")
            r = run("mesh", *paths, "--repel", "--junction-lift", lift, "-o", out, "--report", report, "--quiet")
            self.assertEqual(r.returncode, 0, r.stderr)
            with open(report) as f:
                rep = json.load(f)
            self.assert_valid(rep)
            self.assertEqual(len(rep["regions"]["regions"]), 3)
            for side in ("inside", "outside"):
                self.assertGreater(rep["check"][side]["quality"]["min_scaled_jacobian"], min_sj, (lift, side))

    def test_boxes_sharing_a_face_conform_along_it(self):
        # The face x = 1 is a grid plane of the padded cube (the cube is centred on the input):
        # the two regions meet there face for face.
        b1 = self.write("b1.stl", box_surface((0, 0, 0), (1, 1, 1)))
        b2 = self.write("b2.stl", box_surface((1, 0, 0), (2, 1, 1)))
        path, rep = self.mesh([b1, b2], 3)
        self.assert_valid(rep)
        reg = rep["regions"]
        self.assertEqual(reg["shared_faces"], 2)
        self.assertEqual(reg["regions"][0]["hexes"], reg["regions"][1]["hexes"])
        m = meshio.read(path)
        labels, hexes = m.cell_data["region"][0], m.cells_dict["hexahedron"]
        between = [f for f, owners in hex_faces(hexes).items() if sorted(labels[h] for h in owners) == [1, 2]]
        self.assertGreater(len(between), 0)
        for f in between:
            self.assertTrue(np.allclose(m.points[list(f), 0], 1.0), m.points[list(f)])

    def test_every_format_keeps_the_regions(self):
        outer = self.write("outer.stl", models.uv_sphere(48, 24, 1.0))
        inner = self.write("inner.stl", models.uv_sphere(48, 24, 0.5))
        counts = None
        for ext in ("vtu", "mesh", "meshb", "msh", "exo", "inp"):
            path, rep = self.mesh([outer, inner], 2, out="in." + ext)
            want = [r["hexes"] for r in rep["regions"]["regions"]]
            counts = counts or want
            self.assertEqual(want, counts)
            m = meshio.read(path)
            if ext == "vtu":
                got = [int((m.cell_data["region"][0] == k).sum()) for k in (1, 2)]
            elif ext in ("mesh", "meshb"):
                got = [int((m.cell_data["medit:ref"][0] == k).sum()) for k in (1, 2)]
            elif ext == "msh":
                got = [sum(len(c.data) for c, p in zip(m.cells, m.cell_data["gmsh:physical"]) if (p == k).all())
                       for k in (1, 2)]
            elif ext == "exo":  # one element block per region, in label order
                got = [len(c.data) for c in m.cells]
            else:  # .inp: an ELSET per region
                got = [sum(len(x) for x in m.cell_sets["REGION%d" % k]) for k in (1, 2)]
            self.assertEqual(got, want, ext)

    def test_region_files_hold_each_regions_hexes(self):
        outer = self.write("outer.stl", models.uv_sphere(48, 24, 1.0))
        inner = self.write("inner.stl", models.uv_sphere(48, 24, 0.5))
        path, rep = self.mesh([outer, inner], 2, "--region-files", out="parts.vtu")
        whole = meshio.read(path)
        labels, hexes = whole.cell_data["region"][0], whole.cells_dict["hexahedron"]
        files = rep["outputs"]["regions"]
        self.assertEqual([os.path.basename(f) for f in files], ["parts.region1.vtu", "parts.region2.vtu"])
        for k, f in enumerate(files, start=1):
            part = meshio.read(f)
            self.assertEqual(set(part.cell_data["region"][0].tolist()), {k})
            # The same hexes, corner for corner, over renumbered points.
            got = sorted(tuple(map(tuple, part.points[h])) for h in part.cells_dict["hexahedron"])
            want = sorted(tuple(map(tuple, whole.points[h])) for h in hexes[labels == k])
            self.assertEqual(got, want)
            self.assertEqual(len(part.points), len(np.unique(hexes[labels == k])))

    def test_one_file_of_shells_meshes_as_its_files_would(self):
        # The inner ball first in the file: regions follow the file's order of shells.
        inner, outer = models.uv_sphere(48, 24, 0.5), models.uv_sphere(48, 24, 1.0)
        both = self.write("both.stl", models.merge(inner, outer))
        files = [self.write("inner.stl", inner), self.write("outer.stl", outer)]
        _, split = self.mesh([both], 2, "--shells-as-regions")
        _, apart = self.mesh(files, 2)
        self.assert_valid(split)
        got, want = split["regions"]["regions"], apart["regions"]["regions"]
        self.assertEqual([r["name"] for r in got], ["both.stl shell 1", "both.stl shell 2"])
        self.assertEqual([r["hexes"] for r in got], [r["hexes"] for r in want])
        for g, w in zip(got, want):
            self.assertAlmostEqual(g["volume"], w["volume"], delta=1e-12 * w["volume"])
        self.assertEqual(split["regions"]["priority"], [1, 2])

    def test_bad_region_inputs_get_one_line(self):
        outer = self.write("outer.stl", models.uv_sphere(24, 12, 1.0))
        inner = self.write("inner.stl", models.uv_sphere(24, 12, 0.5))
        v, t = models.uv_sphere(24, 12, 0.3, (3, 0, 0))
        open_shell = self.write("open.stl", (v, t[: len(t) // 2]))
        out = os.path.join(self.dir, "x.vtu")
        for args, says in (
            ([outer, "--region-order", "1"], "--region-order"),
            ([outer, "--region-files"], "--region-files"),
            ([outer, "--shells-as-regions"], "one shell"),
            ([outer, inner, "--shells-as-regions"], "--shells-as-regions"),
            ([outer, inner, "--region-order", "1,1"], "--region-order"),
            ([outer, inner, "--region-order", "1,3"], "--region-order"),
            ([outer, inner, "--region-order", "2"], "--region-order"),
            ([outer, open_shell], "open.stl"),
        ):
            r = run("mesh", *args, "--depth", 1, "-o", out, "--quiet")
            self.assertNotEqual(r.returncode, 0, args)
            lines = r.stderr.strip().splitlines()
            self.assertEqual(len(lines), 1, r.stderr)
            self.assertIn(says, lines[0])
            self.assertFalse(os.path.exists(out))
            self.assertFalse(os.path.exists(os.path.join(self.dir, "outside.vtu")))


if __name__ == "__main__":
    unittest.main()
