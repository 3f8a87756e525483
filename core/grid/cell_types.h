// The cell types of the MCHex positivity proof (Tong & Zhang 2025, Section 5, Theorem 5.2 and
// Figure 8): the cells that the mesher may cut, up to orientation-preserving affine maps. The
// Bernstein certificate of a midpoint-subdivided cell is invariant under such maps (Theorem 5.2),
// so proving every type under the 24 rotations of its corner labels (the octahedral group)
// covers every cell of every grid the octree and its templates make.
//
// The table is derived, never typed: the hexes of the templates (core/grid/templates.h) are taken in
// order (template 1 to 15, each template's hexes in table order) and each one that is not affinely
// equivalent, under some rotation, to an earlier type becomes a new type. The standard set had 8
// such types (the MCHex paper counts 9 for it); the vertex-based set has many more, most of them
// not parallelepipeds (its composites press smaller templates into frustums), and
// tests/test_templates.cpp prints and pins the count.
//
// Local refinement (paper Figure 7) makes further types: the inner points sit halfway from each
// corner to the centroid (core/cutting/local_refinement.h), so the inner cell is an affine image of
// its parent (same type) and only the frustums are new; certify reaches every one of them by
// refining each type under each rotation, and refine_locally commutes with affine maps (tested),
// which covers every refined cell of every grid.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include "core/grid/templates.h"
#include "core/mesh/quality.h"

namespace mchex {

struct CellType {
  std::string name;      // "single", "edge-1", ..., "uniform"
  HexCorners corners{};  // representative, in the unit cube (template coordinates / kTemplateUnits)
  int source = 0;        // the template the representative comes from
  int source_hex = 0;    // its index in template_hexes(source)
};

// The table: basic cells first, in derivation order.
std::span<const CellType> cell_types();

// How a template hex relates to the table: corners[i] = A(type.corners moved by `rotation`)[i]
// for an affine A with det > 0.
struct CellTypeMatch {
  int type = -1;
  int rotation = 0;  // kCubeSymmetries index < 24
};
CellTypeMatch template_hex_type(int t, int hex);

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
