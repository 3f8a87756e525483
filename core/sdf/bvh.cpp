#include "core/sdf/bvh.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <embree3/rtcore.h>

namespace mchex {
namespace {

// The builder's temporary tree, allocated in Embree's thread-local arenas.
struct BuildNode {
  bool leaf;
  uint32_t count;
  BuildNode* child[2];
  RTCBounds bounds[2];
  uint32_t triangles[1];  // leaf: `count` entries (allocated past the struct)
};

void* create_node(RTCThreadLocalAllocator alloc, unsigned int, void*) {
  auto* n = static_cast<BuildNode*>(rtcThreadLocalAlloc(alloc, sizeof(BuildNode), 16));
  n->leaf = false;
  n->count = 0;
  n->child[0] = n->child[1] = nullptr;
  return n;
}

void set_children(void* node, void** children, unsigned int count, void*) {
  auto* n = static_cast<BuildNode*>(node);
  for (unsigned i = 0; i < count && i < 2; ++i) n->child[i] = static_cast<BuildNode*>(children[i]);
}

void set_bounds(void* node, const RTCBounds** bounds, unsigned int count, void*) {
  auto* n = static_cast<BuildNode*>(node);
  for (unsigned i = 0; i < count && i < 2; ++i) n->bounds[i] = *bounds[i];
}

void* create_leaf(RTCThreadLocalAllocator alloc, const RTCBuildPrimitive* prims, size_t count, void*) {
  auto* n = static_cast<BuildNode*>(
      rtcThreadLocalAlloc(alloc, sizeof(BuildNode) + sizeof(uint32_t) * (count ? count - 1 : 0), 16));
  n->leaf = true;
  n->count = uint32_t(count);
  for (size_t i = 0; i < count; ++i) n->triangles[i] = prims[i].primID;
  return n;
}

float down(double v) {
  const float f = float(v);
  return double(f) > v ? std::nextafter(f, -INFINITY) : f;
}
float up(double v) {
  const float f = float(v);
  return double(f) < v ? std::nextafter(f, INFINITY) : f;
}

// Primitive p stands for triangles [p * group, (p + 1) * group) (fewer at the end).
void flatten(const BuildNode* n, const float lo[3], const float hi[3], std::size_t group, std::size_t triangles,
             TriangleBvh& out) {
  const uint32_t self = uint32_t(out.nodes.size());
  out.nodes.push_back({{lo[0], lo[1], lo[2]}, 0, {hi[0], hi[1], hi[2]}, 0});
  if (n->leaf) {
    out.nodes[self].index = uint32_t(out.leaf_triangles.size());
    for (uint32_t k = 0; k < n->count; ++k)
      for (std::size_t t = n->triangles[k] * group; t < std::min(triangles, (n->triangles[k] + 1) * group); ++t)
        out.leaf_triangles.push_back(uint32_t(t));
    out.nodes[self].count = uint32_t(out.leaf_triangles.size()) - out.nodes[self].index;
    return;
  }
  for (int c = 0; c < 2; ++c) {
    if (c == 1) out.nodes[self].index = uint32_t(out.nodes.size());
    const RTCBounds& b = n->bounds[c];
    const float clo[3] = {b.lower_x, b.lower_y, b.lower_z}, chi[3] = {b.upper_x, b.upper_y, b.upper_z};
    flatten(n->child[c], clo, chi, group, triangles, out);
  }
}

}  // namespace

std::vector<std::pair<uint32_t, uint32_t>> TriangleBvh::subtree_slots() const {
  std::vector<std::pair<uint32_t, uint32_t>> slots(nodes.size());
  for (std::size_t n = nodes.size(); n-- > 0;) {
    const BvhNode& node = nodes[n];
    slots[n] = node.count ? std::pair{node.index, node.index + node.count}
                          : std::pair{slots[n + 1].first, slots[node.index].second};
  }
  return slots;
}

TriangleBvh TriangleBvh::build(const TriangleSurface& s, BvhBuilder builder) {
  TriangleBvh out;
  if (s.triangles.empty()) return out;
  if (s.triangles.size() >= (1u << 31)) throw std::length_error("too many triangles for the BVH");
  // A primitive is a triangle, or under kMortonFours four consecutive ones (the last group may
  // be shorter): the builder then makes one leaf per primitive.
  const std::size_t group = builder == BvhBuilder::kMortonFours ? 4 : 1;
  std::vector<RTCBuildPrimitive> prims((s.triangles.size() + group - 1) / group);
  float root_lo[3] = {INFINITY, INFINITY, INFINITY}, root_hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (std::size_t g = 0; g < prims.size(); ++g) {
    Box b;
    for (std::size_t t = g * group; t < std::min(s.triangles.size(), (g + 1) * group); ++t)
      for (uint32_t v : s.triangles[t]) b.extend(s.vertices[v]);
    RTCBuildPrimitive& p = prims[g];
    p.lower_x = down(b.lo.x), p.lower_y = down(b.lo.y), p.lower_z = down(b.lo.z);
    p.upper_x = up(b.hi.x), p.upper_y = up(b.hi.y), p.upper_z = up(b.hi.z);
    p.geomID = 0;
    p.primID = uint32_t(g);
    const float lo[3] = {p.lower_x, p.lower_y, p.lower_z}, hi[3] = {p.upper_x, p.upper_y, p.upper_z};
    for (int a = 0; a < 3; ++a) root_lo[a] = std::min(root_lo[a], lo[a]), root_hi[a] = std::max(root_hi[a], hi[a]);
  }
  RTCDevice device = rtcNewDevice(nullptr);
  if (!device) throw std::runtime_error("Embree device could not be created");
  RTCBVH bvh = rtcNewBVH(device);
  RTCBuildArguments args = rtcDefaultBuildArguments();
  args.byteSize = sizeof(args);
  // RTC_BUILD_QUALITY_LOW is Embree's Morton-code builder.
  args.buildQuality = group == 1 ? RTC_BUILD_QUALITY_MEDIUM : RTC_BUILD_QUALITY_LOW;
  args.maxBranchingFactor = 2;
  args.maxDepth = 64;
  args.sahBlockSize = 1;
  args.minLeafSize = 1;
  args.maxLeafSize = group == 1 ? 4 : 1;
  args.traversalCost = 1.0f;
  args.intersectionCost = 1.0f;
  args.bvh = bvh;
  args.primitives = prims.data();
  args.primitiveCount = prims.size();
  args.primitiveArrayCapacity = prims.size();
  args.createNode = create_node;
  args.setNodeChildren = set_children;
  args.setNodeBounds = set_bounds;
  args.createLeaf = create_leaf;
  const auto* root = static_cast<const BuildNode*>(rtcBuildBVH(&args));
  const RTCError err = rtcGetDeviceError(device);
  if (root && err == RTC_ERROR_NONE) {
    out.nodes.reserve(2 * prims.size());
    out.leaf_triangles.reserve(s.triangles.size());
    flatten(root, root_lo, root_hi, group, s.triangles.size(), out);
  }
  rtcReleaseBVH(bvh);
  rtcReleaseDevice(device);
  if (!root || err != RTC_ERROR_NONE) throw std::runtime_error("Embree BVH build failed");
  return out;
}

}  // namespace mchex
