"""PENDING: rename to tests/test_vulkan_cli.py once host/cli/main.cpp has `devices` and `--backend vulkan`
(the opencl engineer adds them); until then ctest would fail on the missing options.

`mchex-gpu` with `--backend vulkan` on Mesa lavapipe, selected explicitly (its ICD alone, the
device by name; no lavapipe means these tests fail, never skip): `devices` lists it with its limits,
and `mesh` writes the same bytes as `--backend cpu` on an analytic shape and on triangle models.
Only a binary built without the vulkan backend (-DMCHEX_WITH_VULKAN=OFF) skips them, with that reason."""
import filecmp
import glob
import json
import os
import subprocess
import unittest

from harness import EXE, STL_MODELS, ScratchTestCase
from models import bumpy_torus, write_binary_stl

LAVAPIPE_ICDS = sorted(glob.glob("/usr/share/vulkan/icd.d/lvp_icd.*.json"))


def not_built(backend):
    """Why `backend` is not in this binary (CMake MCHEX_WITH_<BACKEND>=OFF: `devices --json` says
    so in the backend's one entry), or None when it is built."""
    r = subprocess.run([EXE, "devices", "--json"], capture_output=True, text=True, timeout=300,
                       stdin=subprocess.DEVNULL)
    if r.returncode != 0:
        return None  # the tests then fail on the same command, with its message
    for d in json.loads(r.stdout):
        if d["backend"] == backend and "not built" in d["note"]:
            return f"mchex-gpu: {backend} {d['note']}"
    return None


VULKAN_NOT_BUILT = not_built("vulkan")


@unittest.skipIf(VULKAN_NOT_BUILT, VULKAN_NOT_BUILT)
class VulkanCli(ScratchTestCase):

    def setUp(self):
        super().setUp()
        self.assertTrue(LAVAPIPE_ICDS, "lavapipe's ICD is missing: setup.sh installs mesa-vulkan-drivers")
        self.env = dict(os.environ, VK_DRIVER_FILES=LAVAPIPE_ICDS[0], VK_ICD_FILENAMES=LAVAPIPE_ICDS[0],
                        MCHEX_VULKAN_DEVICE="llvmpipe", XDG_CACHE_HOME=os.path.join(self.dir, "cache"),
                        MESA_SHADER_CACHE_DIR=os.path.join(self.dir, "mesa"))

    def run_cli(self, *args, env=None):
        return subprocess.run([EXE, *map(str, args)], capture_output=True, text=True, timeout=900,
                              stdin=subprocess.DEVNULL, env=env or self.env)

    def mesh_both(self, *source, vulkan_env=None, precision="fp64"):
        """vulkan_env: the vulkan run's environment; precision: what its report must say it ran."""
        outputs = {}
        for backend in ("cpu", "vulkan"):
            inside, outside = (os.path.join(self.dir, f"{backend}-{n}.mesh") for n in ("in", "out"))
            report = os.path.join(self.dir, f"{backend}.json")
            r = self.run_cli("mesh", *source, "--method", "mchex", "--backend", backend, "-o", inside,
                             "--outside", outside, "--report", report, "--quiet",
                             env=vulkan_env if backend == "vulkan" else None)
            self.assertEqual(r.returncode, 0, f"{backend}: {r.stderr}")
            with open(report) as f:
                b = json.load(f)["backend"]
            self.assertEqual(b["precision"], "fp64" if backend == "cpu" else precision)
            if backend == "vulkan" and precision == "fp64":
                # lavapipe's surface SDF: one walk per invocation over texel buffers, under the loop budget.
                self.assertIn("one walk per invocation", b["kernels"])
                self.assertIn("texel buffers", b["kernels"])
                self.assertIn("loop budget", b["kernels"])
            outputs[backend] = (inside, outside)
        for a, b in zip(outputs["cpu"], outputs["vulkan"]):
            self.assertGreater(os.path.getsize(a), 1000)
            self.assertTrue(filecmp.cmp(a, b, shallow=False), f"{a} and {b} differ")

    def test_devices_lists_lavapipe_with_fp64_and_limits(self):
        r = self.run_cli("devices")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("llvmpipe", r.stdout)
        self.assertIn("vulkan", r.stdout)

    def test_shape_mesh_equals_cpu_byte_for_byte(self):
        self.mesh_both("--shape", "two-holed", "--depth", 3)

    def test_model_meshes_equal_cpu_byte_for_byte(self):
        stl = os.path.join(self.dir, "bumpy.stl")
        write_binary_stl(stl, *bumpy_torus(96, 40))
        self.mesh_both(stl, "--depth", 3)
        self.mesh_both(os.path.join(STL_MODELS, "objects", "bunny.bin.stl"), "--depth", 3)

    def test_exact_crossings_equal_cpu_byte_for_byte(self):
        # The crossings' search runs the field on the device: the same points as on the cpu.
        self.mesh_both(os.path.join(STL_MODELS, "objects", "gearwheel.bin.stl"), "--depth", 3, "--crossings", "exact")

    def test_fp32_path_meshes_equal_cpu_byte_for_byte(self):
        # MCHEX_FORCE_FP32=1: the surface SDF from the device's float candidates with the values
        # computed on the host in double (host/backends/fp32_path.h), the other stages on the host.
        env = dict(self.env, MCHEX_FORCE_FP32="1")
        stl = os.path.join(self.dir, "bumpy.stl")
        write_binary_stl(stl, *bumpy_torus(96, 40))
        self.mesh_both(stl, "--depth", 3, vulkan_env=env, precision="fp32")
        self.mesh_both(os.path.join(STL_MODELS, "objects", "gearwheel.bin.stl"), "--depth", 3, vulkan_env=env,
                       precision="fp32")
        self.mesh_both("--shape", "two-holed", "--depth", 3, vulkan_env=env, precision="fp32")

    def test_devices_shows_the_precision_each_device_would_get(self):
        for force, want in (("0", "fp64"), ("1", "fp32")):
            r = self.run_cli("devices", "--json", env=dict(self.env, MCHEX_FORCE_FP32=force))
            self.assertEqual(r.returncode, 0, r.stderr)
            lavapipe = [d for d in json.loads(r.stdout) if d["backend"] == "vulkan" and "llvmpipe" in d["device"]]
            self.assertEqual(len(lavapipe), 1, r.stdout)
            self.assertEqual(lavapipe[0]["precision"], want)
            self.assertTrue(lavapipe[0]["usable"])

    def test_absent_vulkan_device_is_one_line_exit_1(self):
        env = dict(self.env, VK_DRIVER_FILES=os.path.join(self.dir, "none.json"),
                   VK_ICD_FILENAMES=os.path.join(self.dir, "none.json"))
        r = self.run_cli("mesh", "--shape", "sphere", "--depth", 2, "--backend", "vulkan",
                         "-o", os.path.join(self.dir, "x.mesh"), env=env)
        self.assertEqual(r.returncode, 1, r.stderr)
        self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
        self.assertIn("vulkan", r.stderr)
        self.assertFalse(os.path.exists(os.path.join(self.dir, "x.mesh")))


if __name__ == "__main__":
    unittest.main()
