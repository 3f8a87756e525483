#include "core/ro.h"

#include <limits>
#include <string>

#include "core/error.h"

namespace mchex {

HexMesh compact_mesh(std::span<const Vec3> points, std::span<const Hex> hexes, int32_t region) {
  constexpr uint32_t kUnused = std::numeric_limits<uint32_t>::max();
  std::vector<uint32_t> remap(points.size(), kUnused);
  HexMesh m;
  m.hexes.reserve(hexes.size());
  for (const Hex& h : hexes) {
    Hex out;
    for (int c = 0; c < 8; ++c) {
      uint32_t& r = remap[h[c]];
      if (r == kUnused) {
        r = uint32_t(m.points.size());
        m.points.push_back(points[h[c]]);
      }
      out[c] = r;
    }
    m.hexes.push_back(out);
  }
  m.region.assign(m.hexes.size(), region);
  return m;
}

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
