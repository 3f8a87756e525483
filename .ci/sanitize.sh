#!/usr/bin/env bash
# CI's second build (run by .ci/run after the README's test command): the same sources with both
# device backends configured out (MCHEX_WITH_OPENCL and MCHEX_WITH_VULKAN OFF: no OpenCL, Vulkan
# or shader compiler looked for), compiled by clang with AddressSanitizer, UndefinedBehaviorSanitizer
# (every report fatal) and libFuzzer coverage in every library (MCHEX_FUZZ).
#
# By default (what CI runs at every stop) it builds the readers alone (core/io and what it links)
# and runs a bounded libFuzzer pass over every reader: surfaces (STL, OBJ, OFF, PLY) and hex meshes
# (.mesh, .vtu, .msh ascii and binary, .meshb, .inp, .exo), seeded from the test models. Readers
# take untrusted bytes, so they are where memory errors matter most; this costs about 3 minutes.
#
# With --full it builds everything and also runs the whole test suite instrumented, less the scale
# runs named in `scale` below (they repeat code the rest covers on inputs large enough to take
# 30-60 minutes instrumented, and all run in the first build). That is 11 minutes of build and
# 15 of tests on 2 cores (measured 2026-12-03), which with the first build's 20 minutes would put
# CI past its 30-minute budget, so it is run by hand before landing a change to memory handling,
# threads or the readers (README, "Build options"), and checks in passing that a CPU-only
# build passes its suite (test_backends skips the absent device variants with the reason).
# CPU-only because the drivers (PoCL, lavapipe) are not instrumented and their JIT code trips the
# sanitizers; no reader depends on a device.
# Usage: bash .ci/sanitize.sh [--full] [SECONDS_PER_FUZZER [RUNS_PER_FUZZER]]   (default 60, 60000)
set -euo pipefail
cd "$(dirname "$0")/.."
full=0
if [ "${1:-}" = "--full" ]; then
  full=1
  shift
fi
fuzz_seconds=${1:-60}
fuzz_runs=${2:-60000}

export ASAN_OPTIONS=abort_on_error=1:detect_leaks=1:strict_string_checks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
cmake -S . -B build-cpu -G Ninja -DMCHEX_WITH_OPENCL=OFF -DMCHEX_WITH_VULKAN=OFF \
      -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DMCHEX_FUZZ=ON
if [ "$full" -eq 0 ]; then
  cmake --build build-cpu --target fuzz_read_surface fuzz_read_mesh
else
  cmake --build build-cpu
  # Exhaustive enumerations (every cell type x rotation x subcase, every template, every cell
  # topology, flood fills of the trilinear interpolant) and depth-4 / 50k-triangle end-to-end runs
  # (test_sign: depth-4 meshes of constructed surfaces, over 10 minutes instrumented; the winding
  # number and the repair it drives run instrumented in test_winding_number and test_orientation).
  scale='certify\.TheCubeIsProvenForEverySubcaseAndTheRestIsReported|local_refinement\.EveryCellCertifiesWithItsTopology'
  scale+='|local_refinement\.TemplateSearchFindsTheBuiltInTable|mc33\.RegionsAgreeWithFloodFill'
  scale+='|MchexShapes\.ConformingClosedAndCounted/.*depth4|Mchex\.FitsTheTorusBetterThanRemoveOutside'
  scale+='|^test_end_to_end$|^test_adaptive_cli$|^test_sign$'
  # And the checks that run no code of the build (the sources' formatting and references, the
  # study's page redrawn from its CSVs): the first build ran them on the same files.
  scale+='|^test_format$|^test_references$|^test_study$'
  ctest --test-dir build-cpu --output-on-failure -j2 -E "$scale"
fi

# Seeds: the first byte of each picks the extension (the targets' rule), the rest is a real file.
seeds=build-cpu/seeds
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
# The seed meshes come from a mesher binary: the instrumented one where it was built (--full), else
# the first build's (CI runs this after the README's test command); the bytes are the same.
mchex=build-cpu/host/mchex-gpu
[ -x "$mchex" ] || mchex=build/host/mchex-gpu
for ext in mesh vtu msh meshb inp exo; do
  "$mchex" mesh --shape sphere --depth 1 -o "build-cpu/seed.$ext" --quiet
done
"$mchex" convert build-cpu/seed.msh build-cpu/seed_binary.msh --binary
# The index is fuzz_read_mesh's extension: .mesh .vtu .msh .meshb .inp .exo.
seed "$seeds/mesh" 0 build-cpu/seed.mesh
seed "$seeds/mesh" 1 build-cpu/seed.vtu
seed "$seeds/mesh" 2 build-cpu/seed.msh
seed "$seeds/mesh" 2 build-cpu/seed_binary.msh
seed "$seeds/mesh" 3 build-cpu/seed.meshb
seed "$seeds/mesh" 4 build-cpu/seed.inp
seed "$seeds/mesh" 5 build-cpu/seed.exo

for target in fuzz_read_surface fuzz_read_mesh; do
  corpus=build-cpu/corpus_$target && rm -rf "$corpus" && mkdir -p "$corpus"
  case $target in fuzz_read_surface) from=$seeds/surface ;; *) from=$seeds/mesh ;; esac
  # A crash ends the pass with its input kept as build-cpu/crash-*; the rss and per-input time
  # limits turn allocations and hangs out of proportion into failures too.
  # A fixed seed and run count make the pass the same on every machine (the corpus starts from the
  # seeds alone); the time cap only bounds a slow machine's share of that same sequence.
  build-cpu/tests/$target "$corpus" "$from" -seed=1 -runs="$fuzz_runs" -max_total_time="$fuzz_seconds" -max_len=20000 \
    -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 -artifact_prefix=build-cpu/ 2>&1 | tail -n 12
  echo "$target: no crash"
done
