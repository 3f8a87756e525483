// An unstructured all-hex mesh: the mesher's output and the checker's input.
// Corner order is VTK_HEXAHEDRON: bottom face 0-1-2-3 counter-clockwise seen from above
// (from +w, w being the direction to the top face), top face 4-5-6-7 above 0-1-2-3. With this
// order a positively oriented hex has a positive Jacobian determinant (paper Eq. 8, whose
// node order is the same).
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "core/base/geometry.h"

namespace mchex {

using Hex = std::array<uint32_t, 8>;

// Region labels written per element (MEDIT reference, VTU/MSH cell data).
enum Region : int32_t { kInside = 1, kOutside = 2 };

struct HexMesh {
  std::vector<Vec3> points;
  std::vector<Hex> hexes;
  std::vector<int32_t> region;  // one per hex

  std::array<Vec3, 8> corners(std::size_t h) const {
    std::array<Vec3, 8> c;
    for (int i = 0; i < 8; ++i) c[i] = points[hexes[h][i]];
    return c;
  }
};

// The two meshes the mesher makes: the solid and the rest of the box, sharing their interface.
struct MeshPair {
  HexMesh inside, outside;
};

// Splits a set of hexes over shared points into a compact mesh of those hexes only (points
// renumbered in first-use order, so the result is deterministic).
HexMesh compact_mesh(std::span<const Vec3> points, std::span<const Hex> hexes, int32_t region);
// The same, renumbering `hexes` in place: the mesher's largest arrays are not copied again.
HexMesh compact_mesh(std::span<const Vec3> points, std::vector<Hex>&& hexes, int32_t region);
// The same over `point_count` points read through point_at(id): points kept in several arrays
// (the mesher's shared points and its chunks' own) need not be gathered into one first.
template <class PointAt>
HexMesh compact_mesh(std::size_t point_count, PointAt&& point_at, std::vector<Hex>&& hexes, int32_t region) {
  constexpr uint32_t kUnused = std::numeric_limits<uint32_t>::max();
  std::vector<uint32_t> remap(point_count, kUnused);
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
    if (remap[v] != kUnused) m.points[remap[v]] = point_at(uint32_t(v));
  m.hexes = std::move(hexes);
  m.region.assign(m.hexes.size(), region);
  return m;
}

}  // namespace mchex
