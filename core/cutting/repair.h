// Midpoint subdivision of one polyhedron of a cell, mapped into the cell, with a run-time
// Bernstein check and a volume-centre search where the check fails.
//
// The mesher and certify build a cell's polyhedra in its parametric unit cube and map every hex
// corner through the cell's trilinear map (paper Section 5, Eq. 7). On a transition cell of the
// 3-refinement templates that map is not affine, and plain midpoint subdivision of MC33 case 5
// and 12.1.1 (and of the case-5-like frustum leaves of the refined subcases 3.2, 4.1.2, 6.2) is
// not positive for every crossing: measured by certify, min scaled Bernstein coefficient down to
// -7e-3 on the node, edge and face types, at crossings near the clamp ends. The paper claims
// positivity there at its 9 points (Section 5, cases 1-11 and 13); our bar is all 27 Bernstein
// coefficients of every hex.
//
// The fix is the paper's own device for its Case 12 (Eq. 14), moved from a table to run time: the
// volume centre of a polyhedron is no point of any other polyhedron or cell (it is corner 6 of
// each of the polyhedron's hexes and of nothing else), so it can move freely without breaking
// conformity. Every hex is checked; only when one is not certified, the centre (in space) is
// moved by a deterministic search (sequential linear programming in a trust region, see
// repair.cpp) that maximizes the least scaled coefficient over the polyhedron's hexes (the
// paper's Eq. 14 loss is the same aim summed over a table of cells). The result is a pure
// function of the polyhedron and the cell, so every thread count and backend gives the same
// mesh; cells whose plain subdivision certifies (all cubes in the measured runs) pay one check.
// certify runs this same function, so what it certifies is what the mesher writes.
#pragma once

#include <vector>

#include "core/cutting/polyhedron.h"
#include "core/cutting/subdivide.h"
#include "core/mesh/quality.h"

namespace mchex {

struct MappedSubdivision {
  std::vector<SubdivisionHex> hexes;   // midpoint_subdivide's hexes, corners mapped into the cell
  bool centre_moved = false;           // the search ran (plain subdivision was not certified)
  bool certified = false;              // every coefficient of every hex > 0 (after the search)
  double min_scaled = 0;               // least min_bernstein_scaled over the hexes
  std::vector<double> hex_min_scaled;  // min_bernstein_scaled of each hex
};

// `parametric`: a polyhedron of cut_cell(kUnitCubeCorners, ...); `cell`: the cell's corners (VTK
// order). Throws what midpoint_subdivide throws.
MappedSubdivision subdivide_in_cell(const Polyhedron& parametric, const HexCorners& cell);

// The same into `out`, whose vectors keep their storage (certify subdivides millions of
// polyhedra).
void subdivide_in_cell(const Polyhedron& parametric, const HexCorners& cell, MappedSubdivision& out);

// True when the cell's midpoint subdivision is certified without computing it: an uncut cell
// (its one polyhedron is the cell) that is a right-handed parallelepiped. Its 8 hexes are then
// the images of the unit cube's octants under the cell's affine map, so det J is the constant
// det(A) / 8 > 0 on each (exactly; the tolerance of cell_shape only perturbs that by 1e-9 of the
// size, far below the margin asked of det(A)). Most cells of a grid are like that; the mesher
// skips the 27-coefficient check for them.
bool uncut_affine_cell_certified(const HexCorners& cell);

}  // namespace mchex
