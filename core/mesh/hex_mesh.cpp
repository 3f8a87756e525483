#include "core/mesh/hex_mesh.h"

#include <limits>

namespace mchex {

HexMesh compact_mesh(std::span<const Vec3> points, std::span<const Hex> hexes, int32_t region) {
  return compact_mesh(points, std::vector<Hex>(hexes.begin(), hexes.end()), region);
}

HexMesh compact_mesh(std::span<const Vec3> points, std::vector<Hex>&& hexes, int32_t region) {
  constexpr uint32_t kUnused = std::numeric_limits<uint32_t>::max();
  std::vector<uint32_t> remap(points.size(), kUnused);
  uint32_t used = 0;
  for (Hex& h : hexes)
    for (uint32_t& v : h) {
      uint32_t& r = remap[v];
      if (r == kUnused) r = used++;
      v = r;
    }
  HexMesh m;
  // Sized once: grown point by point the array would be faulted in and copied several times.
  m.points.resize(used);
  for (std::size_t v = 0; v < remap.size(); ++v)
    if (remap[v] != kUnused) m.points[remap[v]] = points[v];
  m.hexes = std::move(hexes);
  m.region.assign(m.hexes.size(), region);
  return m;
}

}  // namespace mchex
