#include "core/mesh/hex_mesh.h"

#include <limits>

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

}  // namespace mchex
