"""The Python module (host/python, docs/python.md) against the command line program as reference:
the same options give the same meshes byte for byte, the same report keys and the same check
JSON; a surface given as arrays meshes as the same surface read from a file; bad input raises
InputError or ResourceError with the CLI's one-line message; Mesh.to_meshio and from_meshio round
trip through meshio's own reader; the GIL is released while the pipeline runs; the package imports
from an install prefix with a clean PYTHONPATH.

Run by ctest with pytest (PYTHONPATH=build/python, MCHEX_GPU the CLI of the same build); the
certificate is run for one transition type (test_certify runs every type)."""
import json
import os
import pathlib
import shutil
import struct
import subprocess
import sys
import threading
import time

import meshio
import numpy as np
import pytest

import mchex

EXE = os.environ["MCHEX_GPU"]
BUILD = os.environ.get("MCHEX_BUILD_DIR")


def cli(*args, check=True):
    r = subprocess.run([EXE, *map(str, args)], capture_output=True, text=True, stdin=subprocess.DEVNULL,
                       timeout=900)
    if check:
        assert r.returncode == 0, r.stderr
    return r


def cli_error(*args):
    """The CLI's one line for a bad run, less its program name and its "(see --help)" pointer."""
    r = cli(*args, check=False)
    assert r.returncode != 0
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    line = lines[0]
    assert line.startswith("mchex-gpu: ")
    line = line[len("mchex-gpu: "):]
    return line[:-len(" (see --help)")] if line.endswith(" (see --help)") else line


def sphere_surface(levels=2):
    """An octahedron subdivided `levels` times onto the unit sphere, outward, closed; coordinates
    rounded to float32 so that a float32 file format holds them exactly."""
    v = [np.array(p, float) for p in [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]]
    t = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]
    for _ in range(levels):
        mid, out = {}, []

        def m(a, b):
            key = (min(a, b), max(a, b))
            if key not in mid:
                p = v[a] + v[b]
                v.append(p / np.linalg.norm(p))
                mid[key] = len(v) - 1
            return mid[key]
        for a, b, c in t:
            ab, bc, ca = m(a, b), m(b, c), m(c, a)
            out += [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
        t = out
    return np.array(v).astype(np.float32).astype(np.float64), np.array(t, np.int64)


def write_off(path, v, t):
    with open(path, "w") as f:
        f.write(f"OFF\n{len(v)} {len(t)} 0\n")
        f.writelines(f"{x!r} {y!r} {z!r}\n" for x, y, z in v)
        f.writelines(f"3 {a} {b} {c}\n" for a, b, c in t)


def write_binary_stl(path, v, t):
    with open(path, "wb") as f:
        f.write(b"\0" * 80 + struct.pack("<I", len(t)))
        for tri in t:
            f.write(struct.pack("<3f", 0, 0, 0) + v[tri].astype("<f4").tobytes() + b"\0\0")


def assert_same_mesh(a, b):
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.hexes, b.hexes)
    np.testing.assert_array_equal(a.region, b.region)


@pytest.fixture(scope="module")
def sphere3(tmp_path_factory):
    """The sphere at depth 3 from both front ends: (python Result, cli folder)."""
    d = tmp_path_factory.mktemp("sphere3")
    cli("--quiet", "mesh", "--shape", "sphere", "--depth", 3, "-o", d / "cli.vtu", "--report", d / "cli.json")
    t = time.perf_counter()
    r = mchex.mesh(shape="sphere", depth=3)
    print(f"mchex.mesh(shape='sphere', depth=3): {time.perf_counter() - t:.2f} s")
    return r, d


def test_shape_mesh_is_the_clis_byte_for_byte(sphere3):
    r, d = sphere3
    r.write(d / "py.vtu")
    assert (d / "py.vtu").read_bytes() == (d / "cli.vtu").read_bytes()
    assert (d / "outside.vtu").stat().st_size > 0
    # meshio as a second reader of the CLI's files, against the arrays themselves.
    for mesh, name, region in ((r.inside, "cli.vtu", 1), (r.outside, "outside.vtu", 2)):
        m = meshio.read(d / name)
        np.testing.assert_array_equal(mesh.points, m.points)
        np.testing.assert_array_equal(mesh.hexes, m.cells_dict["hexahedron"])
        assert mesh.points.dtype == np.float64 and mesh.points.shape[1] == 3
        assert mesh.hexes.dtype == np.int64 and mesh.hexes.shape[1] == 8
        assert mesh.region.dtype == np.int32 and set(np.unique(mesh.region)) == {region}


def test_report_is_the_clis(sphere3):
    r, d = sphere3
    ref = json.loads((d / "cli.json").read_text())
    # The CLI's names its files; mchex.mesh writes none.
    assert set(r.report) == set(ref) - {"outputs"}
    for key in ("input", "method", "grid", "elements", "check", "cases", "fidelity"):
        assert r.report[key] == ref[key], key
    assert r.report["elements"]["inside_hexes"] == len(r.inside.hexes)
    assert r.report["elements"]["outside_vertices"] == len(r.outside.points)


def test_check_agrees_with_the_clis(sphere3):
    r, d = sphere3
    ref = json.loads(cli("check", d / "cli.vtu", "--outside", d / "outside.vtu", "--shape", "sphere",
                         "--json").stdout)
    got = mchex.check(r.inside, r.outside, shape="sphere")
    assert got["check"]["ok"] is True
    assert got["check"] == ref["check"]
    assert got["fidelity"] == ref["fidelity"] and got["input"] == ref["input"]
    # From the files too, named as the CLI names them.
    by_path = mchex.check(str(d / "cli.vtu"), str(d / "outside.vtu"), shape="sphere")
    assert by_path == ref


def test_arrays_mesh_as_the_same_surface_from_a_file(tmp_path):
    v, t = sphere_surface()
    write_off(tmp_path / "s.off", v, t)
    write_binary_stl(tmp_path / "s.stl", v, t)
    opts = dict(depth=3, fidelity=False)
    from_off = mchex.mesh(tmp_path / "s.off", **opts)
    shared = mchex.mesh((v, t), **opts)
    assert_same_mesh(from_off.inside, shared.inside)
    assert_same_mesh(from_off.outside, shared.outside)
    # A triangle soup is welded as the STL reader welds the file's.
    soup = mchex.mesh((v[t.reshape(-1)], np.arange(3 * len(t)).reshape(-1, 3)), **opts)
    from_stl = mchex.mesh(str(tmp_path / "s.stl"), **opts)
    assert_same_mesh(from_stl.inside, soup.inside)
    assert_same_mesh(from_stl.outside, soup.outside)
    # The report names the arrays as given (name=), otherwise states the same surface.
    assert shared.report["input"].pop("file") == "arrays"
    assert from_off.report["input"].pop("file") == str(tmp_path / "s.off")
    assert shared.report["input"] == from_off.report["input"]
    # And the CLI on the file gives the same again.
    cli("-q", "mesh", tmp_path / "s.off", "--depth", 3, "--no-fidelity", "-o", tmp_path / "c.vtu")
    c = meshio.read(tmp_path / "c.vtu")
    np.testing.assert_array_equal(c.points, shared.inside.points)
    np.testing.assert_array_equal(c.cells_dict["hexahedron"], shared.inside.hexes)


@pytest.mark.parametrize("kwargs,args", [
    (dict(depth=9), ["--depth", "9"]),
    (dict(depth=3, threshold=0.1), ["--depth", "3", "--threshold", "0.1"]),
    (dict(method="x"), ["--method", "x"]),
    (dict(eps=0.7), ["--eps", "0.7"]),
    (dict(max_depth=4), ["--max-depth", "4"]),
    (dict(sign="nearest"), ["--sign", "nearest"]),
    (dict(backend="gpu"), ["--backend", "gpu"]),
    (dict(max_memory="lots"), ["--max-memory", "lots"]),
])
def test_bad_values_raise_the_clis_line(tmp_path, kwargs, args):
    expected = cli_error("mesh", "--shape", "sphere", *args, "-o", tmp_path / "x.vtu")
    with pytest.raises(mchex.InputError) as e:
        mchex.mesh(shape="sphere", **kwargs)
    assert str(e.value) == expected
    assert isinstance(e.value, ValueError)
    assert not list(tmp_path.iterdir())


def test_missing_file_and_memory_refusal_raise_the_clis_line(tmp_path):
    missing = tmp_path / "missing.stl"
    with pytest.raises(mchex.InputError) as e:
        mchex.mesh(missing)
    assert str(e.value) == cli_error("mesh", missing, "-o", tmp_path / "x.vtu")
    with pytest.raises(mchex.ResourceError) as e:
        mchex.mesh(shape="sphere", depth=5, max_memory="1M")
    r = cli("mesh", "--shape", "sphere", "--depth", 5, "--max-memory", "1M", "-o", tmp_path / "x.vtu", check=False)
    assert r.returncode == 2
    assert str(e.value) == r.stderr.strip()[len("mchex-gpu: "):]
    with pytest.raises(mchex.InputError, match="^give either a surface or a shape, not both$"):
        mchex.mesh(sphere_surface(0), shape="sphere")


def test_bad_arrays_and_options_raise_input_error():
    v, t = sphere_surface(0)
    cases = [
        ((v[:, :2], t), "vertices: expected an N x 3 array of floats, got shape (6, 2) of float64"),
        ((v, t.astype(float)), "triangles: expected an M x 3 array of integers, got shape (8, 3) of float64"),
        ((v, t + 6), "triangles: row 0 names point 6, which is not one of the 6 points"),
        ((v, -t), "triangles: row 0 names point -2, which is not one of the 6 points"),
        ((np.where(v == 1, np.nan, v), t), "vertices: row 0 is not finite"),
        ((v, t[:0]), "triangles: the surface has no triangles"),
        ((v,), "source: expected a file name or a (vertices, triangles) pair"),
    ]
    for source, message in cases:
        with pytest.raises(mchex.InputError) as e:
            mchex.mesh(source, depth=1)
        assert str(e.value) == message
    with pytest.raises(mchex.InputError, match=r"^mesh: unknown option dpeth \(the options: region_order, shells_as_regions, junction_lift, method, crossings, eps, depth,"):
        mchex.mesh(shape="sphere", dpeth=3)
    with pytest.raises(mchex.InputError, match=r"^--depth: expected a value, got True$"):
        mchex.mesh(shape="sphere", depth=True)
    with pytest.raises(mchex.InputError, match=r"^--threads: Value 0 not in range \[1 - 1024\]$"):
        mchex.mesh(shape="sphere", threads=0)
    with pytest.raises(mchex.InputError, match=r"^check: unknown option depth"):
        mchex.check((v, np.zeros((1, 8), np.int64)), depth=3)



def test_several_sources_are_the_clis_regions(tmp_path):
    """A list of surfaces meshes as several INPUT files do: the same region-labelled meshes byte
    for byte, whether each region comes as a file or as arrays, region_order and
    shells_as_regions as on the command line."""
    v, t = sphere_surface()
    small = (0.5 * v).astype(np.float32).astype(np.float64)
    write_off(tmp_path / "big.off", v, t)
    write_off(tmp_path / "small.off", small, t)
    opts = dict(depth=2, fidelity=False)
    for order in (None, "1,2"):
        extra = ["--region-order", order] if order else []
        cli("-q", "mesh", tmp_path / "big.off", tmp_path / "small.off", "--depth", 2, "--no-fidelity", *extra,
            "-o", tmp_path / "c.vtu", "--report", tmp_path / "c.json")
        c = meshio.read(tmp_path / "c.vtu")
        rep = json.loads((tmp_path / "c.json").read_text())
        by_files = mchex.mesh([tmp_path / "big.off", str(tmp_path / "small.off")], region_order=order, **opts)
        by_arrays = mchex.mesh([(v, t), (small, t)], region_order=order, **opts)
        for r in (by_files, by_arrays):
            np.testing.assert_array_equal(r.inside.points, c.points)
            np.testing.assert_array_equal(r.inside.hexes, c.cells_dict["hexahedron"])
            np.testing.assert_array_equal(r.inside.region, c.cell_data["region"][0])
            assert set(np.unique(r.outside.region)) == {3}
            assert r.report["regions"]["priority"] == rep["regions"]["priority"]
            assert [x["hexes"] for x in r.report["regions"]["regions"]] == [
                x["hexes"] for x in rep["regions"]["regions"]]
        assert [x["name"] for x in by_arrays.report["regions"]["regions"]] == ["arrays 1", "arrays 2"]
        # The ball is inside the shell: by volume it wins its points, with "1,2" the shell does.
        counts = np.bincount(by_files.inside.region, minlength=3)[1:]
        assert (counts[1] > 0) == (order is None)
    # One file of two shells, and the same shells as one pair of arrays.
    both_v = np.concatenate([v, small])
    both_t = np.concatenate([t, t + len(v)])
    write_off(tmp_path / "both.off", both_v, both_t)
    shells = mchex.mesh(tmp_path / "both.off", shells_as_regions=True, **opts)
    shells_arrays = mchex.mesh((both_v, both_t), shells_as_regions=True, **opts)
    assert_same_mesh(shells.inside, shells_arrays.inside)
    np.testing.assert_array_equal(np.bincount(shells.inside.region)[1:], np.bincount(
        mchex.mesh([(v, t), (small, t)], **opts).inside.region)[1:])
    with pytest.raises(mchex.InputError, match="^source: an empty list"):
        mchex.mesh([], **opts)
    with pytest.raises(mchex.InputError, match=r"^--region-order orders the regions of several INPUT"):
        mchex.mesh((v, t), region_order="2,1", **opts)
    with pytest.raises(mchex.InputError, match="^give either a surface or a shape, not both$"):
        mchex.mesh([(v, t), (small, t)], shape="sphere", **opts)

def test_check_finds_a_broken_mesh(sphere3):
    r, _ = sphere3
    flipped = mchex.Mesh(r.inside.points, r.inside.hexes[:, [4, 5, 6, 7, 0, 1, 2, 3]], r.inside.region)
    got = mchex.check(flipped)
    assert got["check"]["ok"] is False


def test_to_meshio_round_trip(sphere3, tmp_path):
    r, _ = sphere3
    m = r.outside.to_meshio()
    assert_same_mesh(mchex.from_meshio(m), r.outside)
    # Through a file meshio writes and reads itself: the regions come back as cell data.
    meshio.write(tmp_path / "o.vtu", m)
    back = mchex.from_meshio(meshio.read(tmp_path / "o.vtu"))
    assert_same_mesh(back, r.outside)
    assert mchex.check(mchex.from_meshio(r.inside.to_meshio()), back)["check"]["ok"] is True


def test_the_gil_is_released_while_meshing():
    ticks = [0]
    running = threading.Event()
    done = threading.Event()

    def count():
        running.set()
        while not done.is_set():
            ticks[0] += 1
    thread = threading.Thread(target=count)
    thread.start()
    running.wait()
    start = ticks[0]
    t = time.perf_counter()
    mchex.mesh(shape="sphere", depth=4)
    seconds = time.perf_counter() - t
    during = ticks[0] - start
    done.set()
    thread.join()
    # A held GIL would give the counter only the interpreter's switch interval (5 ms) at the
    # call's start; released, it counts all through the run (millions per second).
    print(f"depth 4: {seconds:.2f} s, counter +{during}")
    assert seconds > 0.5 and during > 10000 * seconds


def test_devices_are_the_clis():
    listed = mchex.devices()
    assert listed == json.loads(cli("devices", "--json").stdout)
    assert {d["backend"] for d in listed} >= {"cpu"}
    assert mchex.backends()[:2] == ["auto", "cpu"]


def test_certify_bad_eps_is_the_clis_line():
    with pytest.raises(mchex.InputError) as e:
        mchex.certify(eps=0.0)
    assert str(e.value) == cli_error("certify", "--eps", "0")


def test_certify_unknown_type_is_the_clis_line():
    with pytest.raises(mchex.InputError) as e:
        mchex.certify(types=["no-such-type"])
    assert str(e.value) == cli_error("certify", "--type", "no-such-type")


def test_certify_summary_is_the_clis_table():
    # One transition type with subcases left to the run-time remedy (face-2), and the single type,
    # which is always certified: a few seconds, where every type takes minutes (test_certify runs
    # them all).
    got = mchex.certify(types="face-2")
    assert [t["type"] for t in got["types"]] == ["single", "face-2"]
    # Passed: every subcase reached and the cube type proven for all; a failure of another type is
    # left to the run-time remedy, and is then one of that type's subcases left to it.
    assert got["passed"] is True
    types = {t["type"]: t for t in got["types"]}
    assert types["single"]["left_to_remedy"] == [] and types["face-2"]["left_to_remedy"] != []
    if got["first_failure"] is not None:
        f = got["first_failure"]
        assert f["type"] != "single" and f["subcase"] in types[f["type"]]["left_to_remedy"]
    # The per-type summary against the table the CLI prints for the same run (deterministic: the
    # same seed and samples), row for row.
    printed = cli("certify", "--type", "face-2").stdout.splitlines()
    assert got["text"].splitlines()[:5] == printed[:5]
    rows = {line.split()[0]: line.split() for line in printed[3:5]}
    for t in got["types"]:
        row = rows[t["type"]]
        assert int(row[1]) == t["hexes"]
        assert row[2] == f"{len(t['proven_subcases'])}/32"
        assert (row[5:] if row[5] != "-" else []) == t["left_to_remedy"]


@pytest.mark.skipif(not BUILD, reason="needs MCHEX_BUILD_DIR (set by ctest)")
def test_imports_from_the_install_prefix(tmp_path):
    prefix = tmp_path / "prefix"
    subprocess.run(["cmake", "--install", BUILD, "--prefix", prefix], check=True, capture_output=True)
    site = prefix / "lib" / "python3" / "dist-packages"
    assert (site / "mchex" / "__init__.py").is_file()
    code = ("import mchex, json; r = mchex.mesh(shape='sphere', depth=1, fidelity=False); "
            "print(json.dumps([mchex.__file__, len(r.inside.hexes), r.report['check']['ok']]))")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(site)
    out = subprocess.run(["/usr/bin/python3", "-c", code], capture_output=True, text=True, env=env,
                         cwd=tmp_path, check=True)
    where, hexes, ok = json.loads(out.stdout)
    assert pathlib.Path(where).resolve().is_relative_to(site.resolve())
    assert hexes == len(mchex.mesh(shape="sphere", depth=1, fidelity=False).inside.hexes) and ok
    # And from the build tree with nothing else on the path.
    env["PYTHONPATH"] = str(pathlib.Path(BUILD) / "python")
    out = subprocess.run(["/usr/bin/python3", "-c", code], capture_output=True, text=True, env=env,
                         cwd=tmp_path, check=True)
    assert json.loads(out.stdout)[1] == hexes
    shutil.rmtree(prefix)
