"""The mchex-gpu command line as a user runs it: real files, real exit codes, one-line errors,
no partial output. Run by ctest with MCHEX_GPU pointing at the binary."""
import json
import os
import struct
import subprocess
import unittest

import meshio
import numpy as np

from harness import EXE, ScratchTestCase, run





def write_cube_stl(path, size=1.0):
    """A closed, outward-oriented cube as ascii STL."""
    v = [(x * size, y * size, z * size) for z in (0, 1) for y in (0, 1) for x in (0, 1)]
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    with open(path, "w") as f:
        f.write("solid cube\n")
        for a, b, c, d in quads:
            for tri in ((a, b, c), (a, c, d)):
                f.write(" facet normal 0 0 0\n  outer loop\n")
                for i in tri:
                    f.write("   vertex %r %r %r\n" % v[i])
                f.write("  endloop\n endfacet\n")
        f.write("endsolid cube\n")


class MeshCommand(ScratchTestCase):

    def test_default_input_writes_both_meshes_and_a_summary(self):
        r = run("mesh", cwd=self.dir)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("inside", r.stdout)
        for name in ("inside.mesh", "outside.mesh"):
            m = meshio.read(os.path.join(self.dir, name))
            self.assertGreater(len(m.cells_dict["hexahedron"]), 0)

    def test_ro_meshes_of_a_shape_fill_the_box_and_pass_check(self):
        inside, outside, report = (os.path.join(self.dir, n) for n in ("in.vtu", "out.msh", "r.json"))
        r = run("mesh", "--shape", "sphere", "--depth", 3, "--method", "ro", "-o", inside, "--outside", outside,
                "--report", report, "--fidelity", "--quiet")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(r.stdout, "")
        rep = json.load(open(report))
        n = 27
        self.assertEqual(rep["grid"]["cells"], n ** 3)
        self.assertEqual(rep["elements"]["inside_hexes"] + rep["elements"]["outside_hexes"], n ** 3)
        for key in ("input", "grid", "elements", "check", "times", "peak_memory_bytes", "backend", "fidelity"):
            self.assertIn(key, rep)
        self.assertGreater(rep["fidelity"]["iou"], 0.8)
        # Independent reader: the inside cells are exactly the grid cells whose corner sum is positive,
        # for the unit sphere f = 1 - |p|.
        m = meshio.read(inside)
        hexes = m.cells_dict["hexahedron"]
        self.assertEqual(len(hexes), rep["elements"]["inside_hexes"])
        corner_sum = (1 - np.linalg.norm(m.points[hexes], axis=2)).sum(axis=1)
        self.assertTrue(np.all(corner_sum > 0))
        c = run("check", inside, "--outside", outside, "--shape", "sphere", "--json")
        self.assertEqual(c.returncode, 0, c.stderr)
        j = json.loads(c.stdout)
        self.assertIn("check", j)
        self.assertAlmostEqual(j["fidelity"]["iou"], rep["fidelity"]["iou"], delta=0.02)

    def test_surface_file_input(self):
        stl = os.path.join(self.dir, "cube.stl")
        write_cube_stl(stl)
        out = os.path.join(self.dir, "cube.mesh")
        r = run("mesh", stl, "--depth", 2, "-o", out, "--quiet")
        self.assertEqual(r.returncode, 0, r.stderr)
        m = meshio.read(out)
        # The cube fills 1/1.2 of the padded box per axis: at 9 cells per axis, the inside
        # cells are the 7^3 whose centres are inside (corner sums are exact here).
        self.assertGreater(len(m.cells_dict["hexahedron"]), 0)
        self.assertTrue(os.path.exists(os.path.join(self.dir, "outside.mesh")))

    def assert_one_line_error(self, r, *needles, code=1):
        self.assertEqual(r.returncode, code, r.stdout + r.stderr)
        lines = r.stderr.strip().splitlines()
        self.assertEqual(len(lines), 1, r.stderr)
        for n in needles:
            self.assertIn(n, lines[0])

    def assert_no_output(self):
        self.assertEqual(sorted(f for f in os.listdir(self.dir) if not f.startswith("bad")), [])

    def bad(self, name, content):
        p = os.path.join(self.dir, name)
        with open(p, "wb") as f:
            f.write(content)
        return p

    def mesh_bad(self, path, *needles):
        r = run("mesh", path, "-o", os.path.join(self.dir, "x.mesh"), "--depth", 1)
        self.assert_one_line_error(r, str(path), *needles)
        self.assert_no_output()

    def test_bad_inputs_give_one_line_and_exit_1(self):
        self.mesh_bad(os.path.join(self.dir, "missing.stl"))
        os.mkdir(os.path.join(self.dir, "bad_dir.stl"))
        self.mesh_bad(os.path.join(self.dir, "bad_dir.stl"))
        self.mesh_bad(self.bad("bad_empty.stl", b""))
        tri = struct.pack("<12fH", *([0.0] * 3 + [0, 0, 0, 1, 0, 0, 0, 1, 0]), 0)
        self.mesh_bad(self.bad("bad_trunc.stl", b"\0" * 80 + struct.pack("<I", 10) + tri * 3))
        self.mesh_bad(self.bad("bad_huge.stl", b"\0" * 80 + struct.pack("<I", 2_000_000_000) + tri))
        self.mesh_bad(self.bad("bad_nan.obj", b"v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n"))
        self.mesh_bad(self.bad("bad_inf.obj", b"v 0 0 0\nv 1 0 0\nv inf 1 0\nf 1 2 3\n"))
        self.mesh_bad(self.bad("bad_index.off", b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"))
        self.mesh_bad(self.bad("bad_index.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"))
        rng = np.random.default_rng(5)
        for ext in ("stl", "obj", "off", "ply"):
            self.mesh_bad(self.bad("bad_random." + ext, rng.bytes(4096)))

    def test_bad_usage(self):
        self.assert_one_line_error(run("mesh", "--shape", "cube"), "cube")
        self.assert_one_line_error(run("mesh", "--depth", "9"), "depth")
        self.assert_one_line_error(run("mesh", "-o", os.path.join(self.dir, "x.xyz")), "x.xyz")
        self.assert_one_line_error(run("frobnicate"))
        self.assert_one_line_error(run("check", os.path.join(self.dir, "none.mesh")), "none.mesh")
        self.assert_one_line_error(run("mesh", "-o", os.path.join(self.dir, "no", "such", "dir.mesh"), "--depth", 1),
                                   "dir.mesh")
        self.assert_no_output()

    def test_a_grid_beyond_memory_is_refused_up_front_with_exit_2(self):
        r = run("mesh", "--depth", 6, "-o", os.path.join(self.dir, "big.vtu"))
        self.assert_one_line_error(r, "depth 6", "GiB", code=2)
        self.assert_no_output()

    def test_check_rejects_a_broken_mesh(self):
        # Two hexes that are the same element: a face shared by... they overlap entirely.
        p = os.path.join(self.dir, "dup.mesh")
        pts = "".join(f"{x} {y} {z} 0\n" for z in (0, 1) for y in (0, 1) for x in (0, 1))
        hexes = "1 2 4 3 5 6 8 7 1\n" * 3
        with open(p, "w") as f:
            f.write(f"MeshVersionFormatted 2\nDimension 3\nVertices\n8\n{pts}Hexahedra\n3\n{hexes}End\n")
        r = run("check", p)
        self.assertNotEqual(r.returncode, 0)
        self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)

    def test_help_on_every_subcommand(self):
        for sub in ("mesh", "check"):
            r = run(sub, "--help")
            self.assertEqual(r.returncode, 0)
            self.assertIn("--", r.stdout)


class HeapTunables(ScratchTestCase):
    """The command line restarts itself with glibc's heap tunables for huge pages
    (host/cli/huge_pages.h); a user's own glibc.malloc.hugetlb choice stands, other tunables are
    kept, and the mesh is the same bytes either way."""

    def mesh(self, name, tunables):
        env = {k: v for k, v in os.environ.items() if k != "GLIBC_TUNABLES"}
        if tunables is not None:
            env["GLIBC_TUNABLES"] = tunables
        out, rep = (os.path.join(self.dir, f"{name}.{x}") for x in ("meshb", "json"))
        r = subprocess.run([EXE, "mesh", "--shape", "torus", "--depth", "2", "-o", out, "--report", rep, "--quiet"],
                           capture_output=True, text=True, stdin=subprocess.DEVNULL, env=env, timeout=600)
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(rep) as f, open(out, "rb") as m:
            return json.load(f)["heap_tunables"], m.read()

    def test_restart_sets_the_heap_up_and_respects_the_users_choice(self):
        with open("/sys/kernel/mm/transparent_hugepage/enabled") as f:
            modes = f.read()
        usable = "[always]" in modes or "[madvise]" in modes
        ours = ("glibc.malloc.hugetlb=1:glibc.malloc.mmap_threshold=4194304:glibc.malloc.top_pad=8388608:"
                "glibc.malloc.trim_threshold=1073741824")
        plain, plain_bytes = self.mesh("plain", None)
        self.assertEqual(plain, ours if usable else None)
        kept, kept_bytes = self.mesh("kept", "glibc.malloc.hugetlb=0")
        self.assertEqual(kept, "glibc.malloc.hugetlb=0")
        added, added_bytes = self.mesh("added", "glibc.malloc.arena_max=2")
        self.assertEqual(added, "glibc.malloc.arena_max=2:" + ours if usable else "glibc.malloc.arena_max=2")
        self.assertEqual(plain_bytes, kept_bytes)
        self.assertEqual(plain_bytes, added_bytes)


if __name__ == "__main__":
    unittest.main()
