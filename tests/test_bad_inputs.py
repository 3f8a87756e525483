"""Every broken or invalid surface the test packages ship either meshes to a valid mesh or fails
cleanly: exit 0 with meshes that `check` passes (both conform, every hex Bernstein-certified), or
exit 1 or 2 with exactly one stderr line that names the file; never a signal, a hang or a file
left behind (no partial mesh, no hidden temporary). The files: npm stl-models' broken/ folder,
assimp-testmodels' invalid files (models/invalid/ and OFF/invalid.off) and openscad-testing-data's
STLs whose names say they are bad, plus those of its stl/ folder. Depth 2 grids keep the sweep
to a few seconds. A file that meshes must be of the right solid: where meshio (an independent
reader) reads it, hex centres farther than a cell from its triangles (and, across its holes, from
the level set w = 1/2) are inside the mesh exactly where the brute-force numpy winding number of
those triangles exceeds 1/2."""
import glob
import json
import os
import random
import struct
import subprocess
import unittest

import meshio
import numpy as np

import models
from harness import STL_MODELS, ScratchTestCase, run

TIMEOUT = 60


def bad_files():
    files = glob.glob(os.path.join(STL_MODELS, "broken", "*"))
    files += glob.glob("/usr/share/assimp/models/invalid/*") + glob.glob("/usr/share/assimp/models/*/invalid*")
    files += glob.glob("/usr/share/openscad/testdata/stl/*")
    for pattern in ("*invalid*", "*broken*", "*bad*"):
        files += glob.glob(f"/usr/share/openscad/testdata/**/{pattern}.stl", recursive=True)
    return sorted(f for f in set(files) if os.path.isfile(f) and not f.endswith("readme.txt"))


class BadInputSweep(ScratchTestCase):
    def test_every_bad_file_meshes_or_fails_cleanly(self):
        files = bad_files()
        self.assertGreater(len(files), 25, files)
        outcomes = {}
        for i, f in enumerate(files):
            with self.subTest(file=f):
                folder = os.path.join(self.dir, str(i))
                os.mkdir(folder)
                try:
                    r = run("mesh", f, "--depth", 2, "-o", "inside.mesh", "--quiet", cwd=folder, timeout=TIMEOUT)
                except subprocess.TimeoutExpired:
                    self.fail(f"{f}: no answer in {TIMEOUT} s")
                self.assertGreaterEqual(r.returncode, 0, f"killed by signal {-r.returncode}: {r.stderr}")
                self.assertIn(r.returncode, (0, 1, 2), r.stderr)
                outcomes[os.path.basename(f)] = r.returncode
                if r.returncode != 0:
                    lines = r.stderr.splitlines()
                    self.assertEqual(len(lines), 1, r.stderr)
                    self.assertIn(f, lines[0])
                    self.assertEqual(os.listdir(folder), [])
                    continue
                self.assertEqual(sorted(os.listdir(folder)), ["inside.mesh", "outside.mesh"])
                c = run("check", "inside.mesh", "--outside", "outside.mesh", "--json", cwd=folder, timeout=TIMEOUT)
                self.assertEqual(c.returncode, 0, c.stdout[-2000:] + c.stderr)
                report = json.loads(c.stdout)["check"]
                self.assertTrue(report["ok"], report["errors"])
                self.assertEqual(report["union"]["gap_faces"], 0)
                self.assertEqual(report["union"]["overlap_faces"], 0)
                for side in ("inside", "outside"):
                    q = report[side]["quality"]
                    self.assertEqual(q["certified"], q["count"], side)
                verified = self.assert_right_solid(f, folder)
                if verified:
                    outcomes[os.path.basename(f)] = "meshed, right solid"
        # Some of them mesh (a missing endsolid, a wrong normal), most are refused.
        self.assertIn(0, outcomes.values(), outcomes)
        # The independent reader reads most of those that mesh; each of those was checked above.
        meshed = [k for k, v in outcomes.items() if v in (0, "meshed, right solid")]
        checked = [k for k, v in outcomes.items() if v == "meshed, right solid"]
        self.assertGreaterEqual(2 * len(checked), len(meshed), outcomes)
        self.assertIn(1, outcomes.values(), outcomes)

    def assert_right_solid(self, path, folder):
        """True when meshio reads the file's triangles and every hex centre farther than a cell
        from them lies on the side their winding number says; False when meshio cannot read it."""
        try:
            surface = meshio.read(path)
            tris = np.concatenate([c.data for c in surface.cells if c.type == "triangle"])
        except Exception:  # a broken file an independent reader refuses: nothing to compare with
            return False
        verts = np.asarray(surface.points, dtype=float)
        lo, hi = verts.min(axis=0), verts.max(axis=0)
        cell = 1.2 * (hi - lo).max() / 9  # depth 2 over the padded cube (10 % each side)
        # Points on every triangle no farther apart than a quarter cell, so a centre more than
        # cell + spacing from all of them is more than a cell from the surface.
        spacing = cell / 4
        samples = [verts]
        for tri in verts[tris]:
            n = int(np.ceil(max(np.linalg.norm(tri[i] - tri[(i + 1) % 3]) for i in range(3)) / spacing))
            if n > 1:
                i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
                keep = i + j <= n
                a, b = i[keep] / n, j[keep] / n
                samples.append(np.outer(a, tri[0]) + np.outer(b, tri[1]) + np.outer(1 - a - b, tri[2]))
        samples = np.concatenate(samples)
        for name, want_inside in (("inside.mesh", True), ("outside.mesh", False)):
            m = meshio.read(os.path.join(folder, name))
            if "hexahedron" not in m.cells_dict:
                continue  # an empty side: the surface encloses no grid point, or all of them
            centres = m.points[m.cells_dict["hexahedron"]].mean(axis=1)
            centres = centres[np.random.default_rng(1).permutation(len(centres))[:400]]
            far = np.array([np.linalg.norm(samples - c, axis=1).min() > cell + spacing for c in centres], dtype=bool)
            if not far.any():
                continue
            w = models.winding_numbers(verts, tris, centres[far])
            # Across a hole the inside ends on the level set w = 1/2, which the grid resolves to a
            # cell like any surface but far from every triangle: centres near it may go either way.
            w = w[np.abs(w - 0.5) > 0.1]
            self.assertTrue(((w > 0.5) == want_inside).all(), f"{path}: {name} centres with w = {w[(w > 0.5) != want_inside][:5]}")
        return True


class ResourceLimits(ScratchTestCase):
    """mesh --max-memory (core/pipeline/estimate.h): a run whose estimated peak memory is over the
    budget exits 2 before the mesher's work, with one line that names a setting that fits, and
    writes nothing."""

    def refused(self, *args):
        r = run("mesh", "--shape", "torus", *args, "-o", "inside.mesh", "--report", "r.json", cwd=self.dir, timeout=120)
        self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
        lines = r.stderr.strip().splitlines()
        self.assertEqual(os.listdir(self.dir), [])
        return lines[-1]

    def test_over_the_default_budget(self):
        # 729^3 cells, about 600 GB for MCHex: over any machine this runs on.
        line = self.refused("--depth", 6, "--quiet")
        self.assertRegex(line, r"^mchex-gpu: depth 6 needs about [0-9.]+ GiB .* over 80% of the available memory")
        self.assertRegex(line, r"; --depth [0-5] would need about [0-9.]+ [MG]iB$")

    def test_a_small_budget_refuses_a_run_that_fits_by_default(self):
        ok = run("mesh", "--shape", "torus", "--depth", 3, "-o", "fits.mesh", "--quiet", cwd=self.dir, timeout=120)
        self.assertEqual(ok.returncode, 0, ok.stderr)
        for f in os.listdir(self.dir):
            os.remove(os.path.join(self.dir, f))
        line = self.refused("--depth", 3, "--max-memory", "50M", "--quiet")
        self.assertRegex(line, r"^mchex-gpu: depth 3 needs about [0-9]+ MiB .* over --max-memory 50 MiB; ")
        # Adaptive: checked once the octree is refined, the suggestion a smaller --max-depth.
        line = self.refused("--threshold", 0.05, "--max-depth", 5, "--max-memory", "120M", "--quiet")
        self.assertRegex(line, r"^mchex-gpu: the adaptive grid of [0-9]+ cells needs about .* over --max-memory 120 MiB")
        self.assertRegex(line, r"--max-depth [0-4] would need about")

    def test_sizes(self):
        r = run("mesh", "--shape", "torus", "--depth", 1, "--max-memory", "3X", "-o", "a.mesh", cwd=self.dir)
        self.assertEqual(r.returncode, 1)
        self.assertIn("expected a size such as 8G or 512M, got 3X", r.stderr)
        for size in ("1G", "1.5GiB", "900MB", "2000000000", "1t"):
            r = run("mesh", "--shape", "torus", "--depth", 1, "--max-memory", size, "-o", "a.mesh", "--quiet",
                    cwd=self.dir)
            self.assertEqual(r.returncode, 0, size + r.stderr)


class BackendChoices(ScratchTestCase):
    """--backend offers only the backends built into this binary (host/backends/registry.h): the
    values its help lists are auto plus those `devices` does not call "not built"."""

    def test_help_lists_the_built_backends(self):
        devices = json.loads(run("devices", "--json").stdout)
        built = {"auto"} | {d["backend"] for d in devices if "not built" not in d["note"]}
        help_text = run("mesh", "--help").stdout
        line = next(l for l in help_text.splitlines() if "--backend" in l)
        offered = set(line[line.index("{") + 1:line.index("}")].split(","))
        self.assertEqual(offered, built, line)
        for name in {"cpu", "opencl", "vulkan"} - built:
            r = run("mesh", "--backend", name, "--depth", 1, "-o", "a.mesh", cwd=self.dir)
            self.assertEqual(r.returncode, 1)
            self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
            self.assertIn(f"backend '{name}' is not built into this binary", r.stderr)
        # A name that is no backend at all is refused by the option itself, listing what is built.
        r = run("mesh", "--backend", "metal", "--depth", 1, "-o", "a.mesh", cwd=self.dir)
        self.assertEqual(r.returncode, 1)
        self.assertIn("metal not in {" + ",".join(sorted(built, key=["auto", "cpu", "opencl", "vulkan"].index)) + "}",
                      r.stderr)


def mutations(data, seed, count):
    """`count` damaged copies of `data`, the same ones on every run (seeded): cut short, bytes
    overwritten, a number replaced by an extreme token, a run of bytes zeroed, garbage inserted,
    and, for a binary STL, its triangle count replaced."""
    rng = random.Random(seed)
    tokens = [b"1e308", b"nan", b"-inf", b"99999999999", b"-7", b"4294967295", b"1e-320", b"0"]
    for k in range(count):
        d = bytearray(data)
        op = k % 6
        if op == 0:
            d = d[:rng.randrange(1, len(d))]
        elif op == 1:
            for _ in range(rng.randrange(1, 10)):
                d[rng.randrange(len(d))] = rng.randrange(256)
        elif op == 2:
            digits = [i for i, c in enumerate(d) if 48 <= c <= 57]
            if digits:
                i = rng.choice(digits)
                d[i:i + 1] = rng.choice(tokens)
        elif op == 3:
            i = rng.randrange(len(d))
            j = min(len(d), i + rng.randrange(1, 64))
            d[i:j] = bytes(j - i)
        elif op == 4:
            i = rng.randrange(len(d))
            d[i:i] = bytes(rng.randrange(256) for _ in range(20))
        elif data[:5] != b"solid" and len(d) >= 84:
            d[80:84] = struct.pack("<I", rng.choice([0, 1, 2**31, 2**32 - 1, 12345678]))
        yield bytes(d)


class MutatedFiles(ScratchTestCase):
    """Seeded damage to small valid files of every format the CLI reads: each damaged file either
    works or is refused with exit 1 and exactly one stderr line; never a signal, a hang, or (for
    mesh and convert) an output file left behind. Surfaces through `mesh`, hex meshes through
    `check` and `convert`. The files the test packages ship broken are swept above; these reach
    the readers' other paths (counts past the data, NaN coordinates, indices out of range)."""

    def expect_clean(self, args, folder, what):
        try:
            r = run(*args, cwd=folder, timeout=TIMEOUT)
        except subprocess.TimeoutExpired:
            self.fail(f"{what}: no answer in {TIMEOUT} s")
        self.assertGreaterEqual(r.returncode, 0, f"{what}: killed by signal {-r.returncode}: {r.stderr}")
        self.assertIn(r.returncode, (0, 1), f"{what}: {r.stderr}")
        if r.returncode:
            self.assertEqual(len(r.stderr.splitlines()), 1, f"{what}: {r.stderr}")
        return r.returncode

    def damaged_file(self, folder_name, ext, data):
        """A fresh folder holding `data` as damaged.EXT: the folder and the file's name."""
        folder = os.path.join(self.dir, folder_name)
        os.mkdir(folder)
        name = f"damaged.{ext}"
        with open(os.path.join(folder, name), "wb") as f:
            f.write(data)
        return folder, name

    def test_damaged_surfaces(self):
        verts, tris = models.box_surface((0, 0, 0), (1, 1, 1))
        path = os.path.join(self.dir, "base.stl")
        models.write_binary_stl(path, verts, tris)
        with open(path, "rb") as f:
            stl = f.read()
        vs = "".join(f"{x} {y} {z}\n" for x, y, z in verts)
        obj = ("".join(f"v {x} {y} {z}\n" for x, y, z in verts) + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in tris)).encode()
        off = (f"OFF\n{len(verts)} {len(tris)} 0\n" + vs + "".join(f"3 {a} {b} {c}\n" for a, b, c in tris)).encode()
        ply = ("ply\nformat ascii 1.0\n" + f"element vertex {len(verts)}\nproperty float x\nproperty float y\n"
               f"property float z\nelement face {len(tris)}\nproperty list uchar int vertex_indices\nend_header\n" + vs +
               "".join(f"3 {a} {b} {c}\n" for a, b, c in tris)).encode()
        outcomes = []
        for seed, (ext, data) in enumerate((("stl", stl), ("obj", obj), ("off", off), ("ply", ply))):
            for k, damaged in enumerate(mutations(data, seed=seed, count=18)):
                folder, name = self.damaged_file(f"{ext}{k}", ext, damaged)
                with self.subTest(file=f"{ext} {k}"):
                    rc = self.expect_clean(("mesh", name, "--depth", 1, "-o", "in.mesh", "--quiet"), folder, f"{ext} {k}")
                    outcomes.append(rc)
                    left = sorted(set(os.listdir(folder)) - {name})
                    if rc:
                        self.assertEqual(left, [], f"{ext} {k}")
                        continue
                    self.assertEqual(left, ["in.mesh", "outside.mesh"], f"{ext} {k}")
                    c = run("check", "in.mesh", "--outside", "outside.mesh", cwd=folder, timeout=TIMEOUT)
                    self.assertEqual(c.returncode, 0, f"{ext} {k}: {c.stdout[-1500:]}{c.stderr}")
        # Both outcomes occur: the damage is not all harmless, nor all fatal.
        self.assertIn(0, outcomes)
        self.assertIn(1, outcomes)

    def test_damaged_hex_meshes(self):
        sources = []
        for ext, extra in (("mesh", []), ("meshb", []), ("vtu", []), ("msh", []), ("msh", ["--binary"]), ("exo", []),
                           ("inp", [])):
            name = f"base{len(sources)}.{ext}"
            r = run("mesh", "--shape", "sphere", "--depth", 1, *extra, "-o", name, "--outside",
                    f"out{len(sources)}.{ext}", "--quiet", cwd=self.dir)
            self.assertEqual(r.returncode, 0, r.stderr)
            sources.append(name)
        outcomes = []
        for n, source in enumerate(sources):
            ext = source.rsplit(".", 1)[1]
            with open(os.path.join(self.dir, source), "rb") as f:
                data = f.read()
            for k, damaged in enumerate(mutations(data, seed=100 + n, count=12)):
                folder, name = self.damaged_file(f"m{n}-{k}", ext, damaged)
                with self.subTest(file=f"{source} {k}"):
                    outcomes.append(self.expect_clean(("check", name), folder, f"check {source} {k}"))
                    rc = self.expect_clean(("convert", name, "copy.vtu"), folder, f"convert {source} {k}")
                    left = sorted(set(os.listdir(folder)) - {name})
                    self.assertEqual(left, [] if rc else ["copy.vtu"], f"convert {source} {k}")
        self.assertIn(0, outcomes)
        self.assertIn(1, outcomes)


if __name__ == "__main__":
    unittest.main()
