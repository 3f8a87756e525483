"""The CMake options MCHEX_WITH_OPENCL and MCHEX_WITH_VULKAN as the command line shows them, in
any build: a backend configured out is one `devices` entry saying it is not built, and
`--backend NAME` on such a binary is one stderr line and exit 1, with no file written; a built
backend has no such entry. `--backend auto` meshes in every build, with the backend that
`devices --auto-choice` names, decided in a child process."""
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

    def test_auto_is_decided_in_a_child_and_the_drivers_stay_out(self):
        # What auto stands for, by the rule of host/backends/registry.h (a GPU with fp64, else cpu),
        # against the device list.
        r = run("devices", "--auto-choice")
        self.assertEqual(r.returncode, 0, r.stderr)
        choice = r.stdout.strip()
        gpus = [d["backend"] for d in self.devices()
                if d["type"] == "gpu" and d["fp64"] and d["usable"] and d["backend"] in ("opencl", "vulkan")]
        self.assertEqual(choice, gpus[0] if gpus else "cpu")
        # A mesh run with auto uses that backend and gives the same bytes as naming it, and (the
        # probe having run in a child) its peak memory is the named backend's: probed in the
        # process, PoCL and lavapipe stayed loaded, 58 MiB over cpu's on the npm bunny's default
        # run and 71 MiB on this small one.
        peaks, files = {}, {}
        for backend in ("auto", choice):
            out, rep = (os.path.join(self.dir, f"{backend}.{x}") for x in ("meshb", "json"))
            r = run("mesh", "--shape", "torus", "--depth", 2, "--backend", backend, "-o", out, "--report", rep,
                    "--quiet")
            self.assertEqual(r.returncode, 0, r.stderr)
            with open(rep) as f:
                report = json.load(f)
            self.assertEqual(report["backend"]["name"], choice)
            peaks[backend] = report["peak_memory_bytes"]
            with open(out, "rb") as f:
                files[backend] = f.read()
        self.assertEqual(files["auto"], files[choice])
        self.assertLess(peaks["auto"], peaks[choice] + 16 * 2**20, peaks)


if __name__ == "__main__":
    unittest.main()
