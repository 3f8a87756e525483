#!/usr/bin/env bash
# Regenerates the study (perf/study.py: MCHex against RO, element quality, time and memory per
# stage and backend) into perf/results/ and its page perf/README.md, from an existing build.
# Usage: bash perf/run_study.sh [--build build] [--quick] [--parts fidelity,quality,scaling] ...
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
exec /usr/bin/python3 "$here/study.py" "$@"
