#include "core/cutting/ro.h"

#include <string>

#include "core/base/error.h"

namespace mchex {

MeshPair mesh_remove_outside(const UniformGrid& grid, std::span<const double> values) {
  const uint32_t n = grid.cells_per_axis();
  std::vector<Hex> in, out;
  for (uint32_t k = 0; k < n; ++k)
    for (uint32_t j = 0; j < n; ++j)
      for (uint32_t i = 0; i < n; ++i) {
        const Hex c = grid.cell_corners(i, j, k);
        double sum = 0;
        for (uint32_t v : c) sum += values[v];
        (sum > 0 ? in : out).push_back(c);
      }
  const std::vector<Vec3> points = grid.vertices();
  return {compact_mesh(points, in, kInside), compact_mesh(points, out, kOutside)};
}

MeshPair mesh_remove_outside(const HexComplex& complex, std::span<const double> values) {
  if (values.size() != complex.points.size())
    throw InputError("mesh_remove_outside: " + std::to_string(values.size()) + " values for " +
                     std::to_string(complex.points.size()) + " grid points");
  std::vector<Hex> in, out;
  for (const CellCorners& c : complex.cells) {
    double sum = 0;
    for (uint32_t v : c) sum += values[v];
    (sum > 0 ? in : out).push_back(c);
  }
  return {compact_mesh(complex.points, in, kInside), compact_mesh(complex.points, out, kOutside)};
}

}  // namespace mchex
