// A grid that fits the model: the adaptive 3-refinement grid (core/grid/octree.h) with its settings
// chosen from a target Hausdorff ratio (the paper's HR, Tong & Zhang 2025 Section 6: the two-sided
// Hausdorff distance between the inside mesh's boundary and the input surface over the input's
// bounding-box diagonal), and optionally capped in output size.
//
// What drives HR. MCHex places the surface where the trilinear interpolant of each cell crosses
// zero (paper Section 5), so on a cell the surface is misplaced by at most about the refinement
// error the octree allowed there (threshold x the finest cell size, core/grid/octree.h) plus what
// a cell of the finest size cannot resolve (a feature thinner than a cell is lost whole, a sharp
// tip is cut back by a few cells). The finest cell size h = cube edge / 3^D therefore sets HR:
// the rule picks the smallest max depth D with h <= kFinestCellPerHausdorff x H x diagonal, and
// the refinement threshold kFitThreshold (in units of h, so the coarser cells' error stays well
// below h). Both constants are measured (docs/pipeline.md has the table): on the npm bunny,
// gearwheel and cube and a bumpy torus the measured HR was 0.07 to 0.87 h / diagonal, so a
// finest cell of H x diagonal gives HR <= H on them; the irregular tetrahedron's sharp tips
// lose about 4 h. A threshold of 0.2 already lost the analytic torus's finest level (IoU 0.978
// against 0.997 at 0.05, the paper's batch value).
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
#include <string>
#include <vector>

#include "core/base/geometry.h"
#include "core/grid/octree.h"
#include "core/sdf/sdf.h"

namespace mchex {

// The default target Hausdorff ratio: max depth 4 on any model (the finest cell is 1.2 x the largest
// extent / 81, at most 0.0148 x its diagonal): IoU 0.989 to 1 (median 0.996) on the models
// above and the analytic shapes; the sharp ones (gearwheel, tetrahedron) need depth 5 for 0.994.
inline constexpr double kDefaultHausdorffRatio = 0.005;
// Finest cell size per unit of H x input diagonal (measured HR <= 0.87 finest cells / diagonal
// on smooth models).
inline constexpr double kFinestCellPerHausdorff = 3.0;
// The refinement threshold the rule uses, in finest cells (core/grid/octree.h AdaptiveOptions).
inline constexpr double kFitThreshold = 0.05;
// The measured rounds of the fitted grid (core/pipeline/pipeline.cpp) may refine this many levels
// below the error test's deepest level, in at most kFitRounds rounds.
inline constexpr int kFitExtraLevels = 2;
inline constexpr int kFitRounds = 3;
// A leaf is refined for the IoU when this many lattice samples in it disagree with the solid.
inline constexpr std::size_t kFitMisclassifiedPerLeaf = 2;
// ... while the measured IoU is below this (the MCHex prototype's defaults reach 0.996 to 0.9997 on
// the models of perf/CURVES.md).
inline constexpr double kFitIou = 0.998;

// The adaptive settings for target Hausdorff ratio `hausdorff_ratio` (> 0) of a solid with these
// bounds meshed over `cube`: max depth the smallest D (at most kMaxAdaptiveDepth) with
// cube edge / 3^D <= kFinestCellPerHausdorff x hausdorff_ratio x bounds diagonal, threshold
// kFitThreshold. InputError for a ratio that is not positive and finite.
AdaptiveOptions adaptive_for_hausdorff(double hausdorff_ratio, const Box& bounds, const Box& cube);

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
