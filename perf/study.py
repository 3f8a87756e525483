#!/usr/bin/python3
"""The paper's study and the project's scaling curves, regenerated from one command into
perf/results/ (CSV tables and PNG plots) and the results page perf/README.md.

  bash perf/run_study.sh [--build build] [--quick] [--out perf/results] [--page perf/README.md]
                         [--parts fidelity,quality,scaling] [--backends cpu,opencl,vulkan]

Parts (each writes its CSV before it plots, so a stopped study keeps what it measured):
  fidelity  MCHex against RO (the paper's Section 7 comparison: the same grids, the cells RO
            keeps against the cells MCHex cuts) on the test models of perf/curves.py: uniform
            depths 2-5 and the fitted adaptive grid at several --hausdorff targets; IoU and HR
            against hexes and against seconds, with the MCHex prototype's points
            (perf/curves/prototype.csv). A uniform depth whose predicted hexes (8 x 27^depth) are
            over --max-hexes is a row with its reason, not a run.
  quality   scaled Jacobian histograms (inside and outside meshes together) of the default mesh
            of every model, without and with --optimize, from the reports' check.*.quality.
  scaling   seconds per stage (the report's times, which sum to the wall time) against output
            hexes (the bumpy torus at uniform depths 1-4) and against input triangles (bumpy tori
            of 1k-215k triangles at depth 3), per backend; the reference SDF's BVH against the
            paper's brute-force loop (perf/bench_sdf) on the small models; peak memory per
            output hex against hexes over every run of the study.
Every figure of ours comes from a `mchex-gpu mesh` report (see perf/curves.py for how IoU and HR
are measured). Timings are from one run on a shared machine: read them as ratios within the
run (the 1-minute load average is recorded per row).
--quick: the same plots from small settings (depths 1-3, two models, two triangle counts), about
two minutes on two cores: for checking the script, not for figures."""
import argparse
import csv
import datetime
import json
import os
import platform
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "tests"))
import curves  # noqa: E402  (perf/curves.py: the models, one mesh run, the report -> CSV row)
import models  # noqa: E402  (tests/models.py: closed test surfaces written with numpy)

# The report's stages in pipeline order, for the columns and legends; others are appended as met.
STAGE_ORDER = ["read", "repair", "sign", "bvh", "octree", "fit-rounds", "grid", "sdf", "classify", "mchex", "ro",
               "optimize", "check", "write", "other"]
SJ_EDGES = [-1.0, 0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0]


def settings_for(o):
    """Fidelity part: (grid, setting text, CLI args, CSV params, predicted hexes or None)."""
    depths = [1, 2, 3] if o.quick else [2, 3, 4, 5]
    targets = [0.05] if o.quick else [0.02, 0.01, 0.005]
    out = [("uniform", f"--depth {d}", ["--depth", str(d)], {"depth": d}, 8 * 27**d) for d in depths]
    out += [("adaptive", f"--hausdorff {h:g}", ["--hausdorff", f"{h:g}"], {"hausdorff": h}, None) for h in targets]
    return out


class Runner:
    """`mchex-gpu mesh` runs through curves.mesh_once (report, wall time, maximum RSS), with the
    backend and extra arguments of each part."""

    def __init__(self, o, tmp):
        self.o, self.tmp = o, tmp
        self.exe = os.path.join(o.build, "host", "mchex-gpu")
        self.model_files = {}

    def model(self, name):
        if name not in self.model_files:
            ext, make, _ = curves.MODELS[name]
            self.model_files[name] = make(os.path.join(self.tmp, name + ext))
        return self.model_files[name]

    def mesh(self, model_file, args, backend="cpu", fidelity=True):
        opts = argparse.Namespace(lattice=self.o.lattice, max_memory=self.o.max_memory, threads=0,
                                  timeout=self.o.timeout)
        status, rep, wall, rss = curves.mesh_once(self.exe, model_file, args, opts, self.tmp, backend, fidelity)
        return status, rep, wall, rss, opts.load


def write_rows(path, rows, columns, header):
    tmp = path + ".part"
    with open(tmp, "w", newline="") as f:
        for line in header:
            f.write(f"# {line}\n")
        w = csv.DictWriter(f, columns, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    os.replace(tmp, path)


def header_lines(o, what):
    return [f"perf/study.py {what}: mchex-gpu at {o.label}, "
            f"{datetime.datetime.utcnow():%Y-%m-%d %H:%M} UTC, {platform.node() or 'host'} ({os.cpu_count()} cores)"
            + (", --quick" if o.quick else "")]


# ---------------------------------------------------------------------------------- fidelity
FIDELITY_COLUMNS = curves.COLUMNS + ["method"]


def fidelity_part(o, run):
    names = o.models.split(",") if o.models else (["bunny", "bumpy-torus"] if o.quick else
                                                   ["bunny", "gearwheel", "bumpy-torus", "trefoil-tube", "thin-ring"])
    path = os.path.join(o.out, "fidelity.csv")
    rows = []
    for name in names:
        for method in ("mchex", "ro"):
            for grid, text, args, params, predicted in settings_for(o):
                if predicted is not None and predicted > o.max_hexes:
                    status, rep, wall, rss, load = f"skipped: about {predicted:.3g} hexes > --max-hexes", None, None, None, 0
                else:
                    status, rep, wall, rss, load = run.mesh(run.model(name), args + ["--method", method])
                row = curves.row_from(name, "", method, grid, text, params, status, rep, wall, rss, load)
                row["method"] = method
                row["label"] = f"{method}"
                rows.append(row)
                print(f"fidelity {name:13} {method:5} {text:18} {status[:30]:30} in {row['inside_hexes']:>9} out "
                      f"{row['outside_hexes']:>9} IoU {row['iou']:>8} HR {row['hr']:>8} {row['seconds']:>6} s", flush=True)
                write_rows(path, rows, FIDELITY_COLUMNS, header_lines(o, "fidelity"))
    return rows


def fidelity_plots(o, plt, rows):
    names = list(dict.fromkeys(r["model"] for r in rows))
    ok = [r for r in rows if r["status"].startswith("ok")]
    proto = {r["model"]: r for r in curves.read_csv(os.path.join(HERE, "curves", "prototype.csv"))}
    figures = []
    for metric in ("iou", "hr"):
        for xaxis in ("hexes", "seconds"):
            p = os.path.join(o.out, f"{metric}_vs_{xaxis}.png")
            fidelity_figure(plt, names, ok, proto, metric, xaxis, p)
            figures.append(p)
    return figures


def fidelity_figure(plt, names, rows, proto, metric, xaxis, path):
    cols = min(len(names), 3)
    nrows = (len(names) + cols - 1) // cols
    fig, axes = plt.subplots(nrows, cols, figsize=(4.6 * cols, 3.8 * nrows), squeeze=False)
    styles = {("mchex", "uniform"): ("C0", "o", "-"), ("mchex", "adaptive"): ("C0", "s", "--"),
              ("ro", "uniform"): ("C3", "o", "-"), ("ro", "adaptive"): ("C3", "s", "--")}
    x_of = (lambda r: int(r["inside_hexes"]) + int(r["outside_hexes"])) if xaxis == "hexes" else \
        (lambda r: float(r["seconds"]))
    for ax, name in zip(axes.flat, names):
        for (method, grid), (color, marker, line) in styles.items():
            pts = [r for r in rows if r["model"] == name and r["method"] == method and r["grid"] == grid
                   and int(r["inside_hexes"]) > 0 and r[metric] not in ("", "inf")]
            pts.sort(key=x_of)
            if pts:
                ax.plot([x_of(r) for r in pts], [curves.fidelity_of(r, metric) for r in pts], marker=marker,
                        color=color, linestyle=line, label=f"{method.upper()} {grid}")
        if name in proto:
            p = proto[name]
            x = int(p["inside_hexes"]) + int(p["outside_hexes"]) if xaxis == "hexes" else float(p["seconds"])
            ax.plot([x], [curves.fidelity_of(p, metric)], marker="*", markersize=13, color="k", linestyle="none",
                    label="MCHex prototype (its defaults)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(name, fontsize=10)
        ax.set_xlabel("output hexes (inside + outside)" if xaxis == "hexes" else "seconds (without the fidelity measure)",
                      fontsize=8)
        ax.set_ylabel("1 - IoU" if metric == "iou" else "HR", fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
    curves.legend_once(fig, axes, len(names))
    fig.suptitle(f"MCHex against RO: {'1 - IoU' if metric == 'iou' else 'HR'} against "
                 f"{'output hexes' if xaxis == 'hexes' else 'time'} (lower is better)", fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


# ----------------------------------------------------------------------------------- quality
def histogram_of(rep):
    """Scaled Jacobian counts over SJ_EDGES, inside and outside meshes together."""
    total = [0] * (len(SJ_EDGES) - 1)
    for side in ("inside", "outside"):
        h = rep["check"].get(side, {}).get("quality", {}).get("scaled_jacobian_histogram")
        if not h:
            continue
        if h["edges"] != SJ_EDGES:
            raise SystemExit(f"study.py: the report's histogram edges changed ({h['edges']}); update SJ_EDGES")
        total = [a + b for a, b in zip(total, h["counts"])]
    return total


SJ_BINS = [f"sj_{a:g}_{b:g}" for a, b in zip(SJ_EDGES, SJ_EDGES[1:])]
QUALITY_COLUMNS = ["model", "setting", "status", "hexes", "min_sj", "mean_sj", "max_edge_ratio", "min_dihedral",
                   "certified"] + SJ_BINS


def quality_part(o, run):
    names = ["bunny", "bumpy-torus"] if o.quick else ["bunny", "gearwheel", "bumpy-torus", "trefoil-tube"]
    setting = ["--hausdorff", "0.05"] if o.quick else []
    path = os.path.join(o.out, "quality.csv")
    rows = []
    for name in names:
        for label, extra in (("default", []), ("--optimize", ["--optimize"])):
            status, rep, *_ = run.mesh(run.model(name), setting + extra, fidelity=False)
            row = {"model": name, "setting": " ".join(setting + extra) or "(defaults)", "status": status,
                   "optimize": label}
            if rep:
                qs = [rep["check"][s]["quality"] for s in ("inside", "outside") if rep["check"].get(s)]
                h = histogram_of(rep)
                row.update(hexes=sum(q["count"] for q in qs),
                           min_sj=f"{min(q['min_scaled_jacobian'] for q in qs):.3g}",
                           mean_sj=f"{sum(q['mean_scaled_jacobian'] * q['count'] for q in qs) / max(1, sum(q['count'] for q in qs)):.3f}",
                           max_edge_ratio=f"{max(q['max_edge_ratio'] for q in qs):.3g}",
                           min_dihedral=f"{min(q['min_dihedral_angle'] for q in qs):.1f}",
                           certified=f"{sum(q['certified'] for q in qs)}/{sum(q['count'] for q in qs)}")
                row.update(zip(SJ_BINS, h))
            rows.append(row)
            print(f"quality  {name:13} {label:10} {status[:30]:30} min SJ {row.get('min_sj', '')}", flush=True)
            write_rows(path, rows, QUALITY_COLUMNS, header_lines(o, "quality"))
    return rows


def quality_plots(o, plt, rows):
    names = list(dict.fromkeys(r["model"] for r in rows))
    hists = {(r["model"], "--optimize" if "--optimize" in r["setting"] else "default"): [int(r[b]) for b in SJ_BINS]
             for r in rows if r["status"] == "ok"}
    cols = min(len(names), 2)
    nrows = (len(names) + cols - 1) // cols
    fig, axes = plt.subplots(nrows, cols, figsize=(5.5 * cols, 3.6 * nrows), squeeze=False)
    centres = list(range(len(SJ_EDGES) - 1))
    for ax, name in zip(axes.flat, names):
        series = (("default", "C0", "as meshed"), ("--optimize", "C2", "after the optimiser (mesh --optimize)"))
        for k, (key, color, label) in enumerate(series):
            h = hists.get((name, key))
            if h:
                n = max(1, sum(h))
                ax.bar([c + (k - 0.5) * 0.4 for c in centres], [v / n for v in h], width=0.4, color=color, label=label)
        ax.set_xticks(centres)
        ax.set_xticklabels([f"{a:g}" for a in SJ_EDGES[:-1]], fontsize=7)
        ax.set_yscale("log")
        ax.set_title(name, fontsize=10)
        ax.set_xlabel("scaled Jacobian (bin's lower edge)", fontsize=8)
        ax.set_ylabel("fraction of hexes", fontsize=8)
        ax.legend(fontsize=7)
    for ax in list(axes.flat)[len(names):]:
        ax.axis("off")
    fig.suptitle("scaled Jacobian (9 points per hex) of the default meshes, inside and outside", fontsize=11)
    fig.tight_layout()
    png = os.path.join(o.out, "quality.png")
    fig.savefig(png, dpi=90)
    plt.close(fig)
    return [png]


# ----------------------------------------------------------------------------------- scaling
SCALING_COLUMNS = ["series", "backend", "triangles", "depth", "status", "hexes", "peak_bytes", "bytes_per_hex",
                   "wall_s", "load"]


def stages_of(rows):
    """Every stage some row timed, in pipeline order."""
    seen = [s for s in STAGE_ORDER if any(f"t_{s}" in r for r in rows)]
    for r in rows:
        seen += [k[2:] for k in r if k.startswith("t_") and k != "t_total" and k[2:] not in seen]
    return seen


def scaling_part(o, run, backends):
    path = os.path.join(o.out, "scaling.csv")
    rows = []
    torus_sizes = [(40, 12), (160, 42)] if o.quick else [(40, 12), (80, 24), (160, 42), (320, 84), (640, 168)]
    depths = [1, 2] if o.quick else [1, 2, 3, 4]
    tori = {}
    for nu, nv in torus_sizes:
        f = os.path.join(run.tmp, f"torus_{nu}x{nv}.stl")
        models.write_binary_stl(f, *models.bumpy_torus(nu, nv))
        tori[(nu, nv)] = f
    big = tori[torus_sizes[-1] if o.quick else (320, 84)]
    # One untimed run per backend first: OpenCL compiles its program and Vulkan its pipelines on
    # first use (then cached), which is a one-off cost, not the stage's.
    for b in backends:
        run.mesh(tori[torus_sizes[0]], ["--depth", "1"], backend=b, fidelity=False)
    jobs = [("hexes", b, big, d) for b in backends for d in depths]
    jobs += [("triangles", b, tori[s], 2 if o.quick else 3) for b in backends for s in torus_sizes]
    for series, backend, f, depth in jobs:
        status, rep, wall, rss, load = run.mesh(f, ["--depth", str(depth)], backend=backend, fidelity=False)
        row = {"series": series, "backend": backend, "depth": depth, "status": status,
               "wall_s": f"{wall:.2f}" if wall else "", "load": f"{load:.1f}"}
        if rep:
            hexes = rep["elements"]["inside_hexes"] + rep["elements"]["outside_hexes"]
            row.update(triangles=rep["input"]["triangles"], hexes=hexes, peak_bytes=rep["peak_memory_bytes"],
                       bytes_per_hex=f"{rep['peak_memory_bytes'] / max(1, hexes):.0f}",
                       t_total=f"{rep['times']['total']:.4f}")
            for s, t in rep["times"].items():
                if s not in ("total", "fidelity"):
                    row[f"t_{s}"] = f"{t:.4f}"
        rows.append(row)
        print(f"scaling  {series:9} {backend:7} {os.path.basename(f):22} depth {depth} {status[:30]:30} "
              f"{row.get('hexes', ''):>9} hexes {row.get('t_total', '')} s", flush=True)
        write_rows(path, rows, SCALING_COLUMNS + [f"t_{s}" for s in stages_of(rows)] + ["t_total"],
                   header_lines(o, "scaling"))
    brute = brute_force_rows(o, tori, torus_sizes)
    write_rows(os.path.join(o.out, "brute_force.csv"), brute, BRUTE_COLUMNS, header_lines(o, "brute force"))
    return rows, brute


BRUTE_COLUMNS = ["brute_triangles", "brute_points", "brute_force_s", "brute_bvh_s"]


def scaling_plots(o, plt, rows, brute):
    ok = [r for r in rows if r["status"] == "ok"]
    backends = list(dict.fromkeys(r["backend"] for r in ok))
    return [scaling_figure(plt, ok, "hexes", os.path.join(o.out, "time_vs_hexes.png"), backends, []),
            scaling_figure(plt, ok, "triangles", os.path.join(o.out, "time_vs_triangles.png"), backends, brute)]


def brute_force_rows(o, tori, sizes):
    """perf/bench_sdf on the small tori: BVH queries against the paper's every-triangle loop."""
    exe = os.path.join(o.build, "perf", "bench_sdf")
    out = []
    if not os.access(exe, os.X_OK):
        print("scaling  no perf/bench_sdf in the build: the brute-force contrast is left out")
        return out
    for s in sizes[:2] if o.quick else sizes[:3]:
        proc = subprocess.run([exe, "--model", tori[s], "--grid", "28", "--brute-model"], capture_output=True,
                              text=True)
        line = [x for x in proc.stdout.splitlines() if x.startswith("{")]
        if proc.returncode != 0 or not line:
            print(f"scaling  bench_sdf failed on {os.path.basename(tori[s])}: {proc.stderr.strip()[-200:]}")
            continue
        out.append(json.loads(line[-1]))
        print(f"scaling  brute force {out[-1]['brute_triangles']} triangles: {out[-1]['brute_force_s']:.3f} s "
              f"against the BVH's {out[-1]['brute_bvh_s']:.4f} s", flush=True)
    return out


def scaling_figure(plt, rows, series, path, backends, brute):
    fig, axes = plt.subplots(1, len(backends) + 1, figsize=(4.4 * (len(backends) + 1), 3.8), squeeze=False)
    x_of = (lambda r: int(r["hexes"])) if series == "hexes" else (lambda r: int(r["triangles"]))
    for ax, backend in zip(axes.flat, backends):
        pts = sorted((r for r in rows if r["series"] == series and r["backend"] == backend), key=x_of)
        for k, s in enumerate(stages_of(pts) + ["total"]):
            y = [float(r.get(f"t_{s}") or 0) for r in pts]
            if any(v > 0 for v in y):
                ax.plot([x_of(r) for r in pts], [max(v, 1e-4) for v in y], marker="o", markersize=3,
                        color="k" if s == "total" else f"C{k % 10}", linewidth=2.5 if s == "total" else 1, label=s)
        if series == "triangles" and backend == "cpu" and brute:
            ax.plot([int(b["brute_triangles"]) for b in brute], [float(b["brute_force_s"]) for b in brute], marker="x",
                    color="r", linestyle=":", label="brute-force SDF (paper), same points")
            ax.plot([int(b["brute_triangles"]) for b in brute], [float(b["brute_bvh_s"]) for b in brute], marker="+",
                    color="g", linestyle=":", label="BVH SDF, same points")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(f"--backend {backend}", fontsize=10)
        ax.set_xlabel("output hexes" if series == "hexes" else "input triangles", fontsize=8)
        ax.set_ylabel("seconds per stage", fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=6, ncol=2)
    ax = axes.flat[len(backends)]
    for k, backend in enumerate(backends):
        pts = sorted((r for r in rows if r["series"] == series and r["backend"] == backend), key=x_of)
        ax.plot([x_of(r) for r in pts], [float(r["t_total"]) for r in pts], marker="o", color=f"C{k}", label=backend)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_title("total, every backend", fontsize=10)
    ax.set_xlabel("output hexes" if series == "hexes" else "input triangles", fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    same = sorted({r["triangles" if series == "hexes" else "depth"] for r in rows if r["series"] == series})
    fig.suptitle("bumpy torus, " + (f"{', '.join(f'{int(t):,}' for t in same)} triangles, uniform depths: time against "
                                    "output hexes" if series == "hexes" else
                                    f"uniform depth {', '.join(str(d) for d in same)}: time against input triangles"),
                 fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def memory_figure(plt, fidelity_rows, scaling_rows, path):
    fig, ax = plt.subplots(figsize=(6, 4.2))
    pts = [(int(r["inside_hexes"]) + int(r["outside_hexes"]), float(r["peak_mb"]) * 1e6) for r in fidelity_rows
           if r["status"].startswith("ok")]
    pts += [(int(r["hexes"]), float(r["peak_bytes"])) for r in scaling_rows if r["status"] == "ok"]
    pts = [p for p in pts if p[0] > 0]
    ax.plot([p[0] for p in pts], [p[1] / p[0] for p in pts], marker="o", linestyle="none", markersize=4,
            label="runs of this study")
    if pts:
        xs = [min(p[0] for p in pts), max(p[0] for p in pts)]
        ax.plot(xs, [200, 200], color="r", linestyle="--", label="issue 17's target: 200 B/hex")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("output hexes (inside + outside)")
    ax.set_ylabel("peak memory bytes per output hex")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("peak memory per output hex (process RSS, drivers included)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


# ------------------------------------------------------------------------------- the page
def markdown_table(rows, columns, titles):
    out = ["| " + " | ".join(titles) + " |", "|" + "---|" * len(titles)]
    for r in rows:
        out.append("| " + " | ".join(str(r.get(c, "")) for c in columns) + " |")
    return "\n".join(out)


def write_page(o, parts, figures, meta):
    rel = lambda p: os.path.relpath(p, os.path.dirname(os.path.abspath(o.page)))
    lines = ["# Results: the study regenerated", "",
             "<!-- Written by perf/study.py (bash perf/run_study.sh): edit the script, not this page. -->", "",
             f"Made by `{meta['command']}` at {meta['label']} on {meta['date']}, {meta['cores']} cores, in "
             f"{meta['minutes']:.1f} min" + (" (--quick: small settings, not figures)" if meta["quick"] else "") + ". Every figure of ours is read from "
             "a `mchex-gpu mesh` report; the machine is shared, so read times as ratios within this run (each "
             "CSV row has the load average as its run started). The other benchmarks (`bash perf/run.sh`) and "
             "their notes: [CURVES.md](CURVES.md), [FORMATS.md](FORMATS.md), [GPU_RUNS.md](GPU_RUNS.md).", ""]
    if "fidelity" in parts:
        rows, path = parts["fidelity"], os.path.join(o.out, "fidelity.csv")
        lines += ["## MCHex against RO", "",
                  "The paper's comparison (Section 7): RO keeps the cells whose corner values sum above zero, "
                  "MCHex cuts every cell the surface crosses. Uniform grids (`--depth D`): both methods mesh the "
                  "same cells. The fitted adaptive grid (`--hausdorff H`, the default grid): each method gets its "
                  "own, as a user would, since the measured rounds refine where that method's mesh is far from "
                  "the input (docs/pipeline.md). `--backend cpu`. The star is the MCHex prototype at its defaults "
                  "(perf/curves/prototype.csv, measured by another checker). Command per point: `mchex-gpu mesh "
                  "MODEL SETTING --method M --backend cpu --fidelity --lattice "
                  f"{o.lattice}`.", ""]
        lines += [f"![{os.path.basename(f)}]({rel(f)})" for f in figures["fidelity"]] + [""]
        def per_hex(r):
            # Issue 17's memory target is in bytes per output hex (the peak as the report has it).
            if r["inside_hexes"] == "" or r.get("peak_mb", "") == "":
                return ""
            return f"{float(r['peak_mb']) * 1e6 / (int(r['inside_hexes']) + int(r['outside_hexes'])):.0f}"
        shown = [dict(r, hexes=(f"{int(r['inside_hexes']):,} + {int(r['outside_hexes']):,}"
                                if r["inside_hexes"] != "" else ""), bytes_per_hex=per_hex(r)) for r in rows]
        lines += [markdown_table(shown, ["model", "method", "setting", "hexes", "iou", "hr", "min_sj", "seconds",
                                         "peak_mb", "bytes_per_hex", "status"],
                                 ["model", "method", "setting", "hexes (in + out)", "IoU", "HR", "min SJ", "s", "MB",
                                  "B/hex", "status"]), "", f"Table: [{os.path.basename(path)}]({rel(path)})", ""]
    if "quality" in parts:
        rows, path = parts["quality"], os.path.join(o.out, "quality.csv")
        lines += ["## Element quality", "",
                  "Scaled Jacobian at the 8 corners and the centre of every hex of both meshes, from the report's "
                  "check (`mchex-gpu mesh MODEL [--optimize]`), and every hex's Bernstein certificate.", ""]
        lines += [f"![{os.path.basename(f)}]({rel(f)})" for f in figures["quality"]] + [""]
        lines += [markdown_table(rows, ["model", "setting", "hexes", "min_sj", "mean_sj", "max_edge_ratio",
                                        "min_dihedral", "certified", "status"],
                                 ["model", "setting", "hexes", "min SJ", "mean SJ", "max edge ratio",
                                  "min dihedral", "certified", "status"]), "",
                  f"Table: [{os.path.basename(path)}]({rel(path)})", ""]
    if "scaling" in parts:
        (rows, brute), path = parts["scaling"], os.path.join(o.out, "scaling.csv")
        lines += ["## Time and memory", "",
                  "Seconds per stage from the report (`times`: the stages and `other` sum to `total`, the wall time "
                  "from start to written files; docs/trace.md), `mchex-gpu mesh TORUS --depth D --backend B "
                  "--no-fidelity`, on the bumpy torus of tests/models.py. Device backends here are CPU drivers "
                  "(PoCL, lavapipe): their curves show overheads, not GPU speed (perf/GPU_RUNS.md).", ""]
        lines += [f"![{os.path.basename(f)}]({rel(f)})" for f in figures["scaling"]] + [""]
        stages = stages_of(rows)
        lines += [markdown_table(rows, ["series", "backend", "triangles", "depth", "hexes", "t_total"] +
                                 [f"t_{s}" for s in stages] + ["bytes_per_hex", "status"],
                                 ["series", "backend", "triangles", "depth", "hexes", "total s"] +
                                 [f"{s} s" for s in stages] + ["B/hex", "status"]), "",
                  f"Table: [{os.path.basename(path)}]({rel(path)})", ""]
        if brute:
            lines += ["Reference SDF against the paper's brute-force loop (`perf/bench_sdf --model TORUS --grid 28 "
                      "--brute-model`, one thread, the same points):", "",
                      markdown_table([dict(b, ratio=f"{float(b['brute_force_s']) / float(b['brute_bvh_s']):.0f}x") for b in brute],
                                     ["brute_triangles", "brute_points", "brute_force_s", "brute_bvh_s", "ratio"],
                                     ["triangles", "points", "brute force s", "BVH s", "BVH faster by"]), ""]
        lines += [f"![memory_per_hex.png]({rel(os.path.join(o.out, 'memory_per_hex.png'))})", ""]
    tmp = o.page + ".part"
    with open(tmp, "w") as f:
        f.write("\n".join(lines))
    os.replace(tmp, o.page)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--out", default=os.path.join(HERE, "results"))
    ap.add_argument("--page", default=os.path.join(HERE, "README.md"))
    ap.add_argument("--quick", action="store_true", help="small settings: checks the script in minutes")
    ap.add_argument("--plot-only", action="store_true",
                    help="measure nothing: redraw the plots and the page from the CSVs in --out")
    ap.add_argument("--parts", default="fidelity,quality,scaling")
    ap.add_argument("--models", help="fidelity part: comma-separated subset of " + ", ".join(curves.MODELS))
    ap.add_argument("--backends", default="cpu,opencl,vulkan")
    ap.add_argument("--lattice", type=int, default=128)
    ap.add_argument("--max-hexes", type=float, default=6e6)
    ap.add_argument("--max-memory", default="12G")
    ap.add_argument("--timeout", type=float, default=900)
    o = ap.parse_args()
    wanted = [p for p in o.parts.split(",") if p]
    unknown = set(wanted) - {"fidelity", "quality", "scaling"}
    if unknown:
        sys.exit(f"study.py: unknown part(s) {', '.join(sorted(unknown))}; known: fidelity, quality, scaling")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        sys.exit("study.py: matplotlib is missing (Debian: python3-matplotlib; setup.sh installs it)")
    meta_path = os.path.join(o.out, "study.json")
    parts = {}
    if o.plot_only:
        csvs = {"fidelity": "fidelity.csv", "quality": "quality.csv", "scaling": "scaling.csv"}
        for part in wanted:
            path = os.path.join(o.out, csvs[part])
            if os.path.exists(path):
                parts[part] = curves.read_csv(path)
        if "scaling" in parts:
            brute = os.path.join(o.out, "brute_force.csv")
            parts["scaling"] = (parts["scaling"], curves.read_csv(brute) if os.path.exists(brute) else [])
        if not parts or not os.path.exists(meta_path):
            sys.exit(f"study.py: --plot-only: no study CSVs (or study.json) in {o.out}: run the study first")
        with open(meta_path) as f:
            meta = json.load(f)
    else:
        exe = os.path.join(o.build, "host", "mchex-gpu")
        if not os.access(exe, os.X_OK):
            sys.exit(f"study.py: no mchex-gpu binary at {exe}: build first (README) or pass --build DIR")
        if not os.path.isdir(curves.NPM):
            sys.exit("study.py: the npm test models are missing (tests/data/npm): run setup.sh")
        listed = subprocess.run([exe, "devices"], capture_output=True, text=True).stdout.split()
        backends = [b for b in o.backends.split(",") if b == "cpu" or b in listed]
        os.makedirs(o.out, exist_ok=True)
        o.label = curves.git_label()  # as the study starts: the tree the binary was built from
        start = time.monotonic()
        with tempfile.TemporaryDirectory(prefix="study_") as tmp:
            run = Runner(o, tmp)
            if "fidelity" in wanted:
                parts["fidelity"] = fidelity_part(o, run)
            if "quality" in wanted:
                parts["quality"] = quality_part(o, run)
            if "scaling" in wanted:
                parts["scaling"] = scaling_part(o, run, backends)
        meta = {"command": "bash perf/run_study.sh" + (" --quick" if o.quick else ""), "label": o.label,
                "date": f"{datetime.datetime.utcnow():%Y-%m-%d %H:%M} UTC", "cores": os.cpu_count(),
                "minutes": (time.monotonic() - start) / 60, "quick": o.quick}
        with open(meta_path, "w") as f:
            json.dump(meta, f, indent=1)
    figures = {}
    if "fidelity" in parts:
        figures["fidelity"] = fidelity_plots(o, plt, parts["fidelity"])
    if "quality" in parts:
        figures["quality"] = quality_plots(o, plt, parts["quality"])
    if "scaling" in parts:
        figures["scaling"] = scaling_plots(o, plt, *parts["scaling"])
        memory_figure(plt, parts.get("fidelity", []), parts["scaling"][0], os.path.join(o.out, "memory_per_hex.png"))
    write_page(o, parts, figures, meta)
    print(f"study.py: {o.out} and {o.page} written")


if __name__ == "__main__":
    main()
