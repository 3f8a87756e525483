#!/usr/bin/python3
"""Output hexes against fidelity: IoU and HR (the two-sided Hausdorff distance over the input's
bounding-box diagonal) of the inside mesh against its inside hex count, for the uniform grid
(`--depth`) and the adaptive grid (`--threshold T --max-depth D`, optionally `--hausdorff H`) on
the project's test models, next to the MCHex prototype's points. Writes a CSV, then PNG plots.

  /usr/bin/python3 perf/curves.py run  [--build build] [--csv perf/curves/baseline.csv] [--label L]
                                       [--models bunny,cube,...] [--depths 2,3,4]
                                       [--max-depths 3,4] [--thresholds 0.05,0.3,1]
                                       [--hausdorff H1,H2] [--no-uniform] [--no-adaptive]
                                       [--compare OTHER.csv ...] [--plots perf/curves]
  /usr/bin/python3 perf/curves.py plot CSV [CSV ...] [--plots perf/curves]
  /usr/bin/python3 perf/curves.py table CSV [CSV ...]      (a Markdown table, as in perf/CURVES.md)

How each figure is measured. Every point of ours comes from one `mchex-gpu mesh MODEL SETTING
--backend cpu --fidelity --report R.json` run and is read from its report: elements.inside_hexes
and outside_hexes, fidelity.iou (on the report's lattice^3 lattice over the box) and
fidelity.hausdorff_ratio, iou_bound (min over max of the inside mesh's exact volume,
check.inside.quality.volume, and the input's, input.volume: no IoU can exceed it, whatever the
lattice), times.total less times.fidelity (the meshing run as a user sees it:
read, SDF, grid, cutting, check and write, without the fidelity measure itself), and
peak_memory_bytes (taken while the fidelity measure also ran). The process's own wall time and
maximum RSS are recorded beside them. So all of our points, uniform and adaptive, old grid and
new, are measured by the same `--fidelity` code. The prototype's points (perf/curves/prototype.csv)
were measured by a different, independent checker (a 200 x 200 column scan with exact crossings
for the IoU, surfaces sampled on both sides for HR), and its box is 1.003x the model's largest
extent where ours is 1.2x (`--pad 0.1`): compare inside counts, IoU and HR, not outside counts.

Bounds: a uniform depth whose hex count (about 8 x 27^depth) is over --max-hexes is skipped;
thresholds of one max depth run from coarse to fine and stop once a run passes --max-hexes;
every run gets `--max-memory` (the CLI refuses, exit 2, a run whose estimate is over it) and
--timeout. Skipped and refused settings are rows too, with their reason in `status`.

Models: npm `bunny` (its index.js positions and cells written as OBJ), npm `stl-models`
objects/gearwheel.bin.stl, polytopes/cube.bin.stl and polytopes/tetrahedronIrregular.bin.stl
(setup.sh installs both packages into tests/data/npm), and from tests/models.py the bumpy torus
(320 x 84, 53,760 triangles), the trefoil tube (300 x 30; a tube of diameter 0.7 around a knot
about 6 across) and a thin ring (the bumpy torus with tube radius 0.1: a tube about 2 depth-3
cells across, under one depth-2 cell): the last two are thin parts that a coarse grid loses.
The IoU lattice (128 per axis by default) puts only about 10 samples across the thin ring's tube,
so its IoU is coarse; pass --lattice for a finer one (cubic cost)."""
import argparse
import csv
import datetime
import json
import os
import platform
import signal
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(ROOT, "tests"))
import models  # noqa: E402  (tests/models.py: closed test surfaces written with numpy)

NPM = os.path.join(ROOT, "tests", "data", "npm", "node_modules")
STL_MODELS = os.path.join(NPM, "stl-models")

COLUMNS = ["model", "triangles", "label", "grid", "setting", "depth", "max_depth", "threshold", "hausdorff",
           "status", "inside_hexes", "outside_hexes", "iou", "iou_bound", "hr", "min_sj", "certified", "hausdorff_distance", "seconds",
           "seconds_fidelity", "seconds_total", "peak_mb", "wall_s", "max_rss_mb", "load", "lattice", "backend",
           "threads"]


def bunny_obj(path):
    """npm bunny's index.js (`exports.positions=[...]`, `exports.cells=[...]`, 0-based) as OBJ."""
    with open(os.path.join(NPM, "bunny", "index.js")) as f:
        text = f.read()
    arrays = {}
    for part in text.split("exports.")[1:]:
        name, value = part.split("=", 1)
        arrays[name.strip()] = json.loads(value.strip().rstrip(";"))
    with open(path, "w") as f:
        for p in arrays["positions"]:
            f.write("v %r %r %r\n" % tuple(p))
        for c in arrays["cells"]:
            f.write("f %d %d %d\n" % tuple(i + 1 for i in c))
    return path


def package_file(*parts):
    def make(_path):
        return os.path.join(STL_MODELS, *parts)
    return make


def numpy_model(build):
    def make(path):
        v, t = build()
        models.write_binary_stl(path, v, t)
        return path
    return make


# name -> (file extension, maker(path) -> the file to mesh, needs the npm packages)
MODELS = {
    "bunny": (".obj", bunny_obj, True),
    "gearwheel": (".stl", package_file("objects", "gearwheel.bin.stl"), True),
    "cube": (".stl", package_file("polytopes", "cube.bin.stl"), True),
    "tetrahedron": (".stl", package_file("polytopes", "tetrahedronIrregular.bin.stl"), True),
    "bumpy-torus": (".stl", numpy_model(lambda: models.bumpy_torus(320, 84)), False),
    "trefoil-tube": (".stl", numpy_model(lambda: models.trefoil_tube(300, 30)), False),
    "thin-ring": (".stl", numpy_model(lambda: models.bumpy_torus(320, 84, minor=0.1)), False),
}


def number_list(text, kind=float):
    return [kind(x) for x in text.split(",") if x.strip()] if text else []


def git_label():
    try:
        head = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short=7", "HEAD"], capture_output=True,
                              text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", ROOT, "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True).stdout.strip()
        return head + ("+changes" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def mesh_once(exe, model_file, setting_args, o, tmp, backend="cpu", fidelity=True):
    """One `mesh` run: (status, report or None, wall s, max RSS MB)."""
    report = os.path.join(tmp, "report.json")
    for f in ("report.json", "in.mesh", "out.mesh"):
        if os.path.exists(os.path.join(tmp, f)):
            os.remove(os.path.join(tmp, f))
    measure = ["--fidelity", "--lattice", str(o.lattice)] if fidelity else ["--no-fidelity"]
    crossings = ["--crossings", o.crossings] if getattr(o, "crossings", "linear") != "linear" else []
    cmd = [exe, "mesh", model_file, *setting_args, *crossings, "--backend", backend, *measure, "--max-memory", o.max_memory, "--report", report, "-o", os.path.join(tmp, "in.mesh"), "--outside",
           os.path.join(tmp, "out.mesh"), "--quiet"]
    if o.threads:
        cmd += ["--threads", str(o.threads)]
    err_path = os.path.join(tmp, "stderr.txt")
    o.load = os.getloadavg()[0]  # the machine's 1-minute load as the run starts: timings read against it
    start = time.monotonic()
    with open(err_path, "w") as err_file:
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err_file)
    # os.wait4 gives this child's own rusage (its maximum RSS), which RUSAGE_CHILDREN would not.
    while True:
        pid, wait_status, usage = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            break
        if time.monotonic() - start > o.timeout:
            proc.send_signal(signal.SIGTERM)
            os.wait4(proc.pid, 0)
            proc.returncode = -1
            return f"timeout after {o.timeout:g} s", None, time.monotonic() - start, None
        time.sleep(0.05)
    wall = time.monotonic() - start
    rss_mb = usage.ru_maxrss / 1024.0  # KiB -> MiB
    code = os.waitstatus_to_exitcode(wait_status)
    proc.returncode = code  # already reaped: keep Popen from waiting on it again
    if code != 0:
        with open(err_path) as f:
            last = f.read().strip().splitlines()[-1:] or [f"exit {code}"]
        kind = "refused" if code == 2 else f"failed (exit {code})"
        return f"{kind}: {last[0]}", None, wall, rss_mb
    with open(report) as f:
        return "ok", json.load(f), wall, rss_mb


def number(value, spec):
    """A report figure as CSV text. JSON has no infinity: the report writes the Hausdorff distance
    of an empty inside mesh (a model thinner than the grid resolves) as null, so null is "inf"."""
    return "inf" if value is None else format(value, spec)


def row_from(model, tris, label, grid, setting, params, status, rep, wall, rss, load):
    row = {c: "" for c in COLUMNS}
    row.update(model=model, triangles=tris, label=label, grid=grid, setting=setting, status=status, **params)
    if wall is not None:
        row["wall_s"] = f"{wall:.2f}"
        row["load"] = f"{load:.1f}"
    if rss is not None:
        row["max_rss_mb"] = f"{rss:.0f}"
    if rep:
        e, fid, t = rep["elements"], rep.get("fidelity", {}), rep["times"]
        row.update(inside_hexes=e["inside_hexes"], outside_hexes=e["outside_hexes"],
                   iou=number(fid.get("iou"), ".6f"), hr=number(fid.get("hausdorff_ratio"), ".6f"),
                   hausdorff_distance=number(fid.get("hausdorff"), ".6g"),
                   seconds=f"{t['total'] - t.get('fidelity', 0.0):.2f}", seconds_fidelity=f"{t.get('fidelity', 0.0):.2f}",
                   seconds_total=f"{t['total']:.2f}", peak_mb=f"{rep['peak_memory_bytes'] / 1e6:.0f}",
                   lattice=fid.get("lattice", ""), backend=rep["backend"]["name"], threads=rep["backend"]["threads"])
        q = rep["check"].get("inside", {}).get("quality", {})
        solid_volume = rep["input"].get("volume")
        if q.get("volume") is not None and solid_volume:
            # |M n S| <= min(|M|, |S|) and |M u S| >= max(|M|, |S|): exact volumes bound the IoU.
            lo_v, hi_v = sorted((abs(q["volume"]), abs(solid_volume)))
            row["iou_bound"] = f"{lo_v / hi_v:.6f}" if hi_v else ""
        if q.get("count"):
            row["min_sj"] = number(q.get("min_scaled_jacobian"), ".3g")
            row["certified"] = f"{q['certified']}/{q['count']}"
        row["triangles"] = rep["input"].get("triangles", tris)
        if not rep["check"].get("ok", True):
            row["status"] = "ok (check failed: meshes not written)"
    return row


def write_csv(path, rows, header):
    tmp = path + ".part"
    with open(tmp, "w", newline="") as f:
        for line in header:
            f.write(f"# {line}\n")
        w = csv.DictWriter(f, COLUMNS)
        w.writeheader()
        w.writerows(rows)
    os.replace(tmp, path)


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def settings(o):
    """(grid, setting text, CLI args, CSV params, predicted hexes or None), in run order."""
    out = []
    if not o.no_uniform:
        for d in number_list(o.depths, int):
            out.append(("uniform", f"--depth {d}", ["--depth", str(d)], {"depth": d}, 8 * 27**d))
    if not o.no_adaptive:
        hs = number_list(o.hausdorff) or [None]
        for d in number_list(o.max_depths, int):
            for h in hs:
                for t in sorted(number_list(o.thresholds), reverse=True):  # coarse to fine
                    args = ["--threshold", f"{t:g}", "--max-depth", str(d)]
                    params = {"max_depth": d, "threshold": t}
                    if h is not None:
                        args += ["--hausdorff", f"{h:g}"]
                        params["hausdorff"] = h
                    out.append(("adaptive", " ".join(args), args, params, None))
    return out


def run(o):
    exe = os.path.join(o.build, "host", "mchex-gpu")
    if not (os.path.isfile(exe) and os.access(exe, os.X_OK)):
        sys.exit(f"curves.py: no mchex-gpu binary at {exe}: build first "
                 f"(cmake -S . -B build -G Ninja && cmake --build build) or pass --build DIR")
    names = o.models.split(",") if o.models else list(MODELS)
    unknown = [n for n in names if n not in MODELS]
    if unknown:
        sys.exit(f"curves.py: unknown model(s) {', '.join(unknown)}; known: {', '.join(MODELS)}")
    if any(MODELS[n][2] for n in names) and not os.path.isdir(NPM):
        sys.exit(f"curves.py: the npm test models are missing ({os.path.relpath(NPM, ROOT)}): run setup.sh, "
                 f"or choose --models from {', '.join(n for n in MODELS if not MODELS[n][2])}")
    label = o.label or git_label()
    header = [f"perf/curves.py run: mchex-gpu at {label}, --backend cpu, --crossings {o.crossings}, "
              f"fidelity lattice {o.lattice}, "
              f"{datetime.datetime.utcnow():%Y-%m-%d %H:%M} UTC, {platform.node() or 'host'} "
              f"({os.cpu_count()} cores)",
              "seconds = report times.total - times.fidelity; peak_mb = report peak_memory_bytes / 1e6 "
              "(with the fidelity measure); max_rss_mb = the process's maximum RSS in MiB (os.wait4); "
              "load = the 1-minute load average as the run started (the machine is shared: read seconds against it)"]
    rows = []
    os.makedirs(os.path.dirname(os.path.abspath(o.csv)), exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="curves_") as tmp:
        for name in names:
            ext, make, _ = MODELS[name]
            model_file = make(os.path.join(tmp, name + ext))
            tris = ""
            stopped = set()  # (max_depth, hausdorff) whose finer thresholds are past --max-hexes
            for grid, text, args, params, predicted in settings(o):
                family = (params.get("max_depth"), params.get("hausdorff"))
                if predicted is not None and predicted > o.max_hexes:
                    status, rep, wall, rss = f"skipped: about {predicted:.3g} hexes > --max-hexes", None, None, None
                elif grid == "adaptive" and family in stopped:
                    status, rep, wall, rss = "skipped: a coarser threshold passed --max-hexes", None, None, None
                else:
                    status, rep, wall, rss = mesh_once(exe, model_file, args, o, tmp)
                    if rep and rep["elements"]["inside_hexes"] + rep["elements"]["outside_hexes"] > o.max_hexes:
                        stopped.add(family)
                row = row_from(name, tris, label, grid, text, params, status, rep, wall, rss, getattr(o, "load", 0.0))
                tris = row["triangles"]
                rows.append(row)
                print(f"{name:13} {text:44} {status[:40]:40} in {row['inside_hexes']:>9} out "
                      f"{row['outside_hexes']:>9} IoU {row['iou']:>8} HR {row['hr']:>8} {row['seconds']:>6} s "
                      f"{row['peak_mb']:>5} MB", flush=True)
                write_csv(o.csv, rows, header)  # after every run, so a stopped sweep keeps its rows
    print(f"curves.py: {len(rows)} rows -> {o.csv}")
    plot([o.csv, *o.compare], o.plots, o.reference)


IOU_FLOOR = 1e-4  # 1 - IoU is drawn on a log axis: an IoU of 1 on the lattice sits at this floor


def series_name(key):
    label, grid, d = key
    return f"uniform {label}" if grid == "uniform" else f"adaptive D={d} {label}"


def fidelity_of(r, metric):
    return max(1 - float(r["iou"]), IOU_FLOOR) if metric == "iou" else float(r["hr"])


def hexes_of(r, axis):
    return int(r["inside_hexes"]) + (int(r["outside_hexes"]) if axis == "all" else 0)


def legend_once(fig, axes, used):
    """Blanks the panels after the first `used` and draws one legend for the figure, each label
    once (panels share their series)."""
    for ax in list(axes.flat)[used:]:
        ax.axis("off")
    handles = {}
    for ax in axes.flat:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(lab, h)
    fig.legend(handles.values(), handles.keys(), loc="lower right", fontsize=8)


def fidelity_figure(plt, names, curves, styles, proto, metric, axis, path):
    """One panel per model: hexes (inside, or inside + outside) against 1 - IoU or HR, a curve per
    series, the prototype's point as a black star."""
    cols = 4
    nrows = (len(names) + cols - 1) // cols
    fig, axes = plt.subplots(nrows, cols, figsize=(4.2 * cols, 3.6 * nrows), squeeze=False)
    # Uniform first and wide, so the adaptive points (often the same mesh) stay visible on top.
    order = sorted(curves, key=lambda k: (k[1] != "uniform", k))
    for ax, name in zip(axes.flat, names):
        for key in order:
            pts = [r for r in curves[key] if r["model"] == name and int(r["inside_hexes"]) > 0
                   and r[metric] not in ("", "inf")]
            pts.sort(key=lambda r: hexes_of(r, axis))
            if not pts:
                continue
            x = [hexes_of(r, axis) for r in pts]
            y = [fidelity_of(r, metric) for r in pts]
            color, marker = styles[key]
            uniform = key[1] == "uniform"
            ax.plot(x, y, marker=marker, color=color, label=series_name(key), linestyle="-" if uniform else "--",
                    linewidth=3 if uniform else 1.2, markersize=8 if uniform else 5, alpha=0.6 if uniform else 1)
            # One label per distinct point: settings that give the same mesh share it.
            tags = {}
            for r, xi, yi in zip(pts, x, y):
                tag = r["depth"] if uniform else r["threshold"] + (f"/H{r['hausdorff']}" if r["hausdorff"] else "")
                tags.setdefault((xi, yi), []).append(tag)
            for (xi, yi), t in tags.items():
                ax.annotate(",".join(t), (xi, yi), fontsize=6, color=color, textcoords="offset points",
                            xytext=(3, -9 if uniform else 3))
        if name in proto:
            p = proto[name]
            ax.plot([hexes_of(p, axis)], [fidelity_of(p, metric)], marker="*", markersize=13, color="k",
                    linestyle="none", label="MCHex prototype (0b7016b, other checker)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(name, fontsize=10)
        ax.set_xlabel("inside hexes" if axis == "inside" else "all output hexes (inside + outside)", fontsize=8)
        ax.set_ylabel("1 - IoU (lower is better)" if metric == "iou" else "HR (lower is better)", fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
    legend_once(fig, axes, len(names))
    what = "1 - IoU" if metric == "iou" else "HR (Hausdorff / input bounding-box diagonal)"
    note = f"; 1 - IoU under {IOU_FLOOR:g} drawn at {IOU_FLOOR:g}" if metric == "iou" else ""
    fig.suptitle(f"{'inside' if axis == 'inside' else 'all output'} hexes against {what} "
                 f"(point labels: depth, or threshold{note})", fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def cost_figure(plt, curves, styles, path):
    """Seconds and peak memory against all output hexes, every model in one panel each."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for key in sorted(curves):
        color, marker = styles[key]
        x = [hexes_of(r, "all") for r in curves[key]]
        for ax, col in zip(axes, ("seconds", "peak_mb")):
            ax.plot(x, [float(r[col]) for r in curves[key]], marker=marker, color=color, linestyle="none",
                    label=series_name(key))
    for ax, yl in zip(axes, ("seconds (without the fidelity measure)", "peak memory MB (with it)")):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("all output hexes (inside + outside)")
        ax.set_ylabel(yl)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def plot(csvs, out_dir, reference):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        sys.exit("curves.py: matplotlib is missing (Debian: apt-get install python3-matplotlib; setup.sh has it)")
    rows = [r for path in csvs for r in read_csv(path) if r["status"].startswith("ok")]
    proto = {r["model"]: r for r in read_csv(reference)} if reference and os.path.exists(reference) else {}
    names = [n for n in MODELS if any(r["model"] == n for r in rows)]
    if not names:
        sys.exit("curves.py: no measured rows to plot")
    os.makedirs(out_dir, exist_ok=True)
    # One curve per (label, grid, max depth), its points in hex order; one colour and marker each.
    curves = {}
    for r in rows:
        curves.setdefault((r["label"], r["grid"], r["max_depth"]), []).append(r)
    markers = "osD^v<>ph"
    styles = {key: (f"C{i % 10}", markers[i % len(markers)]) for i, key in enumerate(sorted(curves))}
    written = []
    for metric in ("iou", "hr"):
        for axis, suffix in (("inside", ""), ("all", "_all")):
            path = os.path.join(out_dir, f"{metric}{suffix}.png")
            fidelity_figure(plt, names, curves, styles, proto, metric, axis, path)
            written.append(path)
    path = os.path.join(out_dir, "cost.png")
    cost_figure(plt, curves, styles, path)
    written.append(path)
    print("curves.py: plots " + ", ".join(written))


def table(csvs):
    """The CSVs' rows as one Markdown table (perf/CURVES.md's baseline table)."""
    print("| model | setting | inside hexes | outside hexes | IoU | IoU bound | HR | min SJ | s | MB | status |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    for path in csvs:
        for r in read_csv(path):
            ok = r["status"].startswith("ok")
            count = lambda k: f"{int(r[k]):,}" if r[k] else ""
            four = lambda v: v if v in ("", "inf") else f"{float(v):.4f}"
            print(f"| {r['model']} | `{r['setting']}` | {count('inside_hexes')} | {count('outside_hexes')} | "
                  f"{four(r['iou']) if ok else ''} | {four(r['iou_bound']) if ok else ''} | {four(r['hr']) if ok else ''} | {r['min_sj']} | {r['seconds']} | "
                  f"{r['peak_mb']} | {'' if r['status'] == 'ok' else r['status']} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="command", required=True)
    default_ref = os.path.join(HERE, "curves", "prototype.csv")
    r = sub.add_parser("run", help="mesh every model at every setting, write the CSV, plot")
    r.add_argument("--build", default=os.path.join(ROOT, "build"))
    r.add_argument("--csv", default=os.path.join(HERE, "curves", "baseline.csv"))
    r.add_argument("--label", help="the series' name in the CSV and legends (default: the git commit)")
    r.add_argument("--models", help="comma-separated subset of: " + ", ".join(MODELS))
    r.add_argument("--depths", default="2,3,4", help="uniform grid depths")
    r.add_argument("--max-depths", default="3,4", help="adaptive --max-depth values")
    r.add_argument("--thresholds", default="0.05,0.3,1", help="adaptive --threshold values")
    r.add_argument("--hausdorff", default="", help="adaptive --hausdorff values (the new grid); none: no flag")
    r.add_argument("--no-uniform", action="store_true")
    r.add_argument("--no-adaptive", action="store_true")
    r.add_argument("--lattice", type=int, default=128, help="the CLI's --lattice (IoU samples per axis)")
    r.add_argument("--crossings", default="linear", choices=("linear", "exact"),
                   help="the CLI's --crossings (docs/pipeline.md, \"Exact crossings\")")
    r.add_argument("--threads", type=int, default=0, help="the CLI's --threads (default: all cores)")
    r.add_argument("--max-hexes", type=float, default=5e6)
    r.add_argument("--max-memory", default="4G", help="the CLI's --max-memory")
    r.add_argument("--timeout", type=float, default=600, help="seconds per run")
    r.add_argument("--compare", nargs="*", default=[], help="more CSVs drawn on the same plots")
    r.add_argument("--plots", default=os.path.join(HERE, "curves"), help="folder for iou.png, hr.png (inside hexes), iou_all.png, hr_all.png, cost.png")
    r.add_argument("--reference", default=default_ref, help="the prototype's points")
    p = sub.add_parser("plot", help="plot CSVs written by `run`")
    p.add_argument("csvs", nargs="+")
    p.add_argument("--plots", default=os.path.join(HERE, "curves"))
    p.add_argument("--reference", default=default_ref)
    t = sub.add_parser("table", help="print CSVs written by `run` as a Markdown table")
    t.add_argument("csvs", nargs="+")
    o = ap.parse_args()
    if o.command == "run":
        run(o)
    elif o.command == "plot":
        plot(o.csvs, o.plots, o.reference)
    else:
        table(o.csvs)


if __name__ == "__main__":
    main()
