// Reference SDF throughput: signed queries per second per core on a closed 50k+ triangle model
// for the points of a grid over its box, and the speed-up over the paper's brute-force loop
// (every point against every triangle) on a small model; next to it the generalized winding
// number's query rate on the same points (core/sdf/winding_number.h: the sign of
// SignRule::kWindingNumber). Prints a table and one JSON line.
//   bench_sdf [--grid N] [--segments S] [--model FILE] [--brute-model]
// (default model: the tessellated torus). --brute-model: the brute-force contrast runs on the
// model itself and its --grid points (keep both small: the loop costs triangles x points) instead
// of a 4,608-triangle torus at 28^3 points; perf/study.py uses it for its time-against-triangles plot.
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "core/base/parallel.h"
#include "core/grid/grid.h"
#include "core/io/surface_io.h"
#include "core/mesh/surface.h"
#include "core/sdf/sdf.h"
#include "core/sdf/shapes.h"
#include "core/sdf/winding_number.h"
#include "perf/bench_common.h"

using namespace mchex;
using bench::seconds_of;

namespace {

std::vector<Vec3> grid_points(const Box& bounds, int n) {
  const Box cube = padded_cube(bounds, 0.1);
  std::vector<Vec3> pts;
  pts.reserve(std::size_t(n) * n * n);
  const Vec3 s = cube.size();
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        pts.push_back(cube.lo + Vec3{s.x * i / (n - 1), s.y * j / (n - 1), s.z * k / (n - 1)});
  return pts;
}

}  // namespace

int main(int argc, char** argv) {
  int grid = 82, segments = 256;
  std::string model;
  bool brute_on_model = false;
  for (int i = 1; i < argc; ++i) {
    const bool has_value = i + 1 < argc;
    if (!std::strcmp(argv[i], "--brute-model")) brute_on_model = true;
    else if (has_value && !std::strcmp(argv[i], "--model")) model = argv[++i];
    else if (has_value && !std::strcmp(argv[i], "--grid")) grid = std::stoi(argv[++i]);
    else if (has_value && !std::strcmp(argv[i], "--segments")) segments = std::stoi(argv[++i]);
  }
  const int cores = hardware_threads();

  const TriangleSurface big = model.empty() ? tessellate(ShapeKind::kTorus, segments) : read_surface(model);
  const SurfaceReport report = validate_surface(big);
  // The search tree's build (once per surface; 1 thread), so that query speed bought with build
  // time shows.
  double tbuild = 0;
  {
    ThreadLimit one(1);
    tbuild = seconds_of([&] { const SurfaceSdf once(big); });
  }
  const SurfaceSdf sdf(big);
  const auto pts = grid_points(sdf.bounds(), grid);
  std::vector<double> f(pts.size());
  double t1 = 0, tn = 0;
  {
    ThreadLimit one(1);
    t1 = seconds_of([&] { sdf.evaluate(pts, f); });
  }
  tn = seconds_of([&] { sdf.evaluate(pts, f); });

  // The winding number on the same points: its build (1 thread, on top of the BVH's) and queries.
  double twbuild = 0, tw1 = 0, twn = 0;
  {
    ThreadLimit one(1);
    twbuild = seconds_of([&] { const WindingNumber once(big); });
  }
  const WindingNumber winding(big);
  std::vector<double> w(pts.size());
  {
    ThreadLimit one(1);
    tw1 = seconds_of([&] { winding.at(pts, w); });
  }
  twn = seconds_of([&] { winding.at(pts, w); });
  // The signed distance with the winding number's sign: the search plus the winding number.
  double ts1 = 0;
  {
    const SurfaceSdf signed_by_winding(big, SignRule::kWindingNumber);
    ThreadLimit one(1);
    ts1 = seconds_of([&] { signed_by_winding.evaluate(pts, w); });
  }

  // Brute force against the BVH on a model small enough for the loop to finish.
  const TriangleSurface small = brute_on_model ? big : tessellate(ShapeKind::kTorus, 48);
  const SurfaceSdf small_sdf(small);
  const auto small_pts = brute_on_model ? pts : grid_points(small_sdf.bounds(), 28);
  std::vector<double> a(small_pts.size()), b(small_pts.size());
  double tb = 0, tv = 0;
  {
    ThreadLimit one(1);
    tb = seconds_of([&] { brute_force_sdf(small, small_pts, a); });
    tv = seconds_of([&] { small_sdf.evaluate(small_pts, b); });
  }
  double max_diff = 0;
  for (std::size_t i = 0; i < a.size(); ++i) max_diff = std::max(max_diff, std::abs(a[i] - b[i]));
  const double per_core = pts.size() / t1;

  std::printf("reference SDF (Embree BVH + pseudonormal sign)\n");
  std::printf("  model: %s, %zu triangles, %s; %zu grid points (%d^3)\n", model.empty() ? "torus" : model.c_str(),
              big.triangles.size(), report.closed ? "closed" : "open", pts.size(), grid);
  std::printf("  build    : %10.3f s (1 thread)\n", tbuild);
  std::printf("  1 thread : %10.3f M queries/s\n", per_core / 1e6);
  std::printf("  %d threads: %10.3f M queries/s (%.2fx of 1 thread)\n", cores, pts.size() / tn / 1e6, t1 / tn);
  std::printf("generalized winding number (far field to second order, exact sign), same points\n");
  std::printf("  build    : %10.3f s (1 thread, BVH included)\n", twbuild);
  std::printf("  1 thread : %10.3f M queries/s (%.2fx the distance query's time)\n", pts.size() / tw1 / 1e6, tw1 / t1);
  std::printf("  %d threads: %10.3f M queries/s\n", cores, pts.size() / twn / 1e6);
  std::printf("  SurfaceSdf(SignRule::kWindingNumber), 1 thread: %.3f M queries/s\n", pts.size() / ts1 / 1e6);
  std::printf("brute force (paper's method) vs BVH, 1 thread, %zu triangles, %zu points\n", small.triangles.size(),
              small_pts.size());
  std::printf("  brute force %.3f s, BVH %.4f s: BVH is %.1fx faster; max |difference| %.2e\n", tb, tv, tb / tv,
              max_diff);
  std::printf("{\"bench\":\"sdf\",\"model\":\"%s\",\"triangles\":%zu,\"points\":%zu,\"queries_per_s_per_core\":%.0f,"
              "\"queries_per_s_all_cores\":%.0f,\"cores\":%d,\"brute_force_ratio\":%.2f,\"brute_triangles\":%zu,"
              "\"build_s\":%.4f,\"winding_queries_per_s_per_core\":%.0f,\"winding_queries_per_s_all_cores\":%.0f,"
              "\"winding_build_s\":%.4f,\"winding_signed_queries_per_s_per_core\":%.0f,\"brute_points\":%zu,"
              "\"brute_force_s\":%.4f,\"brute_bvh_s\":%.5f}\n",
              model.empty() ? "torus" : model.c_str(), big.triangles.size(), pts.size(), per_core, pts.size() / tn,
              cores, tb / tv, small.triangles.size(), tbuild, pts.size() / tw1, pts.size() / twn, twbuild,
              pts.size() / ts1, small_pts.size(), tb, tv);
  return 0;
}
