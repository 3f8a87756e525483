// Adaptive 3-refinement (core/octree.h): refinement + balancing + templates in output cells per
// second (issue 6 target: >= 1 M/s), with the SDF time shown apart (analytic shapes, so it is
// small), and at threshold 0.05 the adaptive complex's cell count against a uniform grid of the
// same finest cell size (target: <= 1/5). Prints a table and one JSON line; never pass/fail.
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "core/grid.h"
#include "core/octree.h"
#include "core/shapes.h"
#include "perf/bench_common.h"

using namespace mchex;

namespace {

// Times an SDF wrapper's evaluate() calls so that they can be taken out of the refinement time.
class TimedSdf final : public SignedDistance {
 public:
  explicit TimedSdf(const SignedDistance& s) : s_(s) {}
  void evaluate(std::span<const Vec3> p, std::span<double> v) const override {
    seconds += bench::seconds_of([&] { s_.evaluate(p, v); });
  }
  Box bounds() const override { return s_.bounds(); }
  mutable double seconds = 0;

 private:
  const SignedDistance& s_;
};

}  // namespace

int main(int argc, char** argv) {
  const int max_depth = argc > 1 ? std::stoi(argv[1]) : 5;
  const double threshold = argc > 2 ? std::stod(argv[2]) : 0.05;
  fmt::print("adaptive 3-refinement, threshold {} (x cell size), max depth {}\n", threshold, max_depth);
  fmt::print("{:<12} {:>6} {:>11} {:>14} {:>8} {:>8} {:>10} {:>12} {:>9}\n", "shape", "levels", "cells",
             "uniform cells", "ratio", "sdf s", "tree s", "cells/s", "(w/ sdf)");
  std::string json = "[";
  for (const ShapeInfo& info : shape_catalog()) {
    const ShapeSdf shape(info.kind);
    TimedSdf sdf(shape);
    const Box cube = padded_cube(shape.bounds(), 0.1);
    AdaptiveGrid g;
    const double total = bench::seconds_of([&] {
      Octree t = refine_octree(sdf, cube, {threshold, max_depth});
      balance_octree(t);
      g = build_adaptive_complex(t);
    });
    const double tree = total - sdf.seconds;
    const double uniform = std::pow(27.0, g.levels - 1);  // same finest cell size
    const double cells = double(g.complex.cells.size());
    fmt::print("{:<12} {:>6} {:>11} {:>14.0f} {:>8.4f} {:>8.3f} {:>10.3f} {:>12.3g} {:>9.3g}\n",
               std::string(shape_name(info.kind)), g.levels, g.complex.cells.size(), uniform, cells / uniform,
               sdf.seconds, tree, cells / tree, cells / total);
    json += fmt::format("{}{{\"shape\":\"{}\",\"levels\":{},\"cells\":{},\"uniform_cells\":{:.0f},\"ratio\":{:.6f},"
                        "\"sdf_s\":{:.4f},\"tree_s\":{:.4f},\"cells_per_s\":{:.1f},\"cells_per_s_with_sdf\":{:.1f}}}",
                        json.size() > 1 ? "," : "", shape_name(info.kind), g.levels, g.complex.cells.size(), uniform,
                        cells / uniform, sdf.seconds, tree, cells / tree, cells / total);
  }
  json += "]";
  fmt::print("{{\"bench\":\"adaptive\",\"threshold\":{},\"max_depth\":{},\"results\":{}}}\n", threshold, max_depth, json);
  return 0;
}
