// A conforming complex of hexahedral cells: the grid the mesher cuts. The uniform grid, the
// adaptive 3-refinement grid after its templates (issue 6) and a locally refined cell (paper
// Section 5, Figure 7) are all one of these, so one mesher serves them all.
//
// Every cell is the trilinear image of the unit cube through its 8 corner points (VTK hexahedron
// order, right-handed). Conforming means: two cells meet in a whole shared face, a whole shared
// edge, a shared point or not at all (no hanging node), so a face of the complex is named by its
// 4 point ids and an edge by its 2.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/base/geometry.h"
#include "core/grid/grid.h"

namespace mchex {

using CellCorners = std::array<std::uint32_t, 8>;

struct HexComplex {
  Box box;                         // the region the cells fill
  std::vector<Vec3> points;        // grid points; the SDF is sampled at each
  std::vector<CellCorners> cells;  // point ids, VTK order
  // Optional, per cell: the edge length of the cube the cell came from (the octree cell size;
  // h for every cell of a uniform grid). Zero tolerances and error measures scale with it.
  std::vector<double> cell_size;
};

// The uniform grid as a complex: points in UniformGrid::vertex_index order, cells in grid order
// (x fastest).
HexComplex uniform_complex(const UniformGrid& grid);

}  // namespace mchex
