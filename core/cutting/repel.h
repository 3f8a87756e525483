// Grid-point repelling (Awad et al. 2016, Section 2.2, Figure 2): before the cells are cut, a
// grid point that lies closer than delta to the isosurface along one of its grid edges moves
// along that edge, away from the crossing, until the crossing is delta from it. Without it a
// crossing may land arbitrarily close to a corner and the polyhedra get near-zero edges: the
// smallest scaled Jacobians of the mesh. Awad et al. chose delta = s/4 (s the cube's size); here
// delta is a fraction of each grid edge's length, so it serves the adaptive grid's transition
// cells as well as cubes.
//
// The rules (docs/repel.md):
//  - Crossings are the ones the mesher uses: the linear t = f_a / (f_a - f_b) on an edge with a
//    sign change (the zero rule's sign: v >= zero_tolerance is inside), or with exact_crossings
//    the field's own zero on the edge (search_crossings). Edge e = (a, b) asks a to
//    move when t < delta, b when 1 - t < delta, by the distance that puts the crossing at delta
//    of the edge if the isosurface stays where it is.
//  - Jacobi rounds (at most max_rounds): every point gathers its requests from the current
//    positions and values, then all moves are applied at once; each point writes only its own
//    result, so the outcome does not depend on the thread count.
//  - A point keeps its largest request (ties: the lowest edge id). It is pinned (stays) when
//    another request points the opposite way (moving away from one crossing would move it
//    towards the other), when it already moved along another edge direction (a point moves
//    along one grid line only), when its move would leave a face of the padded cube it lies on,
//    or when the move would change its sign (the SDF is evaluated at the new position).
//  - A point's displacement never exceeds max_move x its shortest incident edge (0.45: its
//    cells stay close to the boxes they were and their edges never reverse).
//  - Off-line rounds (our extension; Awad moves along grid lines only): a point whose request is
//    still unmet after the grid-line rounds, and that lies on no face of the padded cube, moves
//    along the SDF's gradient (central differences through the same batch), away from the
//    isosurface, by what would make |f| at least kOffLineMargin x delta x its longest cut incident
//    edge (then every crossing on its edges is at least delta from it, the SDF being 1-Lipschitz),
//    within kOffLineCap of the cap from its grid position; taken only where the sign stays and
//    the nearest crossing on its edges gets farther (no crossing is traded for another; measured
//    on the linear crossings, even with exact_crossings: a candidate's zeros are not searched), and
//    never at a crease of the field (kKinkSlope).
//    Where the isosurface grazes a grid line, moving along the line barely moves the crossing,
//    and a point a crossing asks to move along two lines may take only one: along the gradient
//    both are served by the shortest move (docs/repel.md, "Off the grid lines").
// Points are moved, values re-evaluated; the complex's topology is untouched, so the sign of
// every point and therefore every edge's cut state stays the same. The moved cells are not boxes:
// the mesher maps through each cell's actual corners and Bernstein-checks every hex; a moved cell
// whose hexes are not certified has its corners' moves halved, then undone (relax_cells), and is
// meshed again.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "core/base/geometry.h"
#include "core/cutting/mchex_mesher.h"
#include "core/grid/hex_complex.h"

namespace mchex {

struct RepelOptions {
  double delta = 0.25;      // wanted distance of a crossing from each end, a fraction of its edge
  int max_rounds = 4;       // Jacobi rounds along the grid lines
  double max_move = 0.45;   // displacement cap, a fraction of the point's shortest incident edge
  int off_line_rounds = 4;  // Jacobi rounds along the gradient for the points still pinned (0: Awad's rule alone)
  // The crossings the rules measure: false, where the edge's two values interpolated linearly are
  // zero; true, the field's own zero on the edge (core/cutting/mchex_mesher.h search_crossings),
  // which is where the mesher's `--crossings exact` puts them.
  bool exact_crossings = false;
};

// The off-line rounds aim |f| this much past delta x the longest cut edge: the field is not linear
// along the edges, so a move to exactly that value leaves some crossings a little short.
inline constexpr double kOffLineMargin = 1.05;
// An off-line move's cap, a fraction of the grid-line cap (max_move x the shortest edge): a move
// across the grid lines shears the point's cells, and at the full cap that made the worst hex of a
// junction of three spheres 0.004 (docs/repel.md, "Off the grid lines").
inline constexpr double kOffLineCap = 0.75;
// The central differences' step, a fraction of the point's displacement cap.
inline constexpr double kGradientStep = 1e-3;
// A point where the one-sided differences along an axis differ by more than this slope lies on
// a crease of the field (a junction of several shells, the medial sheet of a thin part): there
// the gradient points nowhere useful, and the point stays.
inline constexpr double kKinkSlope = 0.05;

// The default delta (docs/repel.md measures the choice) and the accepted range (0, kMaxRepelDelta].
inline constexpr double kDefaultRepelDelta = 0.25;
inline constexpr double kMaxRepelDelta = 0.45;

// Per point, after repel.
enum class RepelState : std::uint8_t {
  kStill = 0,  // never asked to move, or every request met
  kMoved,      // moved, every request met
  kPinned,     // a request is still unmet after the last round (moved or not)
};

struct RepelStats {
  double delta = 0;
  std::size_t moved = 0;     // points at a new position
  std::size_t pinned = 0;    // points with a request still unmet (RepelState::kPinned)
  std::size_t restored = 0;  // moved points given back their grid position (relax_cells)
  std::size_t relaxed = 0;   // moves halved by relax_cells (a point may count once per halving)
  std::size_t off_line = 0;  // points the off-line rounds moved (off their grid line)
  int rounds = 0;            // grid-line rounds that moved a point
  int off_line_rounds = 0;   // off-line rounds that moved a point
};

struct Repelled {
  std::vector<Vec3> points;            // the complex's points, moved
  std::vector<double> values;          // the SDF at them (re-evaluated where moved)
  std::vector<RepelState> state;       // per point
  std::vector<std::uint8_t> halvings;  // per point: how often relax_cells halved its move
  std::vector<std::uint8_t> off_line;  // per point: 1 where an off-line round moved it
  RepelStats stats;
};

// cube: the padded cube the complex fills (its face points stay on their faces). values: the
// SDF at complex.points. Throws InputError for a delta outside (0, kMaxRepelDelta] or a size
// mismatch.
Repelled repel(const HexComplex& complex, const Box& cube, std::span<const double> values, const SdfBatch& sdf,
               const RepelOptions& options = {});

// Whether edge parameter t (from the edge's first point) is at least delta from both ends, with
// the slack repel allows for rounding.
bool crossing_clear(double t, double delta);

// How often relax_cells halves a point's move before it gives the point its grid position back.
inline constexpr int kMaxRelaxHalvings = 2;

// The remedy for cells whose moved shape left a hex uncertified: each moved corner of `cells`
// goes halfway back to its grid position (the SDF evaluated there) while it has been halved
// fewer than kMaxRelaxHalvings times and the half-way value keeps the point's sign; else it gets
// its grid position and value back (unmoved_values: the SDF at complex.points). A half move keeps
// most of what repelling bought (the crossing between where it was and DELTA, instead of back at
// the clamp), and a halved point counts as pinned (its request is unmet again). Returns how many
// points changed; each call changes every moved corner of `cells`, so repeated calls end at the
// grid. stats.moved, pinned, relaxed and restored follow. Deterministic: every point depends only
// on its own state.
std::size_t relax_cells(const HexComplex& complex, std::span<const double> unmoved_values,
                        std::span<const std::uint32_t> cells, const SdfBatch& sdf, Repelled& repelled);

}  // namespace mchex
