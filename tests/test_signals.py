"""SIGINT and SIGTERM during `mesh` leave no file behind (core/io/atomic_file.h): a signal while the
SDF, the mesher or the writer runs removes the hidden temporaries and any mesh already moved into
place, and the process dies of the signal (its exit status says which)."""
import os
import signal
import subprocess
import time
import unittest

from harness import EXE, ScratchTestCase

# A run of a few seconds on 2 cores (about 4.4 M output hexes). The moments: "start", early in the
# run (the grid and its SDF); a stage that runs longer than a second, by its line on stderr
# ("mchex-gpu: STAGE ..."; skipped where the stage is quicker); "write", once the outside mesh's
# temporary exists.
ARGS = ["mesh", "--shape", "torus", "--depth", "4", "-o", "inside.vtu", "--report", "report.json"]


class SignalTest(ScratchTestCase):
    def wait_for_stage(self, p, folder, stage):
        if stage == "write":
            # While the outside mesh is written, the inside one already in place (both must go).
            while p.poll() is None and not any(f.startswith(".outside") for f in os.listdir(folder)):
                pass
            return p.poll() is None
        for line in p.stderr:
            if line.startswith(f"mchex-gpu: {stage} ..."):
                return True
        return False

    def interrupt_at(self, stage, sig):
        folder = os.path.join(self.dir, f"{stage}-{sig}")
        os.mkdir(folder)
        p = subprocess.Popen([EXE, *ARGS], cwd=folder, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE, text=True)
        try:
            if stage == "start":
                time.sleep(0.2)
            elif not self.wait_for_stage(p, folder, stage):
                p.wait(timeout=60)
                self.skipTest(f"the run ended before stage {stage} was seen (a faster machine)")
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
