// A flattened bounding volume hierarchy over triangles, built by Embree's BVH builder
// (rtcBuildBVH, SAH) into our own node layout: flat arrays, no pointers, so the same buffers
// serve the CPU reference and, later, the OpenCL and Vulkan kernels.
//
// Layout: nodes in depth-first order; an inner node's left child is the next node and its right
// child is node.index; a leaf holds triangles leaf_triangles[index .. index + count). Bounds are
// floats rounded outward from the double triangles, so distance culling against them is
// conservative while every triangle is measured in double.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "core/mesh/surface.h"

namespace mchex {

struct BvhNode {
  float lo[3];
  uint32_t index;  // inner: right child; leaf: first slot in leaf_triangles
  float hi[3];
  uint32_t count;  // 0 for an inner node
};
static_assert(sizeof(BvhNode) == 32, "BvhNode is shared with device code: keep it 32 bytes");

struct TriangleBvh {
  std::vector<BvhNode> nodes;
  std::vector<uint32_t> leaf_triangles;

  // Empty surfaces give an empty hierarchy.
  static TriangleBvh build(const TriangleSurface& surface);

  // For every node, the range [first, last) of leaf slots under it: one contiguous range, since
  // the layout is depth-first.
  std::vector<std::pair<uint32_t, uint32_t>> subtree_slots() const;
};

}  // namespace mchex
