#!/usr/bin/env bash
# The sanitizer and fuzz passes of CI (run by .ci/run after the test suite), on CPU-only builds:
# the OpenCL and Vulkan drivers (PoCL, lavapipe) are not instrumented and their JIT code trips
# AddressSanitizer's checks, and nothing in the readers depends on a device.
#   1. the test suite built with AddressSanitizer + UndefinedBehaviorSanitizer (gcc), every
#      report fatal;
#   2. a bounded libFuzzer pass (clang, the readers instrumented) over every reader: surfaces
#      (STL, OBJ, OFF, PLY) and hex meshes (.mesh, .vtu, .msh), seeded from the test models.
# Usage: bash .ci/sanitize.sh [SECONDS_PER_FUZZER]   (default 60)
set -euo pipefail
cd "$(dirname "$0")/.."
fuzz_seconds=${1:-60}
cpu_only=(-DMCHEX_WITH_OPENCL=OFF -DMCHEX_WITH_VULKAN=OFF)

export ASAN_OPTIONS=abort_on_error=1:detect_leaks=1:strict_string_checks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
cmake -S . -B build-asan -G Ninja "${cpu_only[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMCHEX_SANITIZE=ON
cmake --build build-asan
ctest --test-dir build-asan --output-on-failure -j2

cmake -S . -B build-fuzz -G Ninja "${cpu_only[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
      -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DMCHEX_FUZZ=ON
cmake --build build-fuzz --target fuzz_read_surface fuzz_read_mesh

# Seeds: the first byte of each picks the extension (the targets' rule), the rest is a real file.
seeds=build-fuzz/seeds
rm -rf "$seeds" && mkdir -p "$seeds/surface" "$seeds/mesh"
seed() {  # seed DIR INDEX FILE
  local out="$1/$(basename "$3").$2"
  { printf "\\$(printf '%03o' "$2")"; head -c 20000 "$3"; } > "$out"
}
models=tests/data/npm/node_modules/stl-models
for f in "$models"/polytopes/*.stl "$models"/broken/*.stl /usr/share/openscad/testdata/scad/3D/features/import*.stl; do
  [ -f "$f" ] && seed "$seeds/surface" 0 "$f"
done
for f in /usr/share/assimp/models/OBJ/*.obj; do [ -f "$f" ] && seed "$seeds/surface" 1 "$f"; done
for f in /usr/share/assimp/models/OFF/*.off; do [ -f "$f" ] && seed "$seeds/surface" 2 "$f"; done
for f in /usr/share/assimp/models/PLY/*.ply; do
  [ -f "$f" ] && [ "$(stat -c %s "$f")" -lt 20000 ] && seed "$seeds/surface" 3 "$f"
done
for ext in mesh vtu msh; do
  build-asan/host/mchex-gpu mesh --shape sphere --depth 1 -o "build-fuzz/seed.$ext" --quiet
done
seed "$seeds/mesh" 0 build-fuzz/seed.mesh
seed "$seeds/mesh" 1 build-fuzz/seed.vtu
seed "$seeds/mesh" 2 build-fuzz/seed.msh

for target in fuzz_read_surface fuzz_read_mesh; do
  corpus=build-fuzz/corpus_$target && mkdir -p "$corpus"
  case $target in fuzz_read_surface) from=$seeds/surface ;; *) from=$seeds/mesh ;; esac
  # A crash ends the pass with its input kept as build-fuzz/crash-*; the rss and per-input time
  # limits turn allocations and hangs out of proportion into failures too.
  build-fuzz/tests/$target "$corpus" "$from" -max_total_time="$fuzz_seconds" -max_len=20000 \
    -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 -artifact_prefix=build-fuzz/ 2>&1 | tail -n 12
  echo "$target: no crash in ${fuzz_seconds} s"
done
