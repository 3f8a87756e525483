// Kernel throughput per backend, as ratios to the cpu reference measured in the same run (the
// machine is shared and noisy: only ratios within one run compare). For the opencl backend also
// where the time goes: device time per kernel (OpenCL profiling events) against host<->device
// transfers, the rest being host-side work (argument checks, decoding, chunking) and launch
// latency.
//
//   bench_backends [--grid N] [--segments S] [--depth D] [--repeat R] [--platform NAME]
//
// Workloads: surface SDF at the N^3 points of a grid over the tessellated torus (2 S x 0.4 S
// triangles; S = 256 gives 52,224), analytic-shape SDF on the same points, refinement error of
// 100,000 cells of the two-holed shape, and MC33 classification + hex prefix sum of the uniform
// depth-D complex of the two-holed shape. Prints a table and one JSON line.
#include <cstdio>
#include <cstring>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <tbb/info.h>

#include "core/grid.h"
#include "core/hex_complex.h"
#include "core/refinement_error.h"
#include "core/shapes.h"
#include "host/backend.h"
#include "host/backend_cpu.h"
#include "host/backend_opencl.h"
#include "perf/bench_common.h"

using namespace mchex;
using bench::seconds_of;

namespace {

struct Workloads {
  TriangleSurface surface;
  std::vector<Vec3> points;
  std::vector<std::array<double, kChildLatticePoints>> lattice;
  std::vector<double> sizes;
  HexComplex complex;
  std::vector<double> values;
};

}  // namespace

int main(int argc, char** argv) {
  int grid = 82, segments = 256, depth = 4, repeat = 3;
  std::string platform;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--grid") grid = std::atoi(argv[i + 1]);
    else if (a == "--segments") segments = std::atoi(argv[i + 1]);
    else if (a == "--depth") depth = std::atoi(argv[i + 1]);
    else if (a == "--repeat") repeat = std::atoi(argv[i + 1]);
    else if (a == "--platform") platform = argv[i + 1];
    else {
      std::fprintf(stderr, "bench_backends: unknown option %s\n", argv[i]);
      return 1;
    }
  }

  Workloads w;
  w.surface = tessellate(ShapeKind::kTorus, segments);
  {
    const Box cube = padded_cube(w.surface.bounds(), 0.1);
    const Vec3 s = cube.size();
    for (int k = 0; k < grid; ++k)
      for (int j = 0; j < grid; ++j)
        for (int i = 0; i < grid; ++i)
          w.points.push_back(cube.lo + Vec3{s.x * i / (grid - 1), s.y * j / (grid - 1), s.z * k / (grid - 1)});
  }
  const ShapeSdf two_holed(ShapeKind::kTwoHoled);
  {
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> pos(-1.4, 1.1);
    for (int c = 0; c < 100000; ++c) {
      const Vec3 lo{pos(rng), pos(rng) * 0.7, pos(rng) * 0.3};
      const double h = 0.02 + 0.1 * (rng() % 100) / 100.0;
      std::array<double, kChildLatticePoints> f;
      for (int z = 0; z < 4; ++z)
        for (int y = 0; y < 4; ++y)
          for (int x = 0; x < 4; ++x) f[child_lattice_index(x, y, z)] = two_holed(lo + Vec3{x * h / 3, y * h / 3, z * h / 3});
      w.lattice.push_back(f);
      w.sizes.push_back(h);
    }
  }
  w.complex = uniform_complex(UniformGrid(padded_cube(two_holed.bounds(), 0.1), depth));
  w.values.resize(w.complex.points.size());
  two_holed.evaluate(w.complex.points, w.values);

  struct Named {
    std::string name;
    std::unique_ptr<Backend> backend;
  };
  std::vector<Named> backends;
  backends.push_back({"cpu", make_cpu_backend()});
  OpenclBackend* ocl = nullptr;
  {
    OpenclOptions o;
    o.platform = platform;
    auto b = std::make_unique<OpenclBackend>(o);
    ocl = b.get();
    backends.push_back({"opencl", std::move(b)});
  }

  const std::size_t n_points = w.points.size(), n_cells = w.complex.cells.size();
  std::map<std::string, std::map<std::string, double>> rate;  // kernel -> backend -> items/s
  std::map<std::string, std::map<std::string, double>> profile;  // opencl: kernel -> part -> s
  std::vector<double> out(n_points), errors(w.lattice.size());
  std::vector<CellCode> codes(n_cells);
  std::vector<std::uint64_t> offsets(n_cells + 1);
  for (auto& [name, b] : backends) {
    SdfSource surface;
    surface.surface = &w.surface;
    SdfSource shape;
    shape.shape = ShapeKind::kTorus;
    b->signed_distance(surface, std::span(w.points).first(16), std::span(out).first(16));  // build the scene once
    // Best of `repeat` runs (the least disturbed by other users of the machine), with the
    // opencl profile of that same run.
    auto measure = [&](const std::string& kernel, std::size_t items, auto&& f) {
      double best = 1e300;
      for (int r = 0; r < repeat; ++r) {
        if (ocl && name == "opencl") ocl->reset_profile();
        const double s = seconds_of(f);
        if (s >= best) continue;
        best = s;
        if (ocl && name == "opencl") {
          auto& p = profile[kernel];
          p.clear();
          p["wall"] = s;
          for (const auto& [k, e] : ocl->profile().kernels) p[k] = e.seconds;
        }
      }
      rate[kernel][name] = items / best;
    };
    measure("sdf_surface", n_points, [&] { b->signed_distance(surface, w.points, out); });
    measure("sdf_shape", n_points, [&] { b->signed_distance(shape, w.points, out); });
    measure("refinement_error", w.lattice.size(), [&] { b->refinement_error(w.lattice, w.sizes, errors); });
    measure("classify+scan", n_cells, [&] { b->classify_cells(w.complex, w.values, codes, offsets); });
  }

  std::printf("bench_backends: %zu surface triangles, %zu points, %zu refinement cells, %zu MC cells, %d CPU threads\n",
              w.surface.triangles.size(), n_points, w.lattice.size(), n_cells, tbb::info::default_concurrency());
  std::printf("opencl device: %s / %s\n\n", ocl->device().platform.c_str(), ocl->device().name.c_str());
  std::printf("%-18s %14s %14s %10s\n", "kernel", "cpu M/s", "opencl M/s", "ocl/cpu");
  nlohmann::json j = {{"triangles", w.surface.triangles.size()}, {"points", n_points}, {"mc_cells", n_cells},
                      {"refinement_cells", w.lattice.size()}, {"threads", tbb::info::default_concurrency()},
                      {"opencl_device", ocl->device().name}};
  for (auto& [kernel, r] : rate) {
    std::printf("%-18s %14.3f %14.3f %10.3f\n", kernel.c_str(), r["cpu"] / 1e6, r["opencl"] / 1e6, r["opencl"] / r["cpu"]);
    j["rate_per_s"][kernel] = r;
    j["ratio_to_cpu"][kernel]["opencl"] = r["opencl"] / r["cpu"];
  }
  std::printf("\nopencl: where the time goes (seconds per call; device time from profiling events)\n");
  for (auto& [kernel, p] : profile) {
    std::printf("  %-18s wall %.4f:", kernel.c_str(), p["wall"]);
    double device = 0;
    for (auto& [part, s] : p)
      if (part != "wall") {
        std::printf(" %s %.4f", part.c_str(), s);
        device += s;
      }
    std::printf("  | host-side and launch %.4f\n", p["wall"] - device);
    j["opencl_profile_s"][kernel] = p;
  }
  std::printf("%s\n", j.dump().c_str());
  return 0;
}
