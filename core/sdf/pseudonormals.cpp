#include "core/sdf/pseudonormals.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace mchex {

Pseudonormals::Pseudonormals(const TriangleSurface& s) {
  const std::size_t nt = s.triangles.size();
  face.resize(nt);
  vertex.assign(s.vertices.size(), Vec3{});
  for (std::size_t t = 0; t < nt; ++t) {
    const auto& tri = s.triangles[t];
    const Vec3 p[3] = {s.vertices[tri[0]], s.vertices[tri[1]], s.vertices[tri[2]]};
    face[t] = normalized(cross(p[1] - p[0], p[2] - p[0]));
    for (int k = 0; k < 3; ++k) {
      const Vec3 u = p[(k + 1) % 3] - p[k], v = p[(k + 2) % 3] - p[k];
      const double angle = std::atan2(norm(cross(u, v)), dot(u, v));
      vertex[tri[k]] += angle * face[t];
    }
  }
  // Edges by sorting the 3T directed half-edges on their unordered vertex pair.
  std::vector<std::pair<uint64_t, uint32_t>> half(3 * nt);
  for (std::size_t t = 0; t < nt; ++t)
    for (int k = 0; k < 3; ++k) {
      uint64_t u = s.triangles[t][k], v = s.triangles[t][(k + 1) % 3];
      if (u > v) std::swap(u, v);
      half[3 * t + k] = {(u << 32) | v, uint32_t(3 * t + k)};
    }
  std::sort(half.begin(), half.end());
  triangle_edges.resize(nt);
  for (std::size_t i = 0; i < half.size();) {
    std::size_t j = i;
    Vec3 sum{};
    while (j < half.size() && half[j].first == half[i].first) sum += face[half[j++].second / 3];
    for (std::size_t k = i; k < j; ++k) triangle_edges[half[k].second / 3][half[k].second % 3] = uint32_t(edge.size());
    edge.push_back(sum);
    i = j;
  }
}

double pseudonormal_signed_value(Vec3 p, Vec3 closest, double squared_distance, Vec3 pseudonormal) {
  const double d = std::sqrt(squared_distance);
  if (d == 0) return 0;
  return dot(p - closest, pseudonormal) > 0 ? -d : d;
}

}  // namespace mchex
