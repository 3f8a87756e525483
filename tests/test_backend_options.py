"""The CMake options MCHEX_WITH_OPENCL and MCHEX_WITH_VULKAN as the command line shows them, in
any build: a backend configured out is one `devices` entry saying it is not built, and
`--backend NAME` on such a binary is one stderr line and exit 1, with no file written; a built
backend has no such entry. `--backend auto` meshes in every build."""
import json
import os
import unittest

from harness import ScratchTestCase, run


class BackendOptions(ScratchTestCase):

    def devices(self):
        r = run("devices", "--json")
        self.assertEqual(r.returncode, 0, r.stderr)
        return json.loads(r.stdout)

    def test_a_backend_not_built_says_so_and_exits_1(self):
        devices = self.devices()
        self.assertEqual(devices[0]["backend"], "cpu")
        for backend in ("opencl", "vulkan"):
            entries = [d for d in devices if d["backend"] == backend]
            absent = [d for d in entries if "not built into this binary" in d["note"]]
            out = os.path.join(self.dir, f"{backend}.mesh")
            if not absent:
                continue  # built: its devices (if any) are real ones, tested in test_<backend>*
            self.assertEqual(len(entries), 1, entries)
            self.assertFalse(absent[0]["usable"])
            r = run("mesh", "--shape", "sphere", "--depth", 2, "--backend", backend, "-o", out)
            self.assertEqual(r.returncode, 1, r.stderr)
            lines = r.stderr.strip().splitlines()
            self.assertEqual(len(lines), 1, r.stderr)
            self.assertIn(f"backend '{backend}' is not built into this binary", lines[0])
            self.assertFalse(os.path.exists(out))

    def test_auto_meshes_in_every_build(self):
        out = os.path.join(self.dir, "auto.mesh")
        r = run("mesh", "--shape", "sphere", "--depth", 2, "--backend", "auto", "-o", out, "--quiet")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertGreater(os.path.getsize(out), 1000)


if __name__ == "__main__":
    unittest.main()
