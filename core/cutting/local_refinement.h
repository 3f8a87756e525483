// Local refinement of one cell (Tong & Zhang 2025, Section 5 and Figure 7): the subcases whose
// 3-regular polyhedra midpoint subdivision cannot be proven positive, and the six tunnel subcases
// (no such polyhedra at all), are split into 7 children before cutting: "connecting its eight grid
// points to its centroid, resulting in seven smaller children cells" (Section 5) - an inner cell
// and 6 frustums, one on each face of the cell. The 8 inserted (inner) points sit at fixed
// positions (halfway from each corner to the centroid, kInnerPointScale); each gets a *virtual* value whose SIGN
// follows a per-subcase template, chosen so that every child falls into a subcase that midpoint subdivision certifies
// and the union of the children's regions has the cell's MC33 topology (Figure 7: "virtual SDF values assigned to new
// vertices ensure each hex falls into the fourteen proven topological cases and the isosurface topology is the same").
// A child whose own subcase still needs refinement is refined once more with its own template (the paper's second
// level, Figure 7 and Section 8).
//
// Guarantees (tests/test_local_refinement.cpp checks each, exhaustively over the 256 sign
// patterns and the face/interior outcomes):
//   conformity  each of the cell's 6 faces is exactly one face of exactly one leaf child (the
//               frustum on it; a refined frustum keeps it whole in its own frustum), so the cell
//               still matches its unrefined neighbours: same 4 values on the face, hence the same
//               face test, crossings, chords, edge midpoints and face centroids. The children
//               meet each other in whole faces;
//   decided by signs alone  no child face other than a face of the cell is ambiguous, and no
//               child has a configuration that admits a tunnel, so every child's subcase follows
//               from the template's signs and the cell's own face tests - never from a virtual
//               value's magnitude. The leaves, their subcases and the hex count are a pure
//               function of the cell's subcase (local_refinement_hexes);
//   topology    the union of the leaves' regions has the cell's regions (same corners, same
//               signs, no extra region) and each is a ball, except the tunnel subcase's region
//               around the tunnel, which is a solid torus;
//   quality     every leaf's subcase is one whose midpoint subdivision certifies (templates
//               chosen by the search in tests/test_local_refinement.cpp, see the table in
//               local_refinement.cpp).
//
// Virtual values (paper: "SDF values for inserted vertices are first computed. When the computed
// sign contradicts the template requirement, the SDF values are adjusted to a minimal magnitude
// with the correct sign"): here the "computed" value is the cell's trilinear interpolant at the
// inner point's parametric position, not a fresh SDF sample, so the result depends only on the
// cell's 8 values (every backend, and both cells next to a shared face, agree without another
// SDF evaluation, and the mesher needs no second SDF pass). Where its sign contradicts the
// template, the magnitude is the interpolant of |f| instead (the field's local scale), with the
// template's sign. Then every magnitude is moved, where the cell's values allow, into the range
// that keeps each crossing on an edge inside the cell at least kInnerCrossingMargin from both
// ends (local_refinement.cpp, virtual_values). The paper's "minimal magnitude" (here
// +-zero_tolerance) put those crossings at the clamp, eps from an inner point, and its polyhedra
// had edges of eps x the cell: on repelled cells the worst hexes of a mesh (npm bunny --repel
// --no-fidelity, min scaled Jacobian 0.002 -> 0.045), and `certify` proved 1409 of 1600 (type, subcase)
// pairs against 1535 with the margin (docs/templates.md). Only magnitudes are chosen, so the
// children's subcases, decided by signs alone, are the template's. A second level treats the
// refined child's 8 values the same way.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/base/geometry.h"
#include "core/cutting/mc33.h"
#include "core/cutting/volume_centre_offset.h"

namespace mchex {

// Placement of the inner points: inner point i = centroid + kInnerPointScale * (corner i -
// centroid), the centroid being the mean of the 8 corners (paper Section 5: the children come from
// "connecting its eight grid points to its centroid"). Taken in space, not in the parametric cube,
// so that the inner cell is an affine image of the cell and the frustums' side faces are planar
// (the paper's "bitter lesson": the closer to affine, the more tractable; see local_refinement.cpp
// for the measured difference on transition cells). On a parallelepiped cell it is the trilinear
// map at parametric 1/4 and 3/4.
inline constexpr double kInnerPointScale = 0.5;
// The parametric position (t and 1 - t) at which an inner point's virtual value interpolates the
// cell's 8 values: the inner point itself on a parallelepiped cell, near it on a transition cell.
// Only the value's magnitude comes from here (the template decides its sign), so it moves the
// crossings on edges inside the cell, never the topology.
inline constexpr double kInnerPointPosition = 0.25;
// How far from both ends a crossing on an edge inside a refined cell is kept, where the cell's
// own values allow (virtual values, above): Awad et al.'s s/4, the distance grid-point repelling
// keeps the cell's own crossings from its corners (core/cutting/repel.h).
inline constexpr double kInnerCrossingMargin = 0.25;

// The 7 children as indices into [cell corners 0..7, inner points 8..15] (inner point 8 + i sits
// next to corner i), each in VTK order and right-handed when the cell is: child 0 is the inner
// cell, child 1 + f the frustum on the cell's face f (faces x=0, x=1, y=0, y=1, z=0, z=1 as in
// core/cutting/mc33.h). A frustum's local axes are the cell's, its local face f is the cell's face f, and
// its edges on that face run in the cell's directions, so it computes the same crossings there.
inline constexpr int kNumLocalRefinementChildren = 7;
using LocalRefinementChild = std::array<std::uint8_t, 8>;
std::array<LocalRefinementChild, kNumLocalRefinementChildren> local_refinement_child_points();

// Per subcase: whether its cells are refined, and the template - the signs of the 8 inner points
// on the subcase's canonical representative (bit i: inner point next to corner i is positive).
// `direct_on_affine`: on an affine cell (CellShape::kAffine, core/cutting/volume_centre_offset.h) the
// subcase is cut directly, its volume centres moved by the offset of Section 5 / Eq. 14, and
// refined only on the other cells (11 and 14: the offset certifies on parallelepipeds, and no
// offset can on the templates' transition cells).
struct LocalRefinementTemplate {
  bool refine = false;
  std::uint8_t inner_positive = 0;
  bool direct_on_affine = false;
  // Where set: the signs used when the subcase is the cell's own (the first level), while
  // inner_positive serves a child refined at the second level. 3.2 needs it: its level-1 template
  // 0x0F leaves case-5 frustums that no volume-centre search certifies on the edge-3 and face-3
  // transition types, and 0x7F, which certifies there, breaks the second level of 7.2 and 7.4.2
  // (local_refinement.cpp).
  bool own_level = false;
  std::uint8_t own_inner_positive = 0;
  constexpr std::uint8_t signs(int depth) const {
    return depth == 0 && own_level ? own_inner_positive : inner_positive;
  }
};
using LocalRefinementTable = std::array<LocalRefinementTemplate, kNumSubcases>;
const LocalRefinementTable& local_refinement_table();

// True when cut_cell + midpoint_subdivide of this class is not certified for every s (or the
// subcase has a tunnel): such a cell goes through refine_locally. Without a shape: on a general
// cell (the table's `refine`); with one, or the cell's corners, the shape's answer (11 and 14 are
// cut directly on affine cells).
bool needs_local_refinement(const CellClass& c);
bool needs_local_refinement(Subcase s);
bool needs_local_refinement(Subcase s, CellShape shape);
bool needs_local_refinement(const CellClass& c, const std::array<Vec3, 8>& corners);

struct LocalRefinement {
  std::vector<Vec3> points;                         // [0, 8): the cell's corners as given; then the inserted points
  std::vector<double> values;                       // f at every point: the cell's 8 values, then virtual values
  std::vector<std::array<std::uint32_t, 8>> cells;  // leaf children, VTK order, into points
  int levels = 0;                                   // 1 or 2
};

// corners: VTK order; f: the 8 values (already through the zero rule, so none is 0); c:
// classify(f); zero_tolerance > 0: the magnitude a virtual value gets where its sign is forced
// (and the least magnitude of any virtual value). Throws std::invalid_argument if c does not need
// refinement, std::logic_error if a table entry breaks its guarantees (tests rule that out).
// `table` exists for the search and tests; the mesher uses the default.
LocalRefinement refine_locally(const std::array<Vec3, 8>& corners, const std::array<double, 8>& f, const CellClass& c,
                               double zero_tolerance, const LocalRefinementTable& table = local_refinement_table());

// Leaf i of a refinement as a cell of its own: its corners and values, VTK order.
struct LocalRefinementLeaf {
  std::array<Vec3, 8> corners;
  std::array<double, 8> values;
};
inline LocalRefinementLeaf leaf_cell(const LocalRefinement& lr, std::size_t i) {
  LocalRefinementLeaf out;
  for (int c = 0; c < 8; ++c) {
    out.corners[c] = lr.points[lr.cells[i][c]];
    out.values[c] = lr.values[lr.cells[i][c]];
  }
  return out;
}

// The geometry alone (values-independent) of one refinement level: the 7 children of a cell as
// corner arrays, in local_refinement_child_points() order. A second level is this applied to a
// child.
std::vector<std::array<Vec3, 8>> local_refinement_children(const std::array<Vec3, 8>& corners);

// Hexes that midpoint subdivision makes from one cell of subcase s: 8 + 2 * cut edges for a cell
// cut directly, the sum over the leaves for a refined one (a pure function of the subcase and the
// cell's shape, see above). The mesher's count pass uses it.
int local_refinement_hexes(Subcase s);  // on a general cell
int local_refinement_hexes(Subcase s, CellShape shape);
// How many refinement levels subcase s uses (0 when it is cut directly).
int local_refinement_levels(Subcase s);

}  // namespace mchex
