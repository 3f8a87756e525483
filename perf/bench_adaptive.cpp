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
//   - "hull": the fraction of the cube that the bounding box of the finest level's cells fills. With
//     the standard templates (convex transitions only) each level's refined region grew to about
//     its bounding box, so the ratio could not fall far below it; the vertex-based templates
//     handle concave transitions too, and the ratio now falls below the hull.
// Every figure comes from core/pipeline/pipeline.h run_pipeline, the stages `mchex-gpu mesh` runs
// (its OctreeTimes take the refinement's SDF batches out of the refinement time).
// Prints a table and one JSON line; never pass/fail.
// --model PATH (repeatable) adds a triangle model read as `mchex-gpu mesh` reads it (perf/run.sh passes
// the closed models of npm's stl-models when setup.sh has installed them).
//   bench_adaptive [--threshold T] [--max-depth D]... [--iou-depth D] [--lattice N] [--shape NAME] [--model PATH]...
//                  [--backend cpu|opencl|vulkan|auto]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "core/pipeline/pipeline.h"
#include "core/sdf/shapes.h"
#include "host/backends/registry.h"

using namespace mchex;

namespace {

struct Model {
  std::string name;
  std::unique_ptr<Solid> solid;
};

Model load(const SolidSource& source, const std::string& label) {
  StageClock clock(true);
  Model m{label, std::make_unique<Solid>(source, clock, true)};
  if (m.solid->surface()) m.name = fmt::format("{} ({} triangles)", label, m.solid->surface()->triangles.size());
  return m;
}

// The bounding box of the finest level's cells, as a fraction of the cube.
double finest_hull(const AdaptiveGrid& g, const Box& cube) {
  const int finest = g.levels - 1;
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (std::size_t c = 0; c < g.complex.cells.size(); ++c)
    if (g.cell_level[c] == finest)
      for (std::uint32_t p : g.complex.cells[c]) {
        lo = {std::min(lo.x, g.complex.points[p].x), std::min(lo.y, g.complex.points[p].y),
              std::min(lo.z, g.complex.points[p].z)};
        hi = {std::max(hi.x, g.complex.points[p].x), std::max(hi.y, g.complex.points[p].y),
              std::max(hi.z, g.complex.points[p].z)};
      }
  const Vec3 cs = cube.size();
  return (hi.x - lo.x) * (hi.y - lo.y) * (hi.z - lo.z) / (cs.x * cs.y * cs.z);
}

// Issue 17 item 3's bound: the share of the output hexes that keeping whole every uncut cell that
// shares no point with a cut cell would save (7 of its 8 Case 1 hexes each), before any transition
// to the subdivided cells around it is paid for. Cut = corner values of both signs, as the mesher's.
double whole_cell_saving(const AdaptiveGrid& g, const SignedDistance& sdf, double hexes) {
  std::vector<double> f(g.complex.points.size());
  sdf.evaluate(g.complex.points, f);
  std::vector<std::uint8_t> touched(f.size(), 0);
  std::vector<std::uint8_t> cut(g.complex.cells.size(), 0);
  for (std::size_t c = 0; c < g.complex.cells.size(); ++c) {
    bool pos = false, neg = false;
    for (std::uint32_t p : g.complex.cells[c]) (f[p] > 0 ? pos : neg) = true;
    cut[c] = pos && neg;
    if (cut[c])
      for (std::uint32_t p : g.complex.cells[c]) touched[p] = 1;
  }
  std::size_t whole = 0;
  for (std::size_t c = 0; c < g.complex.cells.size(); ++c) {
    bool free = !cut[c];
    for (std::uint32_t p : g.complex.cells[c]) free = free && !touched[p];
    whole += free;
  }
  return 7.0 * double(whole) / hexes;
}

}  // namespace

int main(int argc, char** argv) {
  double threshold = 0.05;
  std::vector<int> depths;
  int iou_depth = 4;
  std::size_t lattice = 160;
  std::string only, backend_name = "cpu";
  std::vector<std::string> model_paths;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--model")) model_paths.push_back(argv[i + 1]);
    if (!std::strcmp(argv[i], "--threshold")) threshold = std::stod(argv[i + 1]);
    if (!std::strcmp(argv[i], "--max-depth")) depths.push_back(std::stoi(argv[i + 1]));
    if (!std::strcmp(argv[i], "--iou-depth")) iou_depth = std::stoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--lattice")) lattice = std::stoul(argv[i + 1]);
    if (!std::strcmp(argv[i], "--shape")) only = argv[i + 1];
    if (!std::strcmp(argv[i], "--backend")) backend_name = argv[i + 1];
  }
  if (depths.empty()) depths = {4, 5};
  std::vector<Model> models;
  for (const ShapeInfo& info : shape_catalog())
    models.push_back(load(SolidSource::named_shape(std::string(info.name)), std::string(info.name)));
  const TriangleSurface torus_mesh = tessellate(ShapeKind::kTorus, 160);
  models.push_back(load(SolidSource::in_memory(torus_mesh, "torus-mesh"), "torus-mesh"));
  for (const std::string& path : model_paths)
    models.push_back(load(SolidSource::file(path), std::filesystem::path(path).stem().string()));
  const std::unique_ptr<Backend> backend = make_backend(backend_name);

  fmt::print("adaptive 3-refinement, threshold {} (x finest cell size); IoU lattice {}^3\n", threshold, lattice);
  fmt::print(
      "{:<30} {:>3} {:>3} {:>9} {:>6} {:>6} | {:>6} {:>6} {:>6} {:>6} {:>8} {:>8} | {:>3} {:>7} {:>7} {:>7} {:>8} {:>8} {:>6}\n",
      "shape", "max", "lvl", "cells", "ratio", "hull", "refine", "bal", "cmplx", "sdf", "M cells/s", "/CPU s", "uni",
      "hexes", "IoU a", "IoU u", "HR a %", "HR u %", "whole%");
  std::string json;
  for (const int max_depth : depths)
    for (const Model& m : models) {
      if (!only.empty() && m.name.rfind(only, 0) != 0) continue;
      MeshRequest request;
      request.backend = backend.get();
      request.options.method = "mchex";
      request.options.eps = 1e-3;
      request.options.fidelity = true;
      request.options.lattice = lattice;
      request.options.quiet = true;
      request.options.threshold = threshold;
      request.options.max_depth = max_depth;
      // The adaptive run; its grid and meshes are let go before the uniform one.
      int levels = 0;
      std::size_t cells_n = 0, unsampled = 0, points = 0;
      double hull = 0, adaptive_hexes = 0, sdf_rest = 0, whole = 0;
      OctreeTimes t;
      Fidelity fa;
      bool ok = true;
      {
        const MeshRun a = run_pipeline(request, *m.solid);
        const AdaptiveGrid& g = *a.adaptive;
        levels = g.levels;
        cells_n = g.complex.cells.size();
        unsampled = a.unsampled_points;
        points = g.complex.points.size();
        hull = finest_hull(g, a.cube);
        t = a.octree_times;
        sdf_rest = a.clock.seconds("sdf");
        fa = *a.fidelity;
        adaptive_hexes = double(a.meshes.inside.hexes.size() + a.meshes.outside.hexes.size());
        whole = whole_cell_saving(g, m.solid->sdf(), adaptive_hexes);
        ok = a.check.ok;
      }
      const double tree_s = t.refine + t.balance + t.complex;
      const double cells = double(cells_n);
      const int finest = levels - 1;
      const double uniform = std::pow(27.0, finest);

      // Fidelity of the MCHex inside meshes: adaptive, and uniform at the finest level (or the
      // deepest one meshed).
      const int udepth = std::min(finest, iou_depth);
      request.options.threshold = 0;
      request.options.depth = udepth;
      const MeshRun u = run_pipeline(request, *m.solid);
      const Fidelity& fu = *u.fidelity;
      ok = ok && u.check.ok;
      const double uniform_hexes = double(u.meshes.inside.hexes.size() + u.meshes.outside.hexes.size());
      const double hex_ratio = udepth == finest ? adaptive_hexes / uniform_hexes : NAN;

      fmt::print(
          "{:<30} {:>3} {:>3} {:>9} {:>6.3f} {:>6.3f} | {:>6.3f} {:>6.3f} {:>6.3f} {:>6.3f} {:>8.2f} {:>8.2f} | {:>3} {:>7.3f} {:>7.5f} {:>7.5f} {:>8.4f} {:>8.4f} {:>6.1f}{}\n",
          m.name, max_depth, levels, cells_n, cells / uniform, hull, t.refine, t.balance, t.complex, t.sdf + sdf_rest,
          cells / tree_s / 1e6, cells / t.cpu / 1e6, udepth, hex_ratio, fa.iou, fu.iou, 100 * fa.hausdorff_ratio,
          100 * fu.hausdorff_ratio, 100 * whole, ok ? "" : "  CHECK FAILED");
      json += fmt::format(
          "{}{{\"shape\":\"{}\",\"max_depth\":{},\"levels\":{},\"cells\":{},\"uniform_cells\":{:.0f},\"ratio\":{:.6f},"
          "\"hull\":{:.4f},\"refine_s\":{:.4f},\"balance_s\":{:.4f},\"complex_s\":{:.4f},\"sdf_s\":{:.4f},"
          "\"cells_per_s\":{:.1f},\"cells_per_cpu_s\":{:.1f},\"points\":{},\"unsampled_points\":{},\"uniform_depth\":{},"
          "\"mchex_hexes\":{:.0f},\"uniform_mchex_hexes\":{:.0f},\"iou\":{:.6f},\"uniform_iou\":{:.6f},"
          "\"hausdorff_ratio\":{:.6g},\"uniform_hausdorff_ratio\":{:.6g},\"whole_cell_saving\":{:.4f},\"check_ok\":{}}}",
          json.empty() ? "" : ",", m.name, max_depth, levels, cells_n, uniform, cells / uniform, hull, t.refine,
          t.balance, t.complex, t.sdf + sdf_rest, cells / tree_s, cells / t.cpu, points, unsampled, udepth,
          adaptive_hexes, uniform_hexes, fa.iou, fu.iou, fa.hausdorff_ratio, fu.hausdorff_ratio, whole, ok);
      std::fflush(stdout);
    }
  fmt::print(
      "lvl: levels with a leaf (finest = lvl - 1); ratio: cells / 27^(lvl-1); hull: see the header comment;\n"
      "times in s (sdf: refinement batches + the complex's unsampled points); M cells/s: cells / (refine + bal + cmplx);\n"
      "/CPU s: M cells per CPU second of those stages (all threads; load-independent);\n"
      "uni: the uniform depth compared (= lvl - 1 unless deeper than --iou-depth); hexes: MCHex hexes (both meshes),\n"
      "adaptive / uniform, when uni = lvl - 1; IoU, HR (Hausdorff / diagonal) of the inside mesh, a(daptive) and u(niform);\n"
      "whole%: share of the adaptive hexes that keeping uncut cells away from cut ones whole would save at most.\n");
  fmt::print("{{\"bench\":\"adaptive\",\"threshold\":{},\"iou_depth\":{},\"lattice\":{},\"results\":[{}]}}\n",
             threshold, iou_depth, lattice, json);
  return 0;
}
