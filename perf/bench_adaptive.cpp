// Adaptive 3-refinement (core/grid/octree.h) against issue 6's targets, on the analytic shapes and one
// closed triangle model (the torus tessellated, core/sdf/shapes.h):
//   - speed: refinement + balancing + templates in output cells per second, the SDF's time taken
//     out (target: >= 1 M/s), with the time of each stage;
//   - size: the adaptive grid's cells over a uniform grid of the same finest cell size (target:
//     <= 1/5 at threshold 0.05), and the MCHex meshes' hexes over the uniform grid's;
//   - fidelity: IoU and Hausdorff ratio of the MCHex inside mesh, adaptive against that uniform
//     grid (target: equal or better), measured as `mchex-gpu mesh --fidelity` does. Uniform grids
//     deeper than --iou-depth (default 4: 531,441 cells, about 4 M MCHex hexes) are not meshed;
//     such a row compares against uniform depth --iou-depth instead and says so ("uniform depth").
//   - the size bound that the templates set: the standard 3-refinement templates handle only
//     convex transitions, so balancing refines every leaf with finer neighbours across two faces;
//     each level's refined region grows to (about) its bounding box. "hull" is the fraction of the
//     cube that the bounding box of the finest level's cells fills: the ratio cannot be far below it.
// Prints a table and one JSON line; never pass/fail.
// --model PATH (repeatable) adds a triangle model read as `mchex-gpu mesh` reads it (perf/run.sh passes
// the closed models of npm's stl-models when setup.sh has installed them).
//   bench_adaptive [--threshold T] [--max-depth D]... [--iou-depth D] [--lattice N] [--shape NAME] [--model PATH]...
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <time.h>

#include <fmt/format.h>

#include "core/check/fidelity.h"
#include "core/grid/grid.h"
#include "core/cutting/mchex_mesher.h"
#include "core/grid/octree.h"
#include "core/sdf/shapes.h"
#include "core/mesh/surface.h"
#include "perf/bench_common.h"
#include "core/io/surface_io.h"

using namespace mchex;
using bench::seconds_of;

namespace {

// CPU seconds of the whole process (all threads): on this shared machine wall time depends on
// the other users' load, CPU time much less; cells per CPU second x cores is what idle cores do
// at perfect scaling, an upper bound of the wall figure.
double cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

// Times an SDF's evaluate() calls so that they can be taken out of the refinement time.
class TimedSdf final : public SignedDistance {
 public:
  explicit TimedSdf(const SignedDistance& s) : s_(s) {}
  void evaluate(std::span<const Vec3> p, std::span<double> v) const override {
    const double c = cpu_seconds();
    seconds += seconds_of([&] { s_.evaluate(p, v); });
    cpu += cpu_seconds() - c;
  }
  Box bounds() const override { return s_.bounds(); }
  mutable double seconds = 0, cpu = 0;

 private:
  const SignedDistance& s_;
};

struct Model {
  std::string name;
  std::optional<TriangleSurface> surface;
  std::unique_ptr<SignedDistance> sdf;
};

// As the CLI's --fidelity (host/cli/main.cpp measure()): surface samples at 1/400 of the box
// diagonal, IoU on a lattice over the padded cube.
Fidelity fidelity(const HexMesh& inside, const Model& m, const Box& cube, std::size_t lattice) {
  const double spacing = cube.diagonal() / 400;
  const auto samples = m.surface ? sample_surface(*m.surface, spacing)
                                 : sample_surface(*m.sdf, padded_cube(m.sdf->bounds(), 0.05), spacing);
  return measure_fidelity(inside, *m.sdf, samples, cube, lattice, spacing);
}

}  // namespace

int main(int argc, char** argv) {
  double threshold = 0.05;
  std::vector<int> depths;
  int iou_depth = 4;
  std::size_t lattice = 160;
  std::string only;
  std::vector<std::string> model_paths;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--model")) model_paths.push_back(argv[i + 1]);
    if (!std::strcmp(argv[i], "--threshold")) threshold = std::stod(argv[i + 1]);
    if (!std::strcmp(argv[i], "--max-depth")) depths.push_back(std::stoi(argv[i + 1]));
    if (!std::strcmp(argv[i], "--iou-depth")) iou_depth = std::stoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--lattice")) lattice = std::stoul(argv[i + 1]);
    if (!std::strcmp(argv[i], "--shape")) only = argv[i + 1];
  }
  if (depths.empty()) depths = {4, 5};
  std::vector<Model> models;
  for (const ShapeInfo& info : shape_catalog())
    models.push_back({std::string(info.name), std::nullopt, std::make_unique<ShapeSdf>(info.kind)});
  {
    Model m{"torus-mesh", tessellate(ShapeKind::kTorus, 160), nullptr};
    m.sdf = std::make_unique<SurfaceSdf>(*m.surface);
    m.name = fmt::format("torus-mesh ({} triangles)", m.surface->triangles.size());
    models.push_back(std::move(m));
  }
  for (const std::string& path : model_paths) {
    Model m{"", read_surface(path), nullptr};
    m.sdf = std::make_unique<SurfaceSdf>(*m.surface);
    m.name = fmt::format("{} ({} triangles)", std::filesystem::path(path).stem().string(), m.surface->triangles.size());
    models.push_back(std::move(m));
  }

  fmt::print("adaptive 3-refinement, threshold {} (x finest cell size); IoU lattice {}^3\n", threshold, lattice);
  fmt::print("{:<30} {:>3} {:>3} {:>9} {:>6} {:>6} | {:>6} {:>6} {:>6} {:>6} {:>8} {:>8} | {:>3} {:>7} {:>7} {:>7} {:>8} {:>8}\n",
             "shape", "max", "lvl", "cells", "ratio", "hull", "refine", "bal", "cmplx", "sdf", "M cells/s", "/CPU s", "uni",
             "hexes", "IoU a", "IoU u", "HR a %", "HR u %");
  std::string json;
  for (const int max_depth : depths)
    for (const Model& m : models) {
      if (!only.empty() && m.name.rfind(only, 0) != 0) continue;
      TimedSdf sdf(*m.sdf);
      const Box cube = padded_cube(m.sdf->bounds(), 0.1);
      OctreeStats stats;
      double t_refine = 0, t_balance = 0, t_complex = 0;
      std::optional<Octree> tree;
      const double cpu0 = cpu_seconds();
      t_refine = seconds_of([&] { tree.emplace(refine_octree(sdf, cube, {threshold, max_depth}, &stats)); }) - sdf.seconds;
      const double sdf_refine = sdf.seconds;
      t_balance = seconds_of([&] { balance_octree(*tree, &stats); });
      AdaptiveGrid g;
      t_complex = seconds_of([&] { g = build_adaptive_complex(*tree); });
      const double cpu_tree = cpu_seconds() - cpu0 - sdf.cpu;  // refinement less its SDF, balancing, complex
      tree.reset();
      const double tree_s = t_refine + t_balance + t_complex;
      const double cells = double(g.complex.cells.size());
      const int finest = g.levels - 1;
      const double uniform = std::pow(27.0, finest);
      // The bounding box of the finest level's cells, as a fraction of the cube.
      Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
      for (std::size_t c = 0; c < g.complex.cells.size(); ++c)
        if (g.cell_level[c] == finest)
          for (std::uint32_t p : g.complex.cells[c]) {
            lo = {std::min(lo.x, g.complex.points[p].x), std::min(lo.y, g.complex.points[p].y), std::min(lo.z, g.complex.points[p].z)};
            hi = {std::max(hi.x, g.complex.points[p].x), std::max(hi.y, g.complex.points[p].y), std::max(hi.z, g.complex.points[p].z)};
          }
      const Vec3 cs = cube.size();
      const double hull = (hi.x - lo.x) * (hi.y - lo.y) * (hi.z - lo.z) / (cs.x * cs.y * cs.z);
      const std::size_t unsampled = g.unsampled.size(), points = g.complex.points.size();
      const double sdf_rest = seconds_of([&] { evaluate_unsampled(g, *m.sdf); });

      // Fidelity of the MCHex inside meshes: adaptive, and uniform at the finest level (or the
      // deepest one meshed).
      const int udepth = std::min(finest, iou_depth);
      const MeshPair am = mesh_mchex(g.complex, g.values, 1e-3);
      const Fidelity fa = fidelity(am.inside, m, cube, lattice);
      const double adaptive_hexes = double(am.inside.hexes.size() + am.outside.hexes.size());
      const UniformGrid ug(cube, udepth);
      std::vector<double> uv(ug.vertex_count());
      m.sdf->evaluate(ug.vertices(), uv);
      const MeshPair um = mesh_mchex(ug, uv, 1e-3);
      const Fidelity fu = fidelity(um.inside, m, cube, lattice);
      const double uniform_hexes = double(um.inside.hexes.size() + um.outside.hexes.size());
      const double hex_ratio = udepth == finest ? adaptive_hexes / uniform_hexes : NAN;

      fmt::print("{:<30} {:>3} {:>3} {:>9} {:>6.3f} {:>6.3f} | {:>6.3f} {:>6.3f} {:>6.3f} {:>6.3f} {:>8.2f} {:>8.2f} | {:>3} {:>7.3f} {:>7.5f} {:>7.5f} {:>8.4f} {:>8.4f}\n",
                 m.name, max_depth, g.levels, g.complex.cells.size(), cells / uniform, hull, t_refine, t_balance,
                 t_complex, sdf_refine + sdf_rest, cells / tree_s / 1e6, cells / cpu_tree / 1e6, udepth, hex_ratio, fa.iou, fu.iou,
                 100 * fa.hausdorff_ratio, 100 * fu.hausdorff_ratio);
      json += fmt::format(
          "{}{{\"shape\":\"{}\",\"max_depth\":{},\"levels\":{},\"cells\":{},\"uniform_cells\":{:.0f},\"ratio\":{:.6f},"
          "\"hull\":{:.4f},\"refine_s\":{:.4f},\"balance_s\":{:.4f},\"complex_s\":{:.4f},\"sdf_s\":{:.4f},"
          "\"cells_per_s\":{:.1f},\"cells_per_cpu_s\":{:.1f},\"points\":{},\"unsampled_points\":{},\"uniform_depth\":{},"
          "\"mchex_hexes\":{:.0f},\"uniform_mchex_hexes\":{:.0f},\"iou\":{:.6f},\"uniform_iou\":{:.6f},"
          "\"hausdorff_ratio\":{:.6g},\"uniform_hausdorff_ratio\":{:.6g}}}",
          json.empty() ? "" : ",", m.name, max_depth, g.levels, g.complex.cells.size(), uniform, cells / uniform, hull,
          t_refine, t_balance, t_complex, sdf_refine + sdf_rest, cells / tree_s, cells / cpu_tree, points, unsampled, udepth,
          adaptive_hexes, uniform_hexes, fa.iou, fu.iou, fa.hausdorff_ratio, fu.hausdorff_ratio);
      std::fflush(stdout);
    }
  fmt::print("lvl: levels with a leaf (finest = lvl - 1); ratio: cells / 27^(lvl-1); hull: see the header comment;\n"
             "times in s (sdf: refinement batches + the complex's unsampled points); M cells/s: cells / (refine + bal + cmplx);\n"
             "/CPU s: M cells per CPU second of those stages (all threads; load-independent);\n"
             "uni: the uniform depth compared (= lvl - 1 unless deeper than --iou-depth); hexes: MCHex hexes (both meshes),\n"
             "adaptive / uniform, when uni = lvl - 1; IoU, HR (Hausdorff / diagonal) of the inside mesh, a(daptive) and u(niform).\n");
  fmt::print("{{\"bench\":\"adaptive\",\"threshold\":{},\"iou_depth\":{},\"lattice\":{},\"results\":[{}]}}\n", threshold,
             iou_depth, lattice, json);
  return 0;
}
