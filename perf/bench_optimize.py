#!/usr/bin/python3
"""The certified optimiser (core/optimize/optimize.h, docs/optimize.md) on closed models at the
default settings: each input meshed twice, without and with `--optimize`, on --threads T (default 2),
and the figures of issue 18 printed side by side: minimum and mean scaled Jacobian and maximum edge
ratio (both meshes), Bernstein-certified share, IoU and Hausdorff ratio (the report's fidelity,
64^3 lattice), sweeps, the optimiser's hexes per second per sweep (wall, and per CPU second, which
a machine shared with other work distorts less), and where the worst hex is left
and what holds it. Prints a table and one JSON line per input.

  /usr/bin/python3 perf/bench_optimize.py [--build build] [--threads 2] [--only NAME,...] [--repel]

Inputs: the npm gearwheel and cube (stl-models), the npm bunny, the bumpy torus (96 x 48 and
320 x 84) and trefoil tube of tests/models.py, and the four analytic shapes. --repel meshes both
runs with `--repel` (docs/repel.md)."""
import argparse
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests"))
import models  # noqa: E402

sys.path.insert(0, HERE)
import curves  # noqa: E402

STL = os.path.join(HERE, "..", "tests", "data", "npm", "node_modules", "stl-models")


def inputs(tmp):
    out = []
    for name, rel in (("gearwheel", "objects/gearwheel.bin.stl"), ("cube", "polytopes/cube.bin.stl")):
        path = os.path.join(STL, rel)
        if os.path.exists(path):
            out.append((name, [path]))
    if os.path.exists(os.path.join(curves.NPM, "bunny", "index.js")):
        out.append(("bunny", [curves.bunny_obj(os.path.join(tmp, "bunny.obj"))]))
    for name, (v, t) in (("bumpy-torus", models.bumpy_torus(96, 48)), ("bumpy-torus-320", models.bumpy_torus(320, 84)),
                         ("trefoil", models.trefoil_tube(192, 24))):
        path = os.path.join(tmp, name + ".stl")
        models.write_binary_stl(path, v, t)
        out.append((name, [path]))
    for shape in ("sphere", "torus", "rounded-box", "two-holed"):
        out.append((shape, ["--shape", shape]))
    return out


def mesh(exe, args, threads, tmp, tag, optimize, extra=()):
    report = os.path.join(tmp, tag + ".json")
    cmd = [exe, "--threads", str(threads), "mesh", *args, "-o", os.path.join(tmp, tag + ".in.mesh"), "--outside",
           os.path.join(tmp, tag + ".out.mesh"), "--report", report, "--quiet", *extra]
    if optimize:
        cmd.append("--optimize")
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"{tag}: {r.stderr.strip()}")
    with open(report) as f:
        return json.load(f)


def quality(rep):
    c = rep["check"]
    qi, qo = c["inside"]["quality"], c["outside"]["quality"]
    n = qi["count"] + qo["count"]
    return {
        "min_sj": min(qi["min_scaled_jacobian"], qo["min_scaled_jacobian"]),
        "mean_sj": (qi["mean_scaled_jacobian"] * qi["count"] + qo["mean_scaled_jacobian"] * qo["count"]) / n,
        "max_edge_ratio": max(qi["max_edge_ratio"], qo["max_edge_ratio"]),
        "certified": (qi["certified"] + qo["certified"]) / n,
        "hexes": n,
        "iou": rep["fidelity"]["iou"],
        "hr": rep["fidelity"]["hausdorff_ratio"],
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=os.path.join(HERE, "..", "build"))
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--only", default="")
    ap.add_argument("--repel", action="store_true", help="mesh with --repel (both runs)")
    o = ap.parse_args()
    exe = os.path.join(o.build, "host", "mchex-gpu")
    only = set(filter(None, o.only.split(",")))
    print(f"{'input':12} {'hexes':>8} {'minSJ':>17} {'meanSJ':>13} {'maxER':>13} {'cert%':>6} {'IoU':>15} "
          f"{'HR%':>13} {'sweeps':>6} {'Mhex/s':>6} {'/cpu-s':>6}  worst (mesh, SJ, ER, fixed/surface/box corners)")
    with tempfile.TemporaryDirectory() as tmp:
        for name, args in inputs(tmp):
            if only and name not in only:
                continue
            extra = ["--repel"] if o.repel else []
            a = quality(mesh(exe, args, o.threads, tmp, name + ".plain", False, extra))
            rep = mesh(exe, args, o.threads, tmp, name + ".opt", True, extra)
            b, s = quality(rep), rep["optimize"]
            w = s["worst"]
            print(f"{name:12} {b['hexes']:8d} {a['min_sj']:8.2e}->{b['min_sj']:6.3f} {a['mean_sj']:.3f}->{b['mean_sj']:.3f} "
                  f"{a['max_edge_ratio']:6.3g}->{b['max_edge_ratio']:<5.3g} {100 * b['certified']:6.2f} "
                  f"{a['iou']:.4f}->{b['iou']:.4f} {100 * a['hr']:.3f}->{100 * b['hr']:.3f} {s['sweeps']:6d} "
                  f"{s['hexes_per_second_per_sweep'] / 1e6:6.2f} {s['hexes_per_cpu_second_per_sweep'] / 1e6:6.2f} "
                  f"(plain {s['phases']['plain']['hexes_per_second_per_sweep'] / 1e6:.2f}, "
                  f"search {s['phases']['search']['hexes_per_second_per_sweep'] / 1e6:.2f})  {w['mesh']} {w['scaled_jacobian']:.3f} "
                  f"{w['edge_ratio']:.3g} {w['fixed_corners']}/{w['surface_corners']}/{w['box_corners']} "
                  f"(below 0.3: {s['hexes_below_0_3']['before']}->{s['hexes_below_0_3']['after']}, "
                  f"above the edge-ratio cap: {s['hexes_above_edge_ratio_cap']['before']}->"
                  f"{s['hexes_above_edge_ratio_cap']['after']}, "
                  f"{s['hexes_below_0_3_touching_fixed']} touch a fixed vertex)")
            print(json.dumps({"bench": "optimize", "input": name, "repel": o.repel, "threads": o.threads, "without": a, "with": b,
                              "optimize": s}), flush=True)


if __name__ == "__main__":
    main()
