"""The C++ of core/, host/, tests/, perf/ and examples/ stays as .clang-format lays it out (clang-format 14,
Debian's clang-format package): a file that drifts fails here with its name, so the one
formatting commit stays the only one. kernels/ and shaders/ are OpenCL C and GLSL, not formatted."""
import pathlib
import shutil
import subprocess
import unittest

ROOT = pathlib.Path(__file__).resolve().parent.parent
CLANG_FORMAT = shutil.which("clang-format-14") or shutil.which("clang-format")


def cpp_files():
    for top in ("core", "host", "tests", "perf", "examples"):
        for path in sorted((ROOT / top).rglob("*")):
            if path.suffix in (".h", ".cpp") and "data" not in path.relative_to(ROOT).parts:
                yield path


@unittest.skipUnless(CLANG_FORMAT, "clang-format is not installed (setup.sh installs it)")
class FormatTest(unittest.TestCase):
    def test_every_file_is_formatted(self):
        files = [str(p) for p in cpp_files()]
        self.assertGreater(len(files), 100)
        r = subprocess.run([CLANG_FORMAT, "--dry-run", "--Werror", "--style=file", *files],
                           capture_output=True, text=True, cwd=ROOT)
        drifted = sorted({line.split(":")[0] for line in r.stderr.splitlines() if ": error:" in line})
        self.assertEqual(r.returncode, 0, "not formatted: " + ", ".join(drifted) + "\n" + r.stderr[:2000])

    def test_a_drifted_file_is_caught(self):
        sample = ROOT / "core/base/error.h"
        text = sample.read_text().replace("namespace mchex {", "namespace mchex {\n\n\n\n", 1)
        r = subprocess.run([CLANG_FORMAT, "--dry-run", "--Werror", "--style=file",
                            "--assume-filename=" + str(sample)], input=text, capture_output=True, text=True,
                           cwd=ROOT)
        self.assertNotEqual(r.returncode, 0)


if __name__ == "__main__":
    unittest.main()
