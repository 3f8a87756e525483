"""The include-direction check (tests/check_layers.py) on the real tree, and on copies of it with
a deliberate upward include, a file outside any stage folder and an include of host/ from core/,
each of which it must refuse."""
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import unittest

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent
LAYERS = os.environ.get("MCHEX_LAYERS")
CHECK = [sys.executable, str(HERE / "check_layers.py")]


@unittest.skipUnless(LAYERS, "run through ctest (MCHEX_LAYERS names the build's layers.txt)")
class LayersTest(unittest.TestCase):
    def run_check(self, root):
        return subprocess.run(CHECK + [LAYERS, str(root)], capture_output=True, text=True)

    def copy_tree(self):
        tmp = pathlib.Path(tempfile.mkdtemp())
        self.addCleanup(shutil.rmtree, tmp)
        for top in ("core", "host"):
            shutil.copytree(ROOT / top, tmp / top)
        return tmp

    def test_the_tree_keeps_the_direction(self):
        r = self.run_check(ROOT)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)

    def test_every_stage_of_the_build_is_a_folder(self):
        for line in pathlib.Path(LAYERS).read_text().splitlines():
            folder = line.partition(":")[0]
            self.assertTrue((ROOT / folder).is_dir(), folder)

    def expect_refused(self, root, *needles):
        r = self.run_check(root)
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        for n in needles:
            self.assertIn(n, r.stdout)

    def test_an_upward_include_fails(self):
        tmp = self.copy_tree()
        surface = tmp / "core/mesh/surface.h"
        surface.write_text(surface.read_text().replace('#include "core/base/geometry.h"',
                                                       '#include "core/base/geometry.h"\n#include "core/cutting/mc33.h"'))
        self.expect_refused(tmp, "core/mesh/surface.h:", "core/cutting/mc33.h", "core/cutting is not below core/mesh")

    def test_a_sibling_stage_include_fails(self):
        # io and sdf are peers: neither builds on the other.
        tmp = self.copy_tree()
        (tmp / "core/io/peer.cpp").write_text('#include "core/sdf/sdf.h"\n')
        self.expect_refused(tmp, "core/io/peer.cpp:1:", "core/sdf is not below core/io")

    def test_core_including_host_fails(self):
        tmp = self.copy_tree()
        (tmp / "core/device/up.cpp").write_text('// why\n#include "host/backends/registry.h"\n')
        self.expect_refused(tmp, "core/device/up.cpp:2:", "host/backends is not below core/device")

    def test_a_file_outside_the_stages_fails(self):
        tmp = self.copy_tree()
        (tmp / "core/loose.h").write_text("#pragma once\n")
        self.expect_refused(tmp, "core/loose.h: not in a stage folder")


if __name__ == "__main__":
    unittest.main()
