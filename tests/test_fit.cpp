// The grid that fits the model (core/pipeline/fit.h): the depth rule against its definition
// computed here from the cube and the bounds; the hex prediction against the meshes the mesher
// then makes (an upper bound, exact but for affine MC33 11 and 14 cells, whose count the mesher
// reports itself); the cap's search against its promise (the chosen setting fits, the next finer
// one it built does not) and the pipeline's output; the errors as their exception types.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/check/fidelity.h"
#include "core/cutting/mchex_mesher.h"
#include "core/cutting/ro.h"
#include "core/grid/grid.h"
#include "core/grid/octree.h"
#include "core/pipeline/fit.h"
#include "core/pipeline/pipeline.h"
#include "core/pipeline/report.h"
#include "core/sdf/shapes.h"
#include "host/backends/registry.h"

namespace mchex {
namespace {

MeshRun run_cpu(MeshRequest request) {
  const std::unique_ptr<Backend> cpu = make_backend("cpu");
  request.backend = cpu.get();
  request.options.quiet = true;
  return run_pipeline(request);
}

TEST(Fit, DepthIsTheShallowestWhoseFinestCellIsAtMostHTimesTheDiagonal) {
  for (const ShapeKind kind : {ShapeKind::kSphere, ShapeKind::kTorus, ShapeKind::kTwoHoled}) {
    const ShapeSdf sdf(kind);
    const Box bounds = sdf.bounds(), cube = padded_cube(bounds, 0.1);
    const double edge = cube.hi.x - cube.lo.x, diag = bounds.diagonal();
    int previous = 0;
    for (const double h : {0.2, 0.05, 0.015, 0.01, 0.004, 0.001}) {
      const AdaptiveOptions o = adaptive_for_hausdorff(h, bounds, cube);
      // The error test's depth is the base grid; the measured rounds may go kFitExtraLevels below.
      EXPECT_LE(edge / std::pow(3.0, o.error_depth), kFinestCellPerHausdorff * h * diag) << h;
      if (o.error_depth > 0) {
        EXPECT_GT(edge / std::pow(3.0, o.error_depth - 1), kFinestCellPerHausdorff * h * diag) << h;
      }
      EXPECT_EQ(o.max_depth, std::min(kMaxAdaptiveDepth, o.error_depth + kFitExtraLevels)) << h;
      EXPECT_EQ(o.threshold, kFitThreshold);
      EXPECT_GE(o.error_depth, previous) << "a smaller target never gives a coarser grid";
      previous = o.error_depth;
    }
  }
  // The default target on a sphere: base finest cell 2.4 / 81 = 0.030 <= 3 x 0.005 x 2 sqrt(3) = 0.052
  // < 2.4 / 27.
  const ShapeSdf sphere(ShapeKind::kSphere);
  const AdaptiveOptions d =
      adaptive_for_hausdorff(kDefaultHausdorffRatio, sphere.bounds(), padded_cube(sphere.bounds(), 0.1));
  EXPECT_EQ(d.error_depth, 4);
  EXPECT_EQ(d.max_depth, 6);
  // A target too small for the key fields stops at the deepest level.
  const AdaptiveOptions tiny = adaptive_for_hausdorff(1e-12, sphere.bounds(), padded_cube(sphere.bounds(), 0.1));
  EXPECT_EQ(tiny.error_depth, kMaxAdaptiveDepth);
  EXPECT_EQ(tiny.max_depth, kMaxAdaptiveDepth);
  for (const double bad : {0.0, -0.1, std::nan(""), double(INFINITY)})
    EXPECT_THROW(adaptive_for_hausdorff(bad, sphere.bounds(), sphere.bounds()), InputError) << bad;
}

TEST(Fit, PredictionIsTheMeshersCountOrAnUpperBoundOfIt) {
  for (const ShapeKind kind : {ShapeKind::kSphere, ShapeKind::kTorus, ShapeKind::kTwoHoled}) {
    const ShapeSdf sdf(kind);
    const Box cube = padded_cube(sdf.bounds(), 0.1);
    Octree tree = refine_octree(sdf, cube, {0.05, 3});
    balance_octree(tree);
    AdaptiveGrid g = build_adaptive_complex(tree);
    evaluate_unsampled(g, sdf);
    MchexStats stats;
    const MeshPair m = mesh_mchex(g.complex, g.values, 1e-3, &stats);
    const std::size_t made = m.inside.hexes.size() + m.outside.hexes.size();
    const std::size_t predicted = predict_hexes(g, g.values, "mchex");
    EXPECT_EQ(stats.expected_hexes, made);
    EXPECT_GE(predicted, made);
    // Only the affine 11 and 14 cells are counted high (by local refinement's extra hexes).
    if (stats.cases[static_cast<int>(Subcase::k11)] + stats.cases[static_cast<int>(Subcase::k14)] == 0) {
      EXPECT_EQ(predicted, made);
    }
    const MeshPair ro = mesh_remove_outside(g.complex, g.values);
    EXPECT_EQ(predict_hexes(g, g.values, "ro"), ro.inside.hexes.size() + ro.outside.hexes.size());
  }
}

TEST(Fit, TheCapIsTheLargestSettingPredictedToFitAndThePipelineKeepsIt) {
  const ShapeSdf sdf(ShapeKind::kTorus);
  const Box cube = padded_cube(sdf.bounds(), 0.1);
  const AdaptiveOptions start{kFitThreshold, 4};
  for (const std::size_t cap : {std::size_t{20'000}, std::size_t{150'000}, std::size_t{600'000}}) {
    const FitResult r = fit_max_hexes(sdf, cube, start, cap, "mchex");
    EXPECT_LE(r.predicted_hexes, cap);
    ASSERT_FALSE(r.trials.empty());
    // Every setting the search built is reported, and the chosen one is among them; none that
    // fits has more hexes, and the first over the cap (if any) is finer than the chosen one.
    bool found = false;
    for (const FitTrial& t : r.trials) {
      found = found || (t.options.max_depth == r.options.max_depth && t.options.threshold == r.options.threshold);
      if (t.predicted_hexes <= cap) {
        EXPECT_LE(t.predicted_hexes, r.predicted_hexes);
      }
      EXPECT_LE(t.options.max_depth, start.max_depth);
      EXPECT_GE(t.options.threshold, start.threshold);
    }
    EXPECT_TRUE(found);

    MeshRequest request;
    request.solid.shape = "torus";
    request.options.threshold = start.threshold;
    request.options.max_depth = start.max_depth;
    request.options.max_hexes = cap;
    const MeshRun run = run_cpu(request);
    ASSERT_TRUE(run.fit);
    EXPECT_TRUE(run.check.ok);
    const std::size_t made = run.meshes.inside.hexes.size() + run.meshes.outside.hexes.size();
    EXPECT_LE(made, cap);
    EXPECT_LE(made, run.fit->predicted_hexes);
    EXPECT_EQ(run.options.max_depth, r.options.max_depth);
    EXPECT_EQ(run.options.threshold, r.options.threshold);
    const nlohmann::json j = report_json(run);
    EXPECT_EQ(j["fit"]["max_hexes"], cap);
    EXPECT_EQ(j["fit"]["predicted_hexes"], r.predicted_hexes);
    EXPECT_EQ(j["fit"]["trials"].size(), r.trials.size());
    EXPECT_EQ(j["grid"]["max_depth"], r.options.max_depth);
  }
  // The largest cap keeps the starting setting when it fits.
  const FitResult all = fit_max_hexes(sdf, cube, {kFitThreshold, 3}, std::size_t{1} << 40, "mchex");
  EXPECT_EQ(all.options.max_depth, 3);
  EXPECT_EQ(all.options.threshold, kFitThreshold);
}

TEST(Fit, NoSettingFitsIsAResourceErrorNamingACapThatWould) {
  const ShapeSdf sdf(ShapeKind::kSphere);
  try {
    fit_max_hexes(sdf, padded_cube(sdf.bounds(), 0.1), {0.2, 3}, 3, "mchex");
    FAIL() << "no ResourceError";
  } catch (const ResourceError& e) {
    EXPECT_NE(std::string(e.what()).find("--max-hexes 8 would fit"), std::string::npos) << e.what();
  }
  MeshRequest request;
  request.options.depth = 2;
  request.options.max_hexes = 1000;
  EXPECT_THROW(run_cpu(request), InputError);  // a cap needs the adaptive grid
}

TEST(Fit, AHausdorffTargetChoosesTheGridAndTheReportSaysSo) {
  MeshRequest request;
  request.solid.shape = "sphere";
  request.options.hausdorff = 0.05;
  request.options.fidelity = true;
  request.options.lattice = 48;
  const MeshRun run = run_cpu(request);
  ASSERT_TRUE(run.adaptive);
  EXPECT_TRUE(run.check.ok);
  const ShapeSdf sphere(ShapeKind::kSphere);
  const AdaptiveOptions o = adaptive_for_hausdorff(0.05, sphere.bounds(), padded_cube(sphere.bounds(), 0.1));
  EXPECT_EQ(run.options.max_depth, o.max_depth);
  EXPECT_EQ(run.options.threshold, o.threshold);
  const nlohmann::json j = report_json(run);
  EXPECT_EQ(j["fit"]["hausdorff_target"], 0.05);
  EXPECT_TRUE(j["fit"]["max_hexes"].is_null());
  EXPECT_FALSE(j["fit"].contains("trials"));
  ASSERT_TRUE(run.fidelity);
  EXPECT_EQ(j["fidelity"]["iou"], run.fidelity->iou);
  EXPECT_EQ(j["fidelity"]["hausdorff_ratio"], run.fidelity->hausdorff_ratio);
  // The sphere at its fitted depth is within the target.
  EXPECT_LE(run.fidelity->hausdorff_ratio, 0.05);
  EXPECT_GT(run.fidelity->iou, 0.97);
}

// What makes fidelity cheap enough to be on by default changes none of its results: the IoU
// lattice decided block by block where |f| bounds the distance to a sign change gives the signs
// of evaluating every sample; the surface samples cover a sliver triangle at the spacing with
// about area / spacing^2 points.
TEST(Fit, CheapFidelityIsTheFullMeasure) {
  for (const ShapeKind kind : {ShapeKind::kSphere, ShapeKind::kTwoHoled}) {
    const ShapeSdf sdf(kind);
    const Box cube = padded_cube(sdf.bounds(), 0.1);
    const UniformGrid grid(cube, 2);
    const std::vector<Vec3> points = grid.vertices();
    std::vector<double> v(points.size());
    sdf.evaluate(points, v);
    const MeshPair m = mesh_mchex(grid, v, 1e-3);
    const double spacing = cube.diagonal() / 100;
    const std::vector<Vec3> samples = sample_surface(sdf, cube, spacing);
    for (const std::size_t lattice : {std::size_t{37}, std::size_t{64}}) {
      const Fidelity full = measure_fidelity(m.inside, sdf, samples, cube, lattice, spacing);
      const Fidelity fast = measure_fidelity(m.inside, sdf, samples, cube, lattice, spacing, {}, true);
      EXPECT_EQ(full.iou, fast.iou) << lattice;
      EXPECT_EQ(full.solid_volume, fast.solid_volume) << lattice;
      EXPECT_EQ(full.hausdorff, fast.hausdorff) << lattice;
    }
  }
  TriangleSurface sliver;
  sliver.vertices = {{0, 0, 0}, {10, 0, 0}, {10, 0.05, 0}};
  sliver.triangles = {{0, 1, 2}};
  const double spacing = 0.1;
  const std::vector<Vec3> s = sample_surface(sliver, spacing);
  EXPECT_LE(s.size(), 2 * (10 / spacing + 2));  // a grid over two edges gave about 5,000
  for (int i = 0; i <= 1000; ++i) {
    const double u = i / 1000.0, w = 0.5 * u;  // points across the whole triangle
    const Vec3 p{10 * u, 0.05 * w, 0};
    double nearest = 1e9;
    for (const Vec3& q : s) nearest = std::min(nearest, norm(q - p));
    EXPECT_LE(nearest, spacing) << i;
  }
}

}  // namespace
}  // namespace mchex
