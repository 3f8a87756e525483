#!/usr/bin/python3
"""End to end per backend: the whole `mchex-gpu mesh` run (read, SDF, grid, classification,
cutting and subdivision, check, write) on the same inputs with --backend cpu, opencl and vulkan,
as wall times and ratios to cpu measured in one run, the report's stage times, and whether each
backend's meshes are byte-identical to cpu's. Prints a table and one JSON line.

  /usr/bin/python3 perf/bench_end_to_end.py [--build build] [--repeat R] [--depth D] [--backends cpu,opencl,vulkan]

Inputs: the analytic two-holed shape (its SDF is a shape kernel) and the 53,760-triangle bumpy
torus of tests/models.py (a surface SDF over the device BVH), uniform at --depth, plus the torus
adaptive at threshold 0.05 with --depth as its max depth. Each (input, backend) runs once cold (program and pipeline caches
filled; its time is printed apart) and then R times; the best of those is the figure. Timings
are the report's `total` (the process's own clock, without process start), so the ratios compare
the pipelines, not the loader. "B/hex" is the report's peak memory per output hex (inside and
outside together), the figure core/pipeline/estimate.h's memory estimate is calibrated on."""
import argparse
import filecmp
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests"))
import models  # noqa: E402  (tests/models.py: closed test surfaces written with numpy)


def run_mesh(exe, args, backend, out_dir, tag):
    inside = os.path.join(out_dir, f"{tag}.{backend}.in.mesh")
    outside = os.path.join(out_dir, f"{tag}.{backend}.out.mesh")
    report = os.path.join(out_dir, f"{tag}.{backend}.json")
    # --no-fidelity: the figures are the meshing's, as before fidelity was on by default.
    cmd = [exe, "mesh", *args, "--backend", backend, "-o", inside, "--outside", outside, "--report", report, "--quiet",
           "--no-fidelity"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        return None, r.stderr.strip().splitlines()[-1:] or ["exit %d" % r.returncode]
    with open(report) as f:
        rep = json.load(f)
    return {"report": rep, "inside": inside, "outside": outside}, None


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=os.path.join(HERE, "..", "build"))
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--depth", type=int, default=4)
    ap.add_argument("--backends", default="cpu,opencl,vulkan")
    o = ap.parse_args()
    exe = os.path.join(o.build, "host", "mchex-gpu")
    backends = o.backends.split(",")
    if "cpu" not in backends:
        backends.insert(0, "cpu")

    with tempfile.TemporaryDirectory() as tmp:
        torus = os.path.join(tmp, "bumpy.stl")
        v, t = models.bumpy_torus(320, 84)
        models.write_binary_stl(torus, v, t)
        workloads = [
            ("two-holed uniform", "shape", ["--shape", "two-holed", "--depth", str(o.depth)]),
            (f"bumpy torus {len(t)} tris uniform", "torus", [torus, "--depth", str(o.depth)]),
            (f"bumpy torus {len(t)} tris adaptive", "torus_adaptive", [torus, "--threshold", "0.05", "--max-depth", str(o.depth)]),
        ]
        results = {}
        print(f"bench_end_to_end: {exe}, best of {o.repeat} after one cold run")
        header = f"{'workload':36} {'backend':8} {'hexes':>10} {'total s':>8} {'x cpu':>6} {'cold s':>7} {'M hex/s':>8} {'B/hex':>6}  stages (s)  same mesh"
        print(header)
        for name, tag, args in workloads:
            base = None
            for be in backends:
                cold, err = run_mesh(exe, args, be, tmp, tag)
                if err:
                    print(f"{name:36} {be:8} unavailable: {err[0]}")
                    results.setdefault(name, {})[be] = {"error": err[0]}
                    continue
                best = None
                for _ in range(o.repeat):
                    r, err = run_mesh(exe, args, be, tmp, tag)
                    if err:
                        break
                    if best is None or r["report"]["times"]["total"] < best["report"]["times"]["total"]:
                        best = r
                if best is None:
                    print(f"{name:36} {be:8} failed after the cold run: {err[0]}")
                    results.setdefault(name, {})[be] = {"error": err[0]}
                    continue
                rep = best["report"]
                total = rep["times"]["total"]
                hexes = rep["elements"]["inside_hexes"] + rep["elements"]["outside_hexes"]
                if be == "cpu":
                    base = best
                same = None
                if base is not None and be != "cpu":
                    same = filecmp.cmp(base["inside"], best["inside"], shallow=False) and filecmp.cmp(
                        base["outside"], best["outside"], shallow=False)
                ratio = total / base["report"]["times"]["total"] if base else None
                stages = {k: round(v, 4) for k, v in rep["times"].items() if k != "total"}
                results.setdefault(name, {})[be] = {
                    "device": rep["backend"].get("device", be), "hexes": hexes, "total_s": total,
                    "cold_total_s": cold["report"]["times"]["total"], "time_ratio_to_cpu": ratio,
                    "hexes_per_s": hexes / total, "peak_memory_bytes": rep["peak_memory_bytes"],
                    "peak_bytes_per_hex": rep["peak_memory_bytes"] / hexes, "stages_s": stages,
                    "identical_to_cpu": same}
                print(f"{name:36} {be:8} {hexes:10d} {total:8.3f} {ratio:6.2f} {cold['report']['times']['total']:7.3f} "
                      f"{hexes / total / 1e6:8.3f} {rep['peak_memory_bytes'] / hexes:6.0f}  {' '.join(f'{k} {v:.3f}' for k, v in stages.items())}"
                      f"  {'-' if same is None else ('yes' if same else 'DIFFERS')}")
        print(json.dumps({"bench": "end_to_end", "repeat": o.repeat, "depth": o.depth, "results": results}))
        if any(r.get("identical_to_cpu") is False for w in results.values() for r in w.values()):
            sys.exit(1)


if __name__ == "__main__":
    main()
