"""What the Python tests share: the CLI under test (MCHEX_GPU, set by ctest), the test data folder,
running the CLI as a user would (no standard input, output captured), and a scratch folder per test."""
import os
import subprocess
import tempfile
import unittest

EXE = os.environ["MCHEX_GPU"]
DATA = os.environ.get("MCHEX_TEST_DATA", os.path.join(os.path.dirname(__file__), "data"))
STL_MODELS = os.path.join(DATA, "npm", "node_modules", "stl-models")


def run(*args, cwd=None, timeout=900):
    return subprocess.run([EXE, *map(str, args)], capture_output=True, text=True, cwd=cwd,
                          stdin=subprocess.DEVNULL, timeout=timeout)


class ScratchTestCase(unittest.TestCase):
    """A test case with a fresh folder, self.dir, removed afterwards."""

    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = self.tmp.name

    def tearDown(self):
        self.tmp.cleanup()
