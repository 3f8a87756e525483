#!/usr/bin/env bash
# Installs everything mchex-gpu needs to build, test and benchmark on Debian 12, as root,
# non-interactively and idempotently (apt-get only; npm for the two test-data packages).
# Usage: bash setup.sh            (packages + test data)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
export DEBIAN_FRONTEND=noninteractive

pkgs=(
  # toolchain
  build-essential cmake ninja-build pkg-config git ca-certificates
  # reference SDF: Embree 3 BVH + TBB threads
  libembree-dev libtbb-dev
  # surface reader
  libassimp-dev
  # CLI, JSON report, logging, tests
  libcli11-dev nlohmann-json3-dev libspdlog-dev libfmt-dev libgtest-dev libgmock-dev
  # OpenCL: ICD loader, C and C++ headers, PoCL CPU driver, clinfo for diagnosis
  ocl-icd-opencl-dev opencl-headers opencl-clhpp-headers pocl-opencl-icd clinfo
  # Vulkan: loader, headers, Mesa lavapipe, glslang (GLSL -> SPIR-V), vulkaninfo
  libvulkan-dev mesa-vulkan-drivers glslang-tools spirv-tools vulkan-tools
  # independent readers for the tests (meshio), numpy for perf scripts, matplotlib for the plots
  # of perf/curves.py; netCDF4 for meshio's Exodus reader (tests/test_meshio_formats.py)
  python3 python3-meshio python3-numpy python3-matplotlib python3-netcdf4
  # the Python module (host/python, docs/python.md): pybind11 binds it to Debian's python3,
  # python3-dev has Python.h, pytest runs tests/test_python.py
  pybind11-dev python3-dev python3-pytest
  # Exodus II .exo writer and reader (core/io/exodus.cpp; brings netCDF)
  libexodusii-dev
  # CalculiX: solves our .inp files in tests/test_calculix.py
  calculix-ccx
  # a second, independent judge of the .msh output: gmsh's Jacobian bounds and matrices
  # (tests/test_quality_refs.py)
  python3-gmsh
  # formatting check (tests/test_format.py), clang + libFuzzer runtime for CI's fuzz pass
  clang clang-format libclang-rt-14-dev
  # test models: Assimp's sample files (valid and invalid) and OpenSCAD's bad STLs
  assimp-testmodels openscad-testing-data
)

missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
command -v npm >/dev/null || apt-get install -y -qq --no-install-recommends npm >/dev/null

# npm test data (the Stanford bunny and a set of STL models) into a folder git ignores.
data="$here/tests/data/npm"
if [ ! -f "$data/.done" ]; then
  mkdir -p "$data"
  (cd "$data" && npm install --silent --no-audit --no-fund --prefix . bunny@1.0.1 stl-models@0.12.0 >/dev/null)
  touch "$data/.done"
fi
