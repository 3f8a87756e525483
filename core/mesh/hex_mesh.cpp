#include "core/mesh/hex_mesh.h"

#include <limits>

namespace mchex {

HexMesh compact_mesh(std::span<const Vec3> points, std::span<const Hex> hexes, int32_t region) {
  return compact_mesh(points, std::vector<Hex>(hexes.begin(), hexes.end()), region);
}

HexMesh compact_mesh(std::span<const Vec3> points, std::vector<Hex>&& hexes, int32_t region) {
  return compact_mesh(
      points.size(), [points](uint32_t v) { return points[v]; }, std::move(hexes), region);
}

}  // namespace mchex
