// The search tree of the reference SDF (core/sdf/sdf.cpp) and of the devices' fp64 search
// (core/device/device_scene.h copies it into flat float4 arrays for kernels/sdf.h): one builder, so the
// CPU and the devices prune with the same bounds.
#pragma once

#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "core/base/geometry.h"
#include "core/mesh/surface.h"
#include "core/sdf/bvh.h"

namespace mchex {

// The search tree of the reference SDF: the topology of the Embree-built TriangleBvh, with each
// node's triangles bounded by a box in a frame of its own, collapsed to four children per node;
// below each leaf, a triangle layer that bounds each of its triangles on its own.
//
// Why oriented boxes: a point far from a smooth surface is at nearly the same distance from a
// whole patch of it (distance grows only quadratically sideways), so a search must rule out
// every node whose bound is below the answer. An axis-aligned box around a tilted, nearly flat
// piece of surface is as thick as the piece is wide, and comes within range a whole patch away;
// a box aligned with the piece's mean normal is thin and comes within range only right under the
// point. Low in the tree nodes are nearly flat pieces; their in-plane axes are the turn of least
// area about the normal (bound_triangles), which on the 52k torus opens 10 % fewer nodes than an
// arbitrary turn. Where the normals of a node's triangles cancel (high in the tree, around
// corners) the node keeps the axis-aligned frame. A triangle's own bound (its plane and edge
// lines, TriangleLeaf below) rules out most of a leaf's triangles before any is measured exactly.
struct OrientedBox {
  float axis[3][3];    // orthonormal frame (to float precision)
  float lo[3], hi[3];  // extents along the axes, rounded outward
};

// Four children's values side by side (GCC/Clang vector extension: one SSE register on x86-64,
// whatever the target has elsewhere), so that one search step measures four boxes at once.
using Four = float __attribute__((vector_size(16)));
using Four32 = int __attribute__((vector_size(16)));  // a comparison of two Fours

inline Four max4(Four a, Four b) { return a > b ? a : b; }

// Four children's oriented boxes side by side (structure of arrays). A child is an inner node
// (count 0, child = its wide node) or a leaf (count = its triangles, child = its TriangleLeaf).
// An absent child has an empty box (lo > hi), which is at infinite distance.
struct alignas(64) WideNode {
  Four axis[3][3];  // [axis][component], one child per lane
  Four lo[3], hi[3];
  uint32_t child[4];
  uint32_t count[4];
  uint32_t leaf_mask;  // bit c: child c is a leaf

  // Lower bounds of the squared distance from p to each child's triangles. `slack` (per query)
  // covers float rounding of the projections and the axes' departure from orthonormality, so a
  // bound never exceeds the true distance.
  Four distance2(const float p[3], float slack) const {
    Four d2 = {};
    for (int a = 0; a < 3; ++a) {
      const Four t = axis[a][0] * p[0] + axis[a][1] * p[1] + axis[a][2] * p[2];
      const Four d = max4(max4(lo[a] - t, t - hi[a]) - slack, Four{});
      d2 += d * d;
    }
    return d2;
  }

  void set(int c, const OrientedBox& b, uint32_t child_index, uint32_t triangles) {
    for (int a = 0; a < 3; ++a) {
      for (int i = 0; i < 3; ++i) axis[a][i][c] = b.axis[a][i];
      lo[a][c] = b.lo[a];
      hi[a][c] = b.hi[a];
    }
    child[c] = child_index;
    count[c] = triangles;
    if (triangles) leaf_mask |= 1u << c;
  }

  static WideNode empty() {
    WideNode w{};
    for (int c = 0; c < 4; ++c)
      for (int a = 0; a < 3; ++a) w.lo[a][c] = INFINITY, w.hi[a][c] = -INFINITY;
    return w;
  }
};

// A leaf's triangles (up to four, one per lane), each bounded by its plane and its three edge
// lines: for x in the triangle, p - x splits into a part along the unit normal n, at least p's
// distance from the plane's interval, and a part in the plane, at least p's distance beyond any
// edge line (m_e, a unit in-plane normal pointing away from the triangle, has m_e.x <= hi_e).
// So |p - x|^2 >= plane^2 + edge^2: exact off the plane's interior and near the edges, much
// tighter than any box, and it rules out nearly every triangle that is not the answer before the
// exact test in double. Degenerate triangles keep a coordinate axis and no edge lines.
struct alignas(64) TriangleLeaf {
  Four normal[3];
  Four plane_lo, plane_hi;
  Four edge[3][3];  // [edge][component]
  Four edge_hi[3];
  uint32_t slot[4];  // leaf slot of each triangle

  Four distance2(const float p[3], float slack) const {
    const Four t = normal[0] * p[0] + normal[1] * p[1] + normal[2] * p[2];
    const Four dp = max4(max4(plane_lo - t, t - plane_hi) - slack, Four{});
    Four de = edge[0][0] * p[0] + edge[0][1] * p[1] + edge[0][2] * p[2] - edge_hi[0];
    for (int e = 1; e < 3; ++e) de = max4(de, edge[e][0] * p[0] + edge[e][1] * p[1] + edge[e][2] * p[2] - edge_hi[e]);
    de = max4(de - slack, Four{});
    return dp * dp + de * de;
  }

  TriangleLeaf(const TriangleSurface& s, std::span<const uint32_t> triangles, uint32_t first_slot);
  TriangleLeaf() = default;  // to be assigned (the tree makes its leaves in parallel)
};

// The search tree: wide nodes collapsed from the binary tree (each node takes its two children
// and keeps opening the inner one holding the most triangles until it has four: half the depth,
// four boxes per step), and the triangle layer, one node per leaf.
//
// Frames::kAxisAligned gives every node the coordinate frame and the hierarchy's own box: the
// answers are the same (the search is exact whatever the boxes), a search may open more nodes, and
// the tree is made in a fraction of the time (no sums, no node's corners gathered and sorted, no
// turns tried), which pays for a surface searched by one batch (the fidelity's mesh boundary, made
// for every mesh it measures).
struct SearchTree {
  enum class Frames { kFitted, kAxisAligned };
  std::vector<WideNode> nodes;
  std::vector<TriangleLeaf> leaves;

  SearchTree(const TriangleSurface& s, const TriangleBvh& bvh, Frames frames = Frames::kFitted);
};

}  // namespace mchex
