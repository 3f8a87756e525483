#include "core/pipeline/fit.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include <fmt/format.h>

#include "core/base/error.h"
#include "core/base/parallel.h"
#include "core/cutting/local_refinement.h"
#include "core/cutting/mc33.h"
#include "core/cutting/mchex_mesher.h"

namespace mchex {
namespace {

// The threshold grows by this factor per step at the depth over the cap; after kThresholdSteps
// steps (x 64) the grid at that depth is close to the one a level coarser, which is already known.
constexpr double kThresholdStep = 2;
constexpr int kThresholdSteps = 6;

FitTrial build_and_predict(const SignedDistance& sdf, const Box& cube, const AdaptiveOptions& options,
                           const std::string& method) {
  Octree tree = refine_octree(sdf, cube, options);
  balance_octree(tree);
  AdaptiveGrid grid = build_adaptive_complex(tree);
  FitTrial t;
  t.options = options;
  t.cells = grid.complex.cells.size();
  if (method == "ro") {
    t.predicted_hexes = t.cells;  // RO: every cell is one hex of one of the two meshes
    return t;
  }
  evaluate_unsampled(grid, sdf);
  t.predicted_hexes = predict_hexes(grid, grid.values, method);
  return t;
}

}  // namespace

AdaptiveOptions adaptive_for_hausdorff(double hausdorff_ratio, const Box& bounds, const Box& cube) {
  if (!(hausdorff_ratio > 0) || !std::isfinite(hausdorff_ratio))
    throw InputError(fmt::format("the Hausdorff ratio must be positive, got {}", hausdorff_ratio));
  const double finest = kFinestCellPerHausdorff * hausdorff_ratio * bounds.diagonal();
  const double edge = cube.hi.x - cube.lo.x;
  AdaptiveOptions o;
  o.threshold = kFitThreshold;
  o.max_depth = 0;
  while (o.max_depth < kMaxAdaptiveDepth && edge / std::pow(3.0, o.max_depth) > finest) ++o.max_depth;
  o.error_depth = o.max_depth;
  o.max_depth = std::min(kMaxAdaptiveDepth, o.max_depth + kFitExtraLevels);
  return o;
}

std::size_t predict_hexes(const AdaptiveGrid& grid, std::span<const double> values, const std::string& method) {
  const HexComplex& cx = grid.complex;
  if (method == "ro") return cx.cells.size();
  // The values every cell is classified from, as the mesher sees them (its zero rule).
  const std::vector<double> f = apply_zero_rule(cx, values);
  return parallel_reduce(
      cx.cells.size(), 4096, std::size_t{0},
      [&](std::size_t begin, std::size_t end, std::size_t sum) {
        for (std::size_t c = begin; c < end; ++c) {
          std::array<double, 8> fc;
          for (int k = 0; k < 8; ++k) fc[k] = f[cx.cells[c][k]];
          sum += static_cast<std::size_t>(local_refinement_hexes(classify(fc).subcase));
        }
        return sum;
      },
      [](std::size_t a, std::size_t b) { return a + b; });
}

FitResult fit_max_hexes(const SignedDistance& sdf, const Box& cube, const AdaptiveOptions& start, std::size_t max_hexes,
                        const std::string& method) {
  FitResult r;
  auto trial = [&](const AdaptiveOptions& o) -> const FitTrial& {
    r.trials.push_back(build_and_predict(sdf, cube, o, method));
    return r.trials.back();
  };
  // From the coarsest grid up, at the starting threshold: the deepest level that fits.
  std::optional<FitTrial> fits;
  int over = -1;  // the first depth over the cap
  for (int d = 0; d <= start.max_depth; ++d) {
    const FitTrial& t = trial({start.threshold, d});
    if (t.predicted_hexes > max_hexes) {
      over = d;
      break;
    }
    fits = t;
  }
  if (over < 0) {
    r.options = fits->options;
    r.predicted_hexes = fits->predicted_hexes;
    return r;
  }
  if (over == 0)
    throw ResourceError(fmt::format("--max-hexes {}: even the unrefined cube makes {} hexes; --max-hexes {} would fit",
                                    max_hexes, r.trials.back().predicted_hexes, r.trials.back().predicted_hexes));
  // At the depth over the cap, a higher threshold keeps only the cells of largest error refined.
  double threshold = start.threshold;
  for (int s = 0; s < kThresholdSteps; ++s) {
    threshold *= kThresholdStep;
    const FitTrial& t = trial({threshold, over});
    if (t.predicted_hexes <= max_hexes) {
      if (t.predicted_hexes > fits->predicted_hexes) fits = t;
      // One bisection step between the last threshold over the cap and this one: a step of 2 in
      // the threshold can change the output several times over.
      const FitTrial& mid = trial({threshold / std::sqrt(kThresholdStep), over});
      if (mid.predicted_hexes <= max_hexes && mid.predicted_hexes > fits->predicted_hexes) fits = mid;
      break;
    }
  }
  r.options = fits->options;
  r.predicted_hexes = fits->predicted_hexes;
  return r;
}

std::vector<Vec3> chase_ahead(const Octree& tree, const SignedDistance& sdf, std::span<const Vec3> far,
                              std::span<const Vec3> previous) {
  if (previous.empty()) return {};
  const Box& cube = tree.cube();
  // Per far sample its run's candidates, in order, and how near the surface they must stay.
  struct Run {
    std::size_t first, count;
    double reach;  // the half diagonal of the run's leaves
  };
  std::vector<Run> runs;
  std::vector<Vec3> candidates;
  for (const Vec3& p : far) {
    const Vec3* q = &previous[0];
    for (const Vec3& c : previous)
      if (squared_norm(c - p) < squared_norm(*q - p)) q = &c;
    const int level = leaf_level_at(tree, p);
    if (level < 0) continue;
    const double leaf = cube.size().x / std::pow(3.0, level);
    // One leaf on along a grid axis, as a run of same-level leaves repeats (a step across a run,
    // or a diagonal one, would spread the refinement over the surface).
    const Vec3 step = p - *q;
    const double length = norm(step);
    const double along = std::max({std::abs(step.x), std::abs(step.y), std::abs(step.z)});
    if (!(length >= 0.9 * leaf && length <= 1.1 * leaf && along >= 0.99 * length)) continue;
    Run run{candidates.size(), 0, 0.5 * std::sqrt(3.0) * leaf};
    for (int k = 1; k <= kChaseSteps; ++k) {
      const Vec3 x = p + double(k) * step;
      if (!cube.contains(x) || leaf_level_at(tree, x) != level) break;
      candidates.push_back(x);
      ++run.count;
    }
    if (run.count) runs.push_back(run);
  }
  std::vector<double> f(candidates.size());
  if (!candidates.empty()) sdf.evaluate(candidates, f);
  std::vector<Vec3> ahead;
  for (const Run& run : runs)
    for (std::size_t i = run.first; i < run.first + run.count && std::abs(f[i]) <= run.reach; ++i)
      ahead.push_back(candidates[i]);
  std::sort(ahead.begin(), ahead.end(), lexicographic_less);
  ahead.erase(std::unique(ahead.begin(), ahead.end()), ahead.end());
  return ahead;
}

}  // namespace mchex
