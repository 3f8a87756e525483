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

// Which of Embree's builders makes the hierarchy. kSah: the surface-area heuristic at medium
// quality, leaves of 1 to 4 triangles (the fewest nodes opened by the many searches of an input's
// SDF, on the CPU and on the devices). kMortonFours: groups of four consecutive triangles (the
// last may be shorter), a leaf each, sorted by the Morton codes of their centres and split there:
// for a quad surface split around its quads' centres, whose four triangles are a natural leaf
// (the fidelity's mesh boundary, searched by one batch of nearby points: search_tree.h
// Frames::kAxisAligned). On the npm bunny's 254k-triangle boundary 63.5k leaves against the SAH
// builder's 114.8k, built in 0.012 against 0.145 s (2 threads), searched as fast. (Embree's
// Morton builder over single triangles makes a leaf of each, 254k, unless given a least leaf size;
// with 4 it filled them to 2.7.) Searches are exact over any hierarchy.
enum class BvhBuilder { kSah, kMortonFours };

struct TriangleBvh {
  std::vector<BvhNode> nodes;
  std::vector<uint32_t> leaf_triangles;

  // Empty surfaces give an empty hierarchy.
  static TriangleBvh build(const TriangleSurface& surface, BvhBuilder builder = BvhBuilder::kSah);

  // For every node, the range [first, last) of leaf slots under it: one contiguous range, since
  // the layout is depth-first.
  std::vector<std::pair<uint32_t, uint32_t>> subtree_slots() const;
};

}  // namespace mchex
