"""Real-world geometry end to end (issue 16 item 3): what downloaded models have and a clean model
has not. Each variant is judged against the clean surface it was made from: coincident vertices
(an unwelded OBJ) and zero-area and duplicated faces (added to a closed sphere) mesh to the clean
sphere's meshes byte for byte; a sheet thinner than a cell meshes to valid, certified, conforming
meshes with an empty inside and a warning, and on finer cells to one slab. (Grid points exactly on the surface: the zero rule's unit tests, test_mchex_mesher's plane
through grid vertices and test_backends' zero-rule cases; scale 1e-9 .. 1e9: test_sign.py; OFF
comments and colours: test_off.cpp.)"""
import json
import os
import unittest

import numpy as np

import models
from harness import ScratchTestCase, run


def write_obj(path, verts, tris):
    with open(path, "w") as f:
        for v in verts:
            f.write("v {:.17g} {:.17g} {:.17g}\n".format(*v))
        for t in tris:
            f.write("f {} {} {}\n".format(*(t + 1)))


class RealWorld(ScratchTestCase):
    def mesh(self, surface, name, *extra):
        inside = os.path.join(self.dir, name + "_in.vtu")
        outside = os.path.join(self.dir, name + "_out.vtu")
        report = os.path.join(self.dir, name + ".json")
        depth = () if "--depth" in extra else ("--depth", 3)
        r = run("mesh", surface, *depth, "-o", inside, "--outside", outside, "--report", report, "--quiet", *extra)
        self.assertEqual(r.returncode, 0, r.stderr)
        c = run("check", inside, "--outside", outside, "--json")
        self.assertEqual(c.returncode, 0, c.stdout[-2000:] + c.stderr)
        with open(inside, "rb") as a, open(outside, "rb") as b, open(report) as j:
            return a.read(), b.read(), json.load(j), json.loads(c.stdout)

    def clean_sphere(self):
        v, t = models.uv_sphere(24, 12)
        # Coordinates a float32 STL and a %.17g OBJ hold alike, so every variant reads the same points.
        return v.astype(np.float32).astype(np.float64), t

    def test_coincident_vertices_are_welded(self):
        v, t = self.clean_sphere()
        welded = os.path.join(self.dir, "welded.obj")
        write_obj(welded, v, t)
        # Every triangle with its own three copies of its corners: a "soup" of coincident vertices.
        loose = os.path.join(self.dir, "loose.obj")
        write_obj(loose, v[t.reshape(-1)], np.arange(3 * len(t)).reshape(-1, 3))
        a, b = self.mesh(welded, "welded"), self.mesh(loose, "loose")
        self.assertEqual(a[0], b[0])
        self.assertEqual(a[1], b[1])
        self.assertGreater(b[2]["input"]["welded_vertices"], 0)

    def test_zero_area_and_duplicated_faces_change_nothing(self):
        v, t = self.clean_sphere()
        clean = os.path.join(self.dir, "clean.obj")
        write_obj(clean, v, t)
        # Zero-area faces (a repeated corner; three collinear points on one edge), exact duplicates
        # of faces in both orders of their corners, at the end and in between.
        mid = len(v)
        a0, b0 = v[t[0, 0]], v[t[0, 1]]
        v2 = np.vstack([v, (a0 + b0) / 2])
        extra = np.array([[t[5, 0], t[5, 0], t[5, 1]], [t[0, 0], mid, t[0, 1]], t[7], t[9][[1, 2, 0]]])
        dirty = os.path.join(self.dir, "dirty.obj")
        write_obj(dirty, v2, np.vstack([t[:40], extra, t[40:], t[100:103]]))
        a, b = self.mesh(clean, "clean"), self.mesh(dirty, "dirty")
        self.assertEqual(a[0], b[0])
        self.assertEqual(a[1], b[1])
        repair = b[2]["input"]["repair"]
        self.assertGreater(repair["duplicate_faces_removed"], 0)

    def write_sheet(self, thickness):
        """A closed, outward slab 2 x 2 x thickness about the origin."""
        h = thickness / 2
        corners = np.array([[sx, sy, sz] for sz in (-h, h) for sy in (-1.0, 1.0) for sx in (-1.0, 1.0)])
        quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]]
        tris = np.array([[q[0], q[1], q[2]] for q in quads] + [[q[0], q[2], q[3]] for q in quads])
        self.assertGreater(models.signed_volume(corners, tris), 0)
        stl = os.path.join(self.dir, "sheet.stl")
        models.write_binary_stl(stl, corners, tris)
        return stl

    def test_a_sheet_thinner_than_a_cell_is_a_valid_empty_solid_with_a_warning(self):
        # 0.06 thick against cells of 2.4 / 27 = 0.089 at depth 3: no grid point lies inside it.
        stl = self.write_sheet(0.06)
        _, _, rep, chk = self.mesh(stl, "sheet")
        self.assertTrue(rep["input"]["closed"])
        self.assertTrue(chk["check"]["ok"])
        self.assertEqual(chk["check"]["inside"]["hexes"], 0)
        q = chk["check"]["outside"]
        self.assertEqual(q["quality"]["certified"], q["hexes"])
        self.assertTrue(q["boundary"]["closed_manifold"])
        # The user is told, on stderr, and what would keep it.
        r = run("mesh", stl, "--depth", 3, "-o", os.path.join(self.dir, "loud.vtu"))
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("warning: the inside mesh is empty", r.stderr)
        self.assertIn("a finer --depth keeps it", r.stderr)

    def test_the_same_sheet_on_cells_thinner_than_it_is_a_slab(self):
        # Depth 4: cells of 0.030 < 0.06, so the sheet is meshed: one slab, a sphere topologically.
        stl = self.write_sheet(0.06)
        _, _, rep, chk = self.mesh(stl, "sheet4", "--depth", 4)
        inside = chk["check"]["inside"]
        self.assertGreater(inside["hexes"], 0)
        self.assertEqual(inside["quality"]["certified"], inside["hexes"])
        self.assertTrue(inside["boundary"]["closed_manifold"])
        self.assertEqual(inside["boundary"]["components"], 1)
        self.assertEqual(inside["boundary"]["euler_characteristic"], 2)
        # Its volume is the slab's to within the cells that straddle its two faces.
        self.assertAlmostEqual(inside["quality"]["volume"], 4 * 0.06, delta=4 * 2 * 0.030)


if __name__ == "__main__":
    unittest.main()
