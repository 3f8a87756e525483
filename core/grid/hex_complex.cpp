#include "core/grid/hex_complex.h"

namespace mchex {

HexComplex uniform_complex(const UniformGrid& grid) {
  HexComplex c;
  c.box = grid.box();
  c.points = grid.vertices();
  const uint32_t n = grid.cells_per_axis();
  c.cells.reserve(grid.cell_count());
  for (uint32_t k = 0; k < n; ++k)
    for (uint32_t j = 0; j < n; ++j)
      for (uint32_t i = 0; i < n; ++i) c.cells.push_back(grid.cell_corners(i, j, k));
  c.cell_size.assign(c.cells.size(), grid.cell_size());
  return c;
}

}  // namespace mchex
