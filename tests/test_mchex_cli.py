"""`mchex-gpu mesh --method mchex` as a user runs it: the torus at depth 3 to .vtu, checked by
`mchex-gpu check --json` and read back with meshio. Run by ctest with MCHEX_GPU pointing at the
binary."""
import json
import os
import unittest

import meshio

from harness import ScratchTestCase, run





class MchexMethod(ScratchTestCase):

    def test_torus_depth3_conforms_and_has_the_torus_topology(self):
        inside, outside, report = (os.path.join(self.dir, n) for n in ("in.vtu", "out.vtu", "r.json"))
        r = run("mesh", "--shape", "torus", "--depth", 3, "--method", "mchex", "-o", inside,
                "--outside", outside, "--report", report, "--quiet")
        self.assertEqual(r.returncode, 0, r.stderr)
        rep = json.load(open(report))
        self.assertEqual(rep["method"], "mchex")
        # The subcase histogram covers every cell (27^3), and names the 31 subcases and "empty".
        self.assertEqual(len(rep["cases"]), 32)
        self.assertEqual(sum(rep["cases"].values()), 27 ** 3)
        self.assertIn("refined_cells", rep["mchex"])

        c = run("check", inside, "--outside", outside, "--json")
        self.assertEqual(c.returncode, 0, c.stderr)
        chk = json.loads(c.stdout)["check"]
        self.assertTrue(chk["ok"])
        boundary = chk["inside"]["boundary"]
        self.assertEqual(boundary["euler_characteristic"], 0)

        meshes = [meshio.read(p) for p in (inside, outside)]
        for m, key in zip(meshes, ("inside_hexes", "outside_hexes")):
            self.assertEqual(len(m.cells_dict["hexahedron"]), rep["elements"][key])

    def test_eps_out_of_range_is_a_usage_error(self):
        r = run("mesh", "--shape", "sphere", "--depth", 1, "--method", "mchex", "--eps", 0.7,
                "-o", os.path.join(self.dir, "in.vtu"), "--quiet")
        self.assertEqual(r.returncode, 1)
        self.assertFalse(os.path.exists(os.path.join(self.dir, "in.vtu")))


if __name__ == "__main__":
    unittest.main()
