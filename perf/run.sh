#!/usr/bin/env bash
# Runs every benchmark on an existing build and collects their JSON lines in perf/results.jsonl.
# Usage: bash perf/run.sh [build-dir]
set -euo pipefail
build=${1:-build}
here=$(cd "$(dirname "$0")" && pwd)
out="$here/results.jsonl"
: >"$out"
# npm's stl-models (setup.sh) for bench_adaptive: a closed gearwheel and an open bunny.
models=()
for f in gearwheel bunny; do
  m="$here/../tests/data/npm/node_modules/stl-models/objects/$f.bin.stl"
  [ -f "$m" ] && models+=(--model "$m")
done
for bench in "$build"/perf/bench_*; do
  [ -x "$bench" ] || continue
  echo "== $(basename "$bench")"
  args=()
  [ "$(basename "$bench")" = bench_adaptive ] && args=("${models[@]}")
  "$bench" "${args[@]}" | tee /dev/stderr | grep '^{' >>"$out"
done 2>&1
echo "== bench_end_to_end.py"
/usr/bin/python3 "$here/bench_end_to_end.py" --build "$build" 2>&1 | tee /dev/stderr | grep '^{' >>"$out"
echo "== bench_regions.py"
/usr/bin/python3 "$here/bench_regions.py" --build "$build" 2>&1 | tee /dev/stderr | grep '^{' >>"$out"
echo "results: $out"
