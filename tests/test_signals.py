"""SIGINT and SIGTERM during `mesh` leave no file behind (core/io/atomic_file.h): a signal while the
SDF, the mesher or the writer runs removes the hidden temporaries and any mesh already moved into
place, and the process dies of the signal (its exit status says which)."""
import os
import signal
import subprocess
import time
import unittest

from harness import EXE, ScratchTestCase

# A run of a few seconds on 2 cores (about 4.4 M output hexes); the lines of the stages that run
# longer than a second ("mchex-gpu: STAGE ...", on stderr) say when to send the signal; "start"
# is a fixed moment early in the run (the grid and its SDF).
ARGS = ["mesh", "--shape", "torus", "--depth", "4", "-o", "inside.vtu", "--report", "report.json"]


class SignalTest(ScratchTestCase):
    def wait_for_stage(self, p, folder, stage):
        seen = []
        for line in p.stderr:
            seen.append(line)
            if line.startswith(f"mchex-gpu: {stage} ..."):
                break
        else:
            self.fail(f"the run ended before stage {stage}: {''.join(seen)}")
        # In the write: while the outside mesh is written, the inside one already in place (both
        # must go).
        while stage == "write" and p.poll() is None and not any(f.startswith(".outside") for f in os.listdir(folder)):
            pass

    def interrupt_at(self, stage, sig):
        folder = os.path.join(self.dir, f"{stage}-{sig}")
        os.mkdir(folder)
        p = subprocess.Popen([EXE, *ARGS], cwd=folder, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE, text=True)
        try:
            if stage == "start":
                time.sleep(0.2)
            else:
                self.wait_for_stage(p, folder, stage)
            p.send_signal(sig)
            p.stderr.read()
            rc = p.wait(timeout=60)
        finally:
            if p.poll() is None:
                p.kill()
                p.wait()
        self.assertEqual(rc, -sig, f"stage {stage}: exit status {rc}")
        self.assertEqual(os.listdir(folder), [], f"stage {stage}: files left behind")

    def test_sigterm(self):
        for stage in ("start", "mchex", "check", "write"):
            with self.subTest(stage=stage):
                self.interrupt_at(stage, signal.SIGTERM)

    def test_sigint(self):
        for stage in ("start", "write"):
            with self.subTest(stage=stage):
                self.interrupt_at(stage, signal.SIGINT)


if __name__ == "__main__":
    unittest.main()
