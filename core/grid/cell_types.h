// The cell types of the MCHex positivity proof (Tong & Zhang 2025, Section 5, Theorem 5.2 and
// Figure 8): the cells that the mesher may cut, up to orientation-preserving affine maps. The
// Bernstein certificate of a midpoint-subdivided cell is invariant under such maps (Theorem 5.2),
// so proving every type under the 24 rotations of its corner labels (the octahedral group)
// covers every cell of every grid the octree and its templates make.
//
// The table is derived, never typed: the hexes of the templates (core/grid/templates.h) are taken in
// order (cube, node, edge, face; child cubes first) and each one that is not affinely equivalent,
// under some rotation, to an earlier type becomes a new type.
//
// The paper counts 9 basic cells; this derivation finds 8, and the classification can be checked
// by hand (tests/test_templates.cpp asserts it): cube (the child cubes and the face template's
// centre box, an affine cube); node (its 3 hexes are one cell under the 3-fold rotation about the
// diagonal); edge: 3 (the left and right hexes of a sheet are mirror images, and each has the
// orientation-reversing affine symmetry (x, y, z) -> (x, z - y, z), so they are one type under
// det > 0; the middle one, a prism; the top one); face: 3 (the 4 side hexes, the 4 corner hexes,
// and 4 trapezoidal prisms: the hex over the middle column and the two beside it are prisms along
// x of a trapezoid with parallel sides 1/3 and 1, the top slab the same prism along y). Where the
// ninth of the paper comes from is not established (the paper's Figure 8 is a picture; its
// supplementary notebooks are not public here); it is reported, not hidden.
//
// The paper's further 15 + 1 types come from local refinement of these cells (one and two levels,
// Figure 7). They are not listed here: the inner points sit halfway from each corner to the
// centroid (core/cutting/local_refinement.h), so the inner cell is an affine image of its parent (same
// type) and only the frustums are new; certify reaches every one of them by refining each basic
// type under each rotation, and refine_locally commutes with affine maps (tested), which covers
// every refined cell of every grid.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include "core/grid/templates.h"
#include "core/mesh/quality.h"

namespace mchex {

struct CellType {
  std::string name;          // "cube", "node", "edge-1", ..., "face-4"
  HexCorners corners{};      // representative, in the unit cube (template coordinates / 12)
  TemplateKind source{};     // the template the representative comes from
  int source_hex = 0;        // its index in template_hexes(source)
  int refinement_level = 0;  // 0 for the basic cells; 1, 2 for local refinement (not landed)
};

// The table: basic cells first, in derivation order.
std::span<const CellType> cell_types();
inline constexpr int kPaperBasicCellTypes = 9;  // paper, Section 5 ("the enumerated 9 cells"); see above

// How a template hex relates to the table: corners[i] = A(type.corners moved by `rotation`)[i]
// for an affine A with det > 0.
struct CellTypeMatch {
  int type = -1;
  int rotation = 0;  // kCubeSymmetries index < 24
};
CellTypeMatch template_hex_type(TemplateKind kind, int hex);

// The cell moved by cube symmetry g: out[g.corner[c]] = c's corner (as transform_cell in mc33.h).
HexCorners transform_hex(const HexCorners& c, int symmetry);

// Whether b = A(a) for an affine A with det A > 0 (corner for corner), to a tolerance relative to
// the cells' size.
bool affinely_equivalent(const HexCorners& a, const HexCorners& b, double tolerance = 1e-9);

// The first (type, rotation) whose moved representative is affinely equivalent to `c`.
std::optional<CellTypeMatch> find_cell_type(const HexCorners& c);

// A template hex's corners in the unit cube.
HexCorners template_hex_corners(const TemplateHex& h);

}  // namespace mchex
