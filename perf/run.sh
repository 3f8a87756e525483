#!/usr/bin/env bash
# Runs every benchmark on an existing build and collects their JSON lines in perf/results.jsonl.
# Usage: bash perf/run.sh [build-dir]
set -euo pipefail
build=${1:-build}
here=$(cd "$(dirname "$0")" && pwd)
out="$here/results.jsonl"
: >"$out"
for bench in "$build"/perf/bench_*; do
  [ -x "$bench" ] || continue
  echo "== $(basename "$bench")"
  "$bench" | tee /dev/stderr | grep '^{' >>"$out"
done 2>&1
echo "== bench_end_to_end.py"
/usr/bin/python3 "$here/bench_end_to_end.py" --build "$build" 2>&1 | tee /dev/stderr | grep '^{' >>"$out"
echo "results: $out"
