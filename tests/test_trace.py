"""mesh --trace: the Chrome trace-event timeline of the stages and of every backend's kernel
dispatches, uploads and downloads (docs/trace.md), and the report's stages summing to its wall
time. The references are outside the code under test: the process's own wall time measured here,
the grid's point count from the grid's size, and the trace-event format's rules."""
import collections
import json
import os
import time

from harness import ScratchTestCase, run

US = 1e-6  # the trace's unit, in seconds


def built_backends():
    devices = json.loads(run("devices", "--json").stdout)
    return [d["backend"] for d in devices if d.get("usable", True) and "not built" not in d["note"]]


class Trace(ScratchTestCase):

    def mesh_traced(self, backend):
        trace, report = os.path.join(self.dir, "t.json"), os.path.join(self.dir, "r.json")
        t0 = time.monotonic()
        r = run("mesh", "--shape", "sphere", "--depth", 2, "--backend", backend, "--trace", trace, "--report", report,
                "-o", os.path.join(self.dir, "in.mesh"), "-q")
        elapsed = time.monotonic() - t0
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(trace) as f:
            t = json.load(f)
        with open(report) as f:
            rep = json.load(f)
        return t, rep, elapsed

    def assert_trace_format(self, t):
        self.assertIsInstance(t["traceEvents"], list)
        pids = set()
        for e in t["traceEvents"]:
            self.assertIn(e["ph"], ("X", "M"), e)
            pids.add(e["pid"])
            if e["ph"] != "X":
                continue
            for key, kind in (("name", str), ("cat", str), ("ts", (int, float)), ("dur", (int, float)),
                              ("tid", int), ("args", dict)):
                self.assertIsInstance(e[key], kind, e)
            self.assertGreaterEqual(e["ts"], 0, e)
            self.assertGreaterEqual(e["dur"], 0, e)
        self.assertEqual(len(pids), 1)

    def check_backend(self, backend):
        t, rep, elapsed = self.mesh_traced(backend)
        self.assert_trace_format(t)
        events = [e for e in t["traceEvents"] if e["ph"] == "X"]
        whole = [e for e in events if e["cat"] == "run"]
        self.assertEqual([e["name"] for e in whole], ["mesh"])
        whole = whole[0]
        end = lambda e: e["ts"] + e["dur"]
        eps = 2.0  # microseconds: rounding of the printed numbers
        for e in events:
            self.assertGreaterEqual(e["ts"], whole["ts"] - eps, e)
            self.assertLessEqual(end(e), end(whole) + eps, e)

        # Report: the stages and "other" sum to the total, which is within the process's wall time.
        times = rep["times"]
        stages = {k: v for k, v in times.items() if k != "total"}
        self.assertIn("other", stages)
        self.assertAlmostEqual(sum(stages.values()), times["total"], delta=1e-9 * len(stages))
        self.assertLessEqual(times["total"], whole["dur"] * US + 1e-6)
        self.assertLessEqual(whole["dur"] * US, elapsed)

        # Every stage of the report is on the timeline with the same seconds (summed over its runs);
        # the stage events follow one another without overlap or gap ("other" fills the gaps).
        stage_events = sorted((e for e in events if e["cat"] == "stage"), key=lambda e: e["ts"])
        per_stage = collections.defaultdict(float)
        for e in stage_events:
            per_stage[e["name"]] += e["dur"] * US
        self.assertEqual(set(per_stage), set(stages) if stages["other"] > 0 else set(stages) - {"other"})
        for name, seconds in stages.items():
            self.assertAlmostEqual(per_stage[name], seconds, delta=2e-6 * sum(e["name"] == name for e in stage_events)
                                   + 1e-9, msg=name)
        for a, b in zip(stage_events, stage_events[1:]):
            self.assertAlmostEqual(b["ts"], end(a), delta=eps, msg=(a, b))
        self.assertAlmostEqual(end(stage_events[-1]) - stage_events[0]["ts"], times["total"] / US,
                               delta=eps * len(stage_events))

        device = [e for e in events if e["cat"] in ("dispatch", "upload", "download")]
        for e in device:  # each inside one stage
            self.assertTrue(any(s["ts"] - eps <= e["ts"] and end(e) <= end(s) + eps for s in stage_events), e)
            self.assertEqual(e["args"]["backend"], backend, e)
        if backend == "cpu":
            return
        cats = collections.Counter(e["cat"] for e in device)
        for cat in ("dispatch", "upload", "download"):
            self.assertGreater(cats[cat], 0, cat)
        for e in device:
            self.assertGreater(e["args"]["work_items" if e["cat"] == "dispatch" else "bytes"], 0, e)
        # The SDF batch of a uniform grid: every grid point up (3 doubles) and its value down.
        sdf = next(s for s in stage_events if s["name"] == "sdf")
        inside_sdf = [e for e in device if sdf["ts"] - eps <= e["ts"] and end(e) <= end(sdf) + eps]
        points = (rep["grid"]["cells_per_axis"] + 1) ** 3
        self.assertEqual(sum(e["args"]["bytes"] for e in inside_sdf if e["cat"] == "upload"), 24 * points)
        self.assertEqual(sum(e["args"]["bytes"] for e in inside_sdf if e["cat"] == "download"), 8 * points)
        self.assertGreaterEqual(sum(e["args"]["work_items"] for e in inside_sdf if e["cat"] == "dispatch"), points)

    def test_every_built_backend(self):
        backends = built_backends()
        self.assertIn("cpu", backends)
        for backend in backends:
            with self.subTest(backend=backend):
                self.check_backend(backend)

    def test_a_bad_trace_path_is_one_line_and_writes_nothing(self):
        for path in (os.path.join(self.dir, "no-such-folder", "t.json"), self.dir):
            with self.subTest(path=path):
                r = run("mesh", "--shape", "sphere", "--depth", 1, "--trace", path,
                        "-o", os.path.join(self.dir, "in.mesh"))
                self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
                lines = r.stderr.strip().splitlines()
                self.assertEqual(len(lines), 1, r.stderr)
                self.assertIn(path, lines[0])
                self.assertEqual(os.listdir(self.dir), [])

    def test_no_trace_without_the_option(self):
        r = run("mesh", "--shape", "sphere", "--depth", 1, "-o", os.path.join(self.dir, "in.mesh"), "-q")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(sorted(os.listdir(self.dir)), ["in.mesh", "outside.mesh"])


if __name__ == "__main__":
    import unittest
    unittest.main()
