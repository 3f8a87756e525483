// Angle-weighted pseudonormals (Baerentzen & Aanaes 2005) of a triangle surface and the sign rule
// that reads them: the one implementation the reference SDF (core/sdf/sdf.h), the brute-force
// SDF and the device scene (core/device/device_scene.h) share.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/base/geometry.h"
#include "core/mesh/surface.h"

namespace mchex {

// Angle-weighted pseudonormals: one per face, per edge and per vertex. For a closed, consistently
// oriented manifold, the sign of dot(p - q, N) with q the closest point and N the pseudonormal of
// the feature q lies on is the side of p (Baerentzen & Aanaes, IEEE TVCG 2005, Theorem 1).
// Edges are the unordered vertex pairs of the triangles, numbered in sorted (min, max) order.
struct Pseudonormals {
  std::vector<Vec3> face, vertex, edge;
  std::vector<std::array<uint32_t, 3>> triangle_edges;  // edge ids of (ab, bc, ca)

  explicit Pseudonormals(const TriangleSurface& s);

  // The pseudonormal of closest_point_on_triangle's region (0..2 vertex, 3..5 edge, 6 face) of
  // triangle t.
  Vec3 of(uint32_t t, int region, const TriangleSurface& s) const {
    if (region < 3) return vertex[s.triangles[t][region]];
    if (region < 6) return edge[triangle_edges[t][region - 3]];
    return face[t];
  }
};

// Sign of a closest-point answer, in one place for every CPU path (the kernels implement the same
// rule in kernels/sdf.h): a point exactly on the surface gets 0; a point whose offset is
// orthogonal to the pseudonormal (possible only on non-manifold or inconsistent input) is called
// outside.
double pseudonormal_signed_value(Vec3 p, Vec3 closest, double squared_distance, Vec3 pseudonormal);

}  // namespace mchex
