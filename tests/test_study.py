"""perf/run_study.sh's results: the committed page (perf/README.md) is exactly what perf/study.py
makes from the committed CSVs (perf/results/), every plot it shows is drawn from them, and every
measured row is on the page; bad arguments get one line and a non-zero exit. The study's runs
themselves take tens of minutes and are not repeated here: this redraws them (--plot-only)."""
import csv
import os
import re
import shutil
import subprocess
import sys
import tempfile
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULTS = os.path.join(ROOT, "perf", "results")
STUDY = [sys.executable, os.path.join(ROOT, "perf", "study.py")]


def csv_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


class Study(unittest.TestCase):
    """One redraw (matplotlib's plots take seconds), shared by the tests."""

    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.dir = cls.tmp.name
        out = os.path.join(cls.dir, "results")
        shutil.copytree(RESULTS, out, ignore=shutil.ignore_patterns("*.png"))
        page = os.path.join(cls.dir, "README.md")
        cls.redraw = subprocess.run(STUDY + ["--plot-only", "--out", out, "--page", page], capture_output=True,
                                    text=True)
        cls.text = open(page).read() if os.path.exists(page) else ""

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_the_committed_page_is_the_scripts_own(self):
        self.assertEqual(self.redraw.returncode, 0, self.redraw.stderr)
        with open(os.path.join(ROOT, "perf", "README.md")) as f:
            self.assertEqual(f.read(), self.text, "perf/README.md differs from what perf/study.py makes of perf/results/")
        images = re.findall(r"!\[[^]]*\]\(([^)]+)\)", self.text)
        self.assertGreaterEqual(len(images), 8)
        for rel in images:
            with open(os.path.join(self.dir, rel), "rb") as f:
                self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n", rel)
            # The committed plot exists too (it is what the page shows).
            self.assertTrue(os.path.isfile(os.path.join(ROOT, "perf", rel)), rel)

    def test_every_measured_row_is_on_the_page(self):
        self.assertEqual(self.redraw.returncode, 0, self.redraw.stderr)
        lines = self.text.splitlines()
        # Table rows: "| ..." lines that are neither a separator nor the header above one.
        rows = [line for i, line in enumerate(lines) if line.startswith("| ")
                and not (i + 1 < len(lines) and lines[i + 1].startswith("|---"))]
        names = ("fidelity.csv", "quality.csv", "scaling.csv", "brute_force.csv")
        for name in names:
            self.assertGreater(len(csv_rows(os.path.join(RESULTS, name))), 0, name)
        self.assertEqual(len(rows), sum(len(csv_rows(os.path.join(RESULTS, n))) for n in names))
        # MCHex and RO on the same grids: every setting of one method has the other's.
        fid = csv_rows(os.path.join(RESULTS, "fidelity.csv"))
        by_method = {m: {(r["model"], r["setting"]) for r in fid if r["method"] == m} for m in ("mchex", "ro")}
        self.assertEqual(by_method["mchex"], by_method["ro"])
        self.assertTrue(by_method["mchex"])

    def test_bad_arguments_get_one_line(self):
        with tempfile.TemporaryDirectory() as empty:
            for args in (["--parts", "fidelity,nope"], ["--plot-only", "--out", empty]):
                page = os.path.join(empty, "p.md")
                r = subprocess.run(STUDY + args + ["--page", page], capture_output=True, text=True)
                self.assertNotEqual(r.returncode, 0, args)
                self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
                self.assertFalse(os.path.exists(page))
