// Write and read throughput of every mesh format (core/io/mesh_io.h), in hexes per second, on an
// n^3 block of hexes (default n = 144: 2.99 M hexes, 3.0 M points) with two regions (a ball of
// region 1 inside region 2, so that .exo has an interface side set and its boundary node set) and
// coordinates of a mesher's kind (irrational, full precision). The target is 20 M hexes
// per second written in every format. Files go to --dir (default /dev/shm when it exists, so that
// the figure is the format's cost and not the disk's). Prints a table and one JSON line.
//   bench_formats [--n N] [--dir FOLDER] [--repeat R] [--only NAME,NAME...] [--no-read] [--keep]
// The row ".vtu given sj" passes each hex's scaled Jacobian in (MeshWriteOptions), as the
// pipeline can from its check; ".vtu" has the writer compute them.
// --only runs the named rows (".vtu,.msh binary"), --no-read skips the reads: a writer's change
// can then be timed in seconds rather than the minute all rows take. --keep leaves the files in
// --dir (mchex_bench_formats.EXT; the binary .msh and the given-sj .vtu with _binary and _given
// before the extension), so that two builds' files can be compared byte for byte.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/base/parallel.h"
#include "core/io/mesh_io.h"
#include "core/mesh/hex_mesh.h"
#include "core/mesh/quality.h"
#include "perf/bench_common.h"

using namespace mchex;
using bench::seconds_of;
namespace fs = std::filesystem;

namespace {

HexMesh block(uint32_t n) {
  HexMesh mesh;
  const uint32_t s = n + 1;
  mesh.points.reserve(std::size_t(s) * s * s);
  // A mildly warped lattice: coordinates need all 17 digits, as a mesher's do.
  for (uint32_t k = 0; k < s; ++k)
    for (uint32_t j = 0; j < s; ++j)
      for (uint32_t i = 0; i < s; ++i) {
        const double x = i / double(n), y = j / double(n), z = k / double(n);
        mesh.points.push_back({x + 0.01 * std::sin(7 * y), y + 0.01 * std::sin(5 * z), z + 0.01 * std::sin(3 * x)});
      }
  mesh.hexes.reserve(std::size_t(n) * n * n);
  for (uint32_t k = 0; k < n; ++k)
    for (uint32_t j = 0; j < n; ++j)
      for (uint32_t i = 0; i < n; ++i) {
        const uint32_t b = i + s * j + s * s * k;
        mesh.hexes.push_back({b, b + 1, b + 1 + s, b + s, b + s * s, b + 1 + s * s, b + 1 + s + s * s, b + s + s * s});
        const double dx = (i + 0.5) / n - 0.5, dy = (j + 0.5) / n - 0.5, dz = (k + 0.5) / n - 0.5;
        mesh.region.push_back(dx * dx + dy * dy + dz * dz < 0.09 ? kInside : kOutside);
      }
  return mesh;
}

}  // namespace

int main(int argc, char** argv) {
  uint32_t n = 144;
  int repeat = 3;
  std::string only;
  bool reads = true, keep = false;
  fs::path dir = fs::is_directory("/dev/shm") ? fs::path("/dev/shm") : fs::temp_directory_path();
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--no-read")) {
      reads = false;
      continue;
    }
    if (!std::strcmp(argv[i], "--keep")) {
      keep = true;
      continue;
    }
    if (i + 1 == argc) break;
    if (!std::strcmp(argv[i], "--only")) only = argv[i + 1];
    if (!std::strcmp(argv[i], "--n")) n = static_cast<uint32_t>(std::stoul(argv[i + 1]));
    if (!std::strcmp(argv[i], "--dir")) dir = argv[i + 1];
    if (!std::strcmp(argv[i], "--repeat")) repeat = std::stoi(argv[i + 1]);
    ++i;
  }
  auto selected = [&](const char* name) {
    if (only.empty()) return true;
    for (std::size_t b = 0; b <= only.size();) {
      const std::size_t e = std::min(only.find(',', b), only.size());
      if (only.compare(b, e - b, name) == 0) return true;
      b = e + 1;
    }
    return false;
  };
  const HexMesh mesh = block(n);
  const double hexes = static_cast<double>(mesh.hexes.size());
  std::printf("bench_formats: %zu hexes, %zu points, %d threads, files in %s (best of %d)\n", mesh.hexes.size(),
              mesh.points.size(), hardware_threads(), dir.c_str(), repeat);
  std::printf("%-14s %12s %12s %12s %12s\n", "format", "MB", "write s", "write Mhex/s", "read Mhex/s");
  struct Case {
    const char* name;
    const char* extension;
    bool binary;
    bool given_quality = false;  // .vtu: the scaled Jacobians passed in, as the pipeline has them
  };
  const Case cases[] = {{".mesh", ".mesh", false},     {".meshb", ".meshb", false},
                        {".vtu", ".vtu", false},       {".vtu given sj", ".vtu", false, true},
                        {".msh ascii", ".msh", false}, {".msh binary", ".msh", true},
                        {".exo", ".exo", false},       {".inp", ".inp", false}};
  std::vector<double> quality;
  nlohmann::json j = {{"bench", "formats"}, {"hexes", mesh.hexes.size()}, {"threads", hardware_threads()}};
  for (const Case& c : cases) {
    if (!selected(c.name)) continue;
    const fs::path path = dir / (std::string("mchex_bench_formats") + (c.binary ? "_binary" : "") +
                                 (c.given_quality ? "_given" : "") + c.extension);
    MeshWriteOptions options;
    options.binary = c.binary;
    if (c.given_quality) {
      if (quality.empty()) {
        quality.resize(mesh.hexes.size());
        parallel_for(mesh.hexes.size(), [&](std::size_t h) { quality[h] = scaled_jacobian(mesh.corners(h)); });
      }
      options.scaled_jacobians = quality;
    }
    double write = 1e30, read = 1e30;
    for (int r = 0; r < repeat; ++r) {
      write = std::min(write, seconds_of([&] { write_hex_mesh(mesh, path, options); }));
      if (reads)
        read = std::min(read, seconds_of([&] {
                          const HexMesh back = read_hex_mesh(path);
                          if (back.hexes.size() != mesh.hexes.size()) std::abort();
                        }));
    }
    const double mb = static_cast<double>(fs::file_size(path)) / 1e6;
    if (!keep) fs::remove(path);
    std::printf("%-14s %12.1f %12.3f %12.1f %12.1f\n", c.name, mb, write, hexes / write / 1e6, hexes / read / 1e6);
    j[c.name] = {{"mb", mb},
                 {"write_s", write},
                 {"write_mhex_per_s", hexes / write / 1e6},
                 {"read_mhex_per_s", hexes / read / 1e6}};
  }
  std::printf("%s\n", j.dump().c_str());
}
