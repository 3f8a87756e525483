// The RO ("remove outside") baseline of the paper's section 6: a grid cell belongs to the solid
// when the sum of the SDF values at its 8 corners is positive. The solid's mesh is those cells,
// the outside mesh the rest; both are exactly the grid's cells, so they conform by construction.
#pragma once

#include <span>

#include "core/grid/grid.h"
#include "core/grid/hex_complex.h"
#include "core/mesh/hex_mesh.h"

namespace mchex {

// values: the SDF at every grid vertex, in UniformGrid::vertex_index order.
MeshPair mesh_remove_outside(const UniformGrid& grid, std::span<const double> values);
// Any conforming complex (the adaptive grid): values at its points.
MeshPair mesh_remove_outside(const HexComplex& complex, std::span<const double> values);

}  // namespace mchex
