#!/usr/bin/python3
"""Several regions against one: the cost of a k-region mesh (docs/regions.md) over a one-region
MCHex run on the same grid, as ratios of wall times measured in turn in one run (issue 19 asks
for at most 1.5x). Prints a table and one JSON line.

  /usr/bin/python3 perf/bench_regions.py [--build build] [--repeat R] [--depth D]

Inputs (tests/models.py's uv spheres, 96 x 48): nested spheres of radius 1 and 0.5, against the
outer sphere alone (its bounds, so its grid, are the pair's); two crossing spheres (radii 0.6 and
0.5, the junction-lift case) and three, each against the same triangles in one file meshed as one
solid (their union: the same surface to search and the same grid). Uniform --depth, with and
without --repel, fidelity on as by default. Each pair of runs alternates, R times; the best of
each is the figure (the report's `total`, the process's own clock). The k-region run's own
stages are listed: "regions" (the labelling) and the second SDF's share are what it adds."""
import argparse
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests"))
import models  # noqa: E402  (tests/models.py: closed test surfaces written with numpy)


def run_mesh(exe, inputs, extra, out_dir, tag):
    report = os.path.join(out_dir, f"{tag}.json")
    cmd = [exe, "mesh", *inputs, *extra, "-o", os.path.join(out_dir, f"{tag}.in.meshb"), "--outside",
           os.path.join(out_dir, f"{tag}.out.meshb"), "--report", report, "--quiet"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)}: {r.stderr.strip()}")
    with open(report) as f:
        return json.load(f)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=os.path.join(HERE, "..", "build"))
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--depth", type=int, default=4)
    o = ap.parse_args()
    exe = os.path.join(o.build, "host", "mchex-gpu")
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        def stl(name, *surface):
            path = os.path.join(tmp, name)
            models.write_binary_stl(path, *surface)
            return path

        outer = stl("outer.stl", *models.uv_sphere(96, 48, 1.0))
        inner = stl("inner.stl", *models.uv_sphere(96, 48, 0.5))
        spheres = [((-0.35, 0, 0), 0.6), ((0.33, 0.05, 0.02), 0.5), ((0.0, 0.5, -0.1), 0.45)]
        crossing = [stl(f"s{i}.stl", *models.uv_sphere(96, 48, r, c)) for i, (c, r) in enumerate(spheres)]
        two_soup = stl("two.stl", *models.merge(*[models.uv_sphere(96, 48, r, c) for c, r in spheres[:2]]))
        three_soup = stl("three.stl", *models.merge(*[models.uv_sphere(96, 48, r, c) for c, r in spheres]))
        workloads = [("nested spheres", [outer, inner], [outer]), ("two crossing spheres", crossing[:2], [two_soup]),
                     ("three crossing spheres", crossing, [three_soup])]
        print(f"depth {o.depth}, best of {o.repeat} (each pair in turn); seconds are the report's total")
        print(f"{'input':<24} {'options':<10} {'k':>2} {'one region':>11} {'k regions':>10} {'ratio':>6}  "
              f"{'regions':>8} {'sdf':>6} {'sdf (one)':>9}  hexes k / one")
        for name, many, one in workloads:
            for extra in ([], ["--repel"]):
                args = ["--depth", str(o.depth), *extra]
                best = {}
                for rep in range(o.repeat):
                    for tag, inputs in (("one", one), ("many", many)):
                        r = run_mesh(exe, inputs, args, tmp, tag)
                        if tag not in best or r["times"]["total"] < best[tag]["times"]["total"]:
                            best[tag] = r
                t1, tk = best["one"]["times"], best["many"]["times"]
                hexes = {k: v["elements"]["inside_hexes"] + v["elements"]["outside_hexes"] for k, v in best.items()}
                row = {"input": name, "options": " ".join(extra) or "-", "regions": len(many),
                       "one_region_s": t1["total"], "k_regions_s": tk["total"], "ratio": tk["total"] / t1["total"],
                       "labelling_s": tk.get("regions", 0.0), "sdf_s": tk.get("sdf", 0.0),
                       "sdf_one_s": t1.get("sdf", 0.0), "hexes_k": hexes["many"], "hexes_one": hexes["one"]}
                results.append(row)
                print(f"{name:<24} {row['options']:<10} {len(many):>2} {t1['total']:>11.2f} {tk['total']:>10.2f} "
                      f"{row['ratio']:>6.2f}  {row['labelling_s']:>8.2f} {row['sdf_s']:>6.2f} {row['sdf_one_s']:>9.2f}"
                      f"  {hexes['many']:,} / {hexes['one']:,}")
    print(json.dumps({"bench": "regions", "depth": o.depth, "repeat": o.repeat, "rows": results}))


if __name__ == "__main__":
    main()
