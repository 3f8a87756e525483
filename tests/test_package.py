"""The installed C++ package (cmake/install.cmake, docs/package.md): `cmake --install` of this build
into a fresh prefix, then examples/find_package, copied outside the source tree, configured against
that prefix alone with find_package(mchex), built and run. Its hex counts are checked against the
installed command line program's report on the same shape and depth, and its mesh file against
meshio as a second reader. The compile commands show the example saw the installed headers, not
the source tree. Needs MCHEX_BUILD_DIR and the build's compiler (tests/CMakeLists.txt sets them)."""
import json
import os
import pathlib
import re
import shutil
import subprocess
import tempfile
import unittest

import meshio

ROOT = pathlib.Path(__file__).resolve().parent.parent
BUILD = pathlib.Path(os.environ["MCHEX_BUILD_DIR"])
SHAPE, DEPTH = "sphere", 2  # small: the example's build, not the meshing, is what is tested


def run(args, **kw):
    return subprocess.run([str(a) for a in args], capture_output=True, text=True, stdin=subprocess.DEVNULL,
                          timeout=600, **kw)


class PackageTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        top = pathlib.Path(cls.tmp.name)
        cls.prefix = top / "prefix"
        cls.example = top / "example"
        cls.build = top / "example-build"
        shutil.copytree(ROOT / "examples" / "find_package", cls.example)

        def step(args):
            r = run(args)
            if r.returncode != 0:
                raise AssertionError(f"{' '.join(map(str, args))} failed:\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}")
            return r

        step(["cmake", "--install", BUILD, "--prefix", cls.prefix])
        step(["cmake", "-S", cls.example, "-B", cls.build, "-G", os.environ["MCHEX_GENERATOR"],
              "-DCMAKE_CXX_COMPILER=" + os.environ["MCHEX_CXX"],
              "-DCMAKE_BUILD_TYPE=" + os.environ.get("MCHEX_BUILD_TYPE", "Release"),
              "-DCMAKE_PREFIX_PATH=" + str(cls.prefix), "-DCMAKE_EXPORT_COMPILE_COMMANDS=ON"])
        step(["cmake", "--build", cls.build])
        cls.mesh = top / "inside.vtu"
        cls.result = run([cls.build / "mesh_shape", SHAPE, DEPTH, cls.mesh])

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_install_holds_library_headers_and_package(self):
        package = next(self.prefix.glob("lib*/cmake/mchex"))
        for name in ("mchexConfig.cmake", "mchexConfigVersion.cmake", "mchexTargets.cmake"):
            self.assertTrue((package / name).is_file(), name)
        for header in ("core/pipeline/pipeline.h", "core/mesh/hex_mesh.h", "core/check/mesh_check.h",
                       "core/io/mesh_io.h", "core/sdf/shapes.h", "host/backends/registry.h"):
            self.assertTrue((self.prefix / "include/mchex" / header).is_file(), header)
        self.assertTrue(any(self.prefix.glob("lib*/libmchex_pipeline.a")))
        # Every header installed is the source's own file, byte for byte.
        for h in (self.prefix / "include/mchex/core").rglob("*.h"):
            rel = h.relative_to(self.prefix / "include/mchex")
            self.assertEqual(h.read_bytes(), (ROOT / rel).read_bytes(), rel)

    def test_example_compiles_against_the_installed_headers(self):
        commands = json.loads((self.build / "compile_commands.json").read_text())
        command = next(c["command"] for c in commands if c["file"].endswith("main.cpp"))
        includes = re.findall(r"(?:-I|-isystem )\s*(\S+)", command)
        self.assertIn(str(self.prefix / "include/mchex"), includes)
        for inc in includes:
            self.assertFalse(pathlib.Path(inc).resolve().is_relative_to(ROOT), inc)

    def test_example_meshes_as_the_command_line_does(self):
        self.assertEqual(self.result.returncode, 0, self.result.stderr)
        m = re.fullmatch(r"hexes (\d+) (\d+)\n", self.result.stdout)
        self.assertIsNotNone(m, self.result.stdout)
        inside, outside = int(m.group(1)), int(m.group(2))
        self.assertGreater(inside, 0)
        # The installed CLI on the same solid: the same pipeline, reached through its own front end.
        report = pathlib.Path(self.tmp.name) / "report.json"
        r = run([self.prefix / "bin/mchex-gpu", "mesh", "--shape", SHAPE, "--depth", DEPTH, "--backend", "cpu",
                 "-o", pathlib.Path(self.tmp.name) / "cli.vtu", "--report", report, "--quiet"])
        self.assertEqual(r.returncode, 0, r.stderr)
        check = json.loads(report.read_text())["check"]
        self.assertTrue(check["ok"])
        self.assertEqual((inside, outside), (check["inside"]["hexes"], check["outside"]["hexes"]))
        # The example's file, read by meshio.
        cells = meshio.read(self.mesh).cells_dict
        self.assertEqual(len(cells["hexahedron"]), inside)

    def test_bad_arguments_give_one_line_and_exit_1(self):
        for args in (["cube", DEPTH, self.mesh], [SHAPE, "2x", self.mesh], [SHAPE]):
            r = run([self.build / "mesh_shape", *args])
            self.assertEqual(r.returncode, 1, args)
            self.assertEqual(r.stdout, "")
            self.assertEqual(len(r.stderr.splitlines()), 1, r.stderr)
            self.assertTrue(r.stderr.startswith("mesh_shape: "), r.stderr)


if __name__ == "__main__":
    unittest.main()
