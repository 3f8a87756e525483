// A grid that fits the model: the adaptive 3-refinement grid (core/grid/octree.h) with its settings
// chosen from a target Hausdorff ratio (the paper's HR, Tong & Zhang 2025 Section 6: the two-sided
// Hausdorff distance between the inside mesh's boundary and the input surface over the input's
// bounding-box diagonal), and optionally capped in output size.
//
// The rule, in two steps (docs/pipeline.md "The fitted grid" has the measurements):
//  1. the base grid: the paper's error test (threshold kFitThreshold, in finest cells of the error
//     depth) refines to the error depth D, the smallest with cube edge / 3^D <= kFinestCellPerHausdorff
//     x H x diagonal; the octree's max depth is D + kFitExtraLevels, for step 2 only;
//  2. measured rounds (core/pipeline/pipeline.cpp, with the fidelity measure on and no cap): the
//     mesh is measured, the leaves holding samples farther than H x diagonal from the other surface
//     (and, while the IoU is under kFitIou, leaves holding kFitMisclassifiedPerLeaf lattice samples
//     where mesh and solid disagree) are refined, and the grid meshed again, at most kFitRounds
//     times. The a-priori error underestimates what MC loses at tips, thin parts and sharp edges
//     (a tip about one cell across: 0.3 to 1.3 finest cells of error where the mesh lies 5 cells
//     below the input); the measure is what the report says, so the rounds aim at that.
//
// The cap (fit_max_hexes). The output size of a setting is predicted from its built grid before
// any meshing: refine, balance and build the complex (cheap next to meshing), evaluate the SDF at
// the points the refinement did not sample, classify every cell (core/cutting/mc33.h) and sum the
// hexes its subcase makes (local_refinement_hexes on a general cell; RO: one per cell). The
// prediction is exact except for the MC33 11 and 14 cells of affine shape, which are cut into
// fewer hexes: it is an upper bound, so a setting predicted to fit does fit. The search keeps the
// cells of largest error refined: from the coarsest grid up, the max depth grows at the starting
// threshold until a depth D is over the cap; then at D the threshold is doubled (the cells whose
// error exceeds it stay refined, the rest coarsen) until one fits (at most 64 times the start),
// one bisection step (a factor sqrt 2) between that and the last over the cap, and the fitting
// setting with the most hexes, one of those or depth D - 1, wins. No setting fits when even the unrefined cube (one
// cell) is over the cap: ResourceError naming the smallest cap that would fit.
#pragma once

#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include "core/base/geometry.h"
#include "core/grid/octree.h"
#include "core/sdf/sdf.h"

namespace mchex {

// The default target Hausdorff ratio: about the MCHex prototype's HR at its defaults (0.0046 to
// 0.0066 on the public models of perf/curves/prototype.csv); its base grid has error depth 4 on
// any model (the finest cell is 1.2 x the largest extent / 81, at most 0.0148 x its diagonal).
inline constexpr double kDefaultHausdorffRatio = 0.005;
// The base grid's finest cell per unit of H x input diagonal: HR was 0.07 to 0.87 finest cells /
// diagonal on smooth models at depths 3 to 5, so 3 H leaves the rounds the smooth models' worst
// places and the sharp ones' tips.
inline constexpr double kFinestCellPerHausdorff = 3.0;
// The refinement threshold the rule uses, in finest cells (core/grid/octree.h AdaptiveOptions).
inline constexpr double kFitThreshold = 0.05;
// The measured rounds of the fitted grid (core/pipeline/pipeline.cpp) may refine this many levels
// below the error test's deepest level, in at most kFitRounds rounds (the npm gearwheel, whose far
// samples move along its tooth roots, takes 4 with chase_ahead below, 7 without; docs/pipeline.md).
inline constexpr int kFitExtraLevels = 2;
inline constexpr int kFitRounds = 8;
// A leaf is refined for the IoU when this many lattice samples in it disagree with the solid.
inline constexpr std::size_t kFitMisclassifiedPerLeaf = 2;
// ... while the measured IoU is below this at the default H (the MCHex prototype's defaults reach
// 0.996 to 0.9997 on the models of perf/CURVES.md).
inline constexpr double kFitIou = 0.998;
// The IoU the rounds aim at for a target H: the shortfall 1 - IoU scales with H (both are a
// boundary error in units of the model's size), so a looser H asks a looser IoU. A fixed IoU made
// a looser H cost more hexes than a tighter one (perf/README.md: the gearwheel at H 0.02 had 2.4 M
// hexes where H 0.01 had 1.4 M), as coarse base grids were refined leaf by leaf to 0.998.
inline constexpr double fit_iou(double hausdorff_ratio) {
  return 1 - (1 - kFitIou) * hausdorff_ratio / kDefaultHausdorffRatio;
}

// The adaptive settings for target Hausdorff ratio `hausdorff_ratio` (> 0) of a solid with these
// bounds meshed over `cube`: error depth the smallest D (at most kMaxAdaptiveDepth) with
// cube edge / 3^D <= kFinestCellPerHausdorff x hausdorff_ratio x bounds diagonal, max depth
// D + kFitExtraLevels (at most kMaxAdaptiveDepth), threshold kFitThreshold. InputError for a ratio
// that is not positive and finite.
AdaptiveOptions adaptive_for_hausdorff(double hausdorff_ratio, const Box& bounds, const Box& cube);

// The measured rounds' chase (core/pipeline/pipeline.cpp): where a round's far samples all moved
// from the last round's with the same HR (to rounding), refining the far leaves only made
// their neighbours along a run of same-level leaves the next far ones (the npm gearwheel's tooth
// roots, one leaf a round; docs/pipeline.md). Each far sample p steps on from the nearest of the
// last round's samples q, when that step is about a leaf of p's level long: the points p + k (p -
// q), k = 1 to kChaseSteps, up to the first that leaves the cube, lies in a leaf of another level
// or lies farther from the surface than its leaf's half diagonal. Sorted and without repeats.
inline constexpr int kChaseSteps = 3;
std::vector<Vec3> chase_ahead(const Octree& tree, const SignedDistance& sdf, std::span<const Vec3> far,
                              std::span<const Vec3> previous);

// Output hexes (inside and outside together) that `method` ("mchex" | "ro") makes from `grid`
// given the SDF at every point of its complex (`values`; NaN-free): an upper bound, exact but for
// affine MC33 11 and 14 cells (see above).
std::size_t predict_hexes(const AdaptiveGrid& grid, std::span<const double> values, const std::string& method);

// One setting the search built.
struct FitTrial {
  AdaptiveOptions options;
  std::size_t cells = 0;
  std::size_t predicted_hexes = 0;
};

struct FitResult {
  AdaptiveOptions options;  // the chosen setting
  std::size_t predicted_hexes = 0;
  std::vector<FitTrial> trials;  // in the order built
};

// The setting, from `start` down, whose predicted output is at most max_hexes and largest (see
// above). ResourceError when none is.
FitResult fit_max_hexes(const SignedDistance& sdf, const Box& cube, const AdaptiveOptions& start, std::size_t max_hexes,
                        const std::string& method);

}  // namespace mchex
