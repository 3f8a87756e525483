// The cell stage of the MCHex mesher (internal to core/mchex_mesher.cpp): every grid cell cut
// and subdivided, its hex corners merged by global keys into one point array. Kept apart from
// core/hex_mesh.h (see core/mchex_stats.h).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "core/geometry.h"
#include "core/grid.h"
#include "core/mchex_stats.h"

namespace mchex {

struct MchexCells {
  std::vector<Vec3> points;  // every global point once, in first-use order
  std::vector<std::array<std::uint32_t, 8>> inside, outside;  // VTK order, into points
};

// values already passed through the zero rule; eps already validated.
MchexCells mchex_cut_cells(const UniformGrid& grid, std::span<const double> values, double eps,
                           MchexStats& stats);

}  // namespace mchex
