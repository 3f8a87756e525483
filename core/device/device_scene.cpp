#include "core/device/device_scene.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <span>
#include <stdexcept>
#include <string>

#include "core/base/parallel.h"
#include "core/sdf/search_tree.h"

namespace mchex {

namespace {

// The wide tree (DeviceScene's wide_* and leaf_* arrays): core/sdf/search_tree.h's, the reference
// search's own, copied into flat arrays. WideNode's and TriangleLeaf's boxes and bounds are
// structures of float4 arrays in exactly the groups kernels/sdf.h reads (static_asserts below).
static_assert(sizeof(WideNode::axis) + sizeof(WideNode::lo) + sizeof(WideNode::hi) == kWideNodeFloats * sizeof(float));
static_assert(offsetof(WideNode, axis) == 0 && offsetof(WideNode, lo) == 36 * sizeof(float) &&
              offsetof(WideNode, hi) == 48 * sizeof(float));
static_assert(offsetof(TriangleLeaf, normal) == 0 && offsetof(TriangleLeaf, slot) == kLeafBoundFloats * sizeof(float));
static_assert(offsetof(TriangleLeaf, plane_lo) == 12 * sizeof(float) &&
              offsetof(TriangleLeaf, edge) == 20 * sizeof(float) &&
              offsetof(TriangleLeaf, edge_hi) == 56 * sizeof(float));

void build_wide_tree(const TriangleSurface& s, const TriangleBvh& bvh, DeviceScene& out) {
  if (bvh.nodes.empty()) return;
  const SearchTree tree(s, bvh);
  out.wide_boxes.resize(tree.nodes.size() * kWideNodeFloats);
  out.wide_links.resize(tree.nodes.size() * kWideNodeLinks);
  for (std::size_t n = 0; n < tree.nodes.size(); ++n) {
    const WideNode& w = tree.nodes[n];
    std::memcpy(&out.wide_boxes[n * kWideNodeFloats], &w.axis, kWideNodeFloats * sizeof(float));
    for (int c = 0; c < 4; ++c) {
      out.wide_links[n * kWideNodeLinks + c] = w.child[c];
      out.wide_links[n * kWideNodeLinks + 4 + c] = w.count[c];
    }
  }
  out.leaf_bounds.resize(tree.leaves.size() * kLeafBoundFloats);
  out.leaf_slot.resize(tree.leaves.size());
  for (std::size_t l = 0; l < tree.leaves.size(); ++l) {
    std::memcpy(&out.leaf_bounds[l * kLeafBoundFloats], &tree.leaves[l].normal, kLeafBoundFloats * sizeof(float));
    out.leaf_slot[l] = tree.leaves[l].slot[0];  // a leaf's triangles are consecutive slots
  }
  // The stack entries a walk below node n can need once n is popped: it pushes its k inner
  // children, and while the first of them is searched the other k - 1 wait underneath. Children
  // come after their parent (depth first), so one backward pass has every child's need ready.
  std::vector<uint32_t> need(tree.nodes.size(), 0);
  for (std::size_t n = tree.nodes.size(); n-- > 0;) {
    uint32_t inner = 0, deepest = 0;
    for (int c = 0; c < 4; ++c)
      if (tree.nodes[n].count[c] == 0 && tree.nodes[n].lo[0][c] <= tree.nodes[n].hi[0][c])
        ++inner, deepest = std::max(deepest, need[tree.nodes[n].child[c]]);
    need[n] = inner == 0 ? 0 : std::max(inner, inner - 1 + deepest);
  }
  out.wide_stack = std::max<uint32_t>(1, need[0]);
  if (out.wide_stack > uint32_t(kSdfWideStack))
    throw std::logic_error("device SDF tree: the walk needs " + std::to_string(out.wide_stack) +
                           " stack entries, over " + std::to_string(kSdfWideStack));
}

}  // namespace

DeviceScene DeviceScene::build(const TriangleSurface& s, Search search) {
  DeviceScene out;
  const TriangleBvh bvh = TriangleBvh::build(s);
  out.nodes = bvh.nodes;
  out.slot_triangle = bvh.leaf_triangles;
  const std::size_t n = out.slot_triangle.size();
  out.slot_corners.resize(9 * n);
  for (std::size_t k = 0; k < n; ++k)
    for (int c = 0; c < 3; ++c)
      for (int i = 0; i < 3; ++i)
        out.slot_corners[9 * k + 3 * c + i] = s.vertices[s.triangles[out.slot_triangle[k]][c]][i];
  if (search == Search::kFp64) {
    const Pseudonormals normals(s);
    out.slot_features.resize(6 * n);
    out.face_normals.resize(3 * n);
    for (std::size_t k = 0; k < n; ++k) {
      const uint32_t t = out.slot_triangle[k];
      for (int c = 0; c < 3; ++c) {
        out.slot_features[6 * k + c] = s.triangles[t][c];
        out.slot_features[6 * k + 3 + c] = normals.triangle_edges[t][c];
        out.face_normals[3 * k + c] = normals.face[t][c];
      }
    }
    out.edge_normals.resize(3 * normals.edge.size());
    for (std::size_t e = 0; e < normals.edge.size(); ++e)
      for (int i = 0; i < 3; ++i) out.edge_normals[3 * e + i] = normals.edge[e][i];
    out.vertex_normals.resize(3 * normals.vertex.size());
    for (std::size_t v = 0; v < normals.vertex.size(); ++v)
      for (int i = 0; i < 3; ++i) out.vertex_normals[3 * v + i] = normals.vertex[v][i];
    build_wide_tree(s, bvh, out);
  }
  const Box box = s.bounds();
  if (!s.triangles.empty())
    out.scale = std::max({std::abs(box.lo.x), std::abs(box.lo.y), std::abs(box.lo.z), std::abs(box.hi.x),
                          std::abs(box.hi.y), std::abs(box.hi.z)});
  return out;
}

DeviceScene32 DeviceScene32::build(const DeviceScene& d) {
  DeviceScene32 out;
  const std::size_t n = d.slots();
  out.slot_corners.resize(9 * n);
  for (std::size_t i = 0; i < 9 * n; ++i) out.slot_corners[i] = float(d.slot_corners[i]);
  out.slot_slack.resize(n);
  constexpr double kDegenerate = 1e30;
  for (std::size_t k = 0; k < n; ++k) {
    const double* c = &d.slot_corners[9 * k];
    const Vec3 a{c[0], c[1], c[2]}, b{c[3], c[4], c[5]}, cc{c[6], c[7], c[8]};
    const Vec3 ab = b - a, ac = cc - a;
    const double ab2 = dot(ab, ab), ac2 = dot(ac, ac), cross2 = squared_norm(cross(ab, ac));
    // 1 + 2^-40 covers this double evaluation's own rounding.
    double s =
        12 * std::ldexp(1.0, -41) * ab2 * ac2 / (std::sqrt(std::min(ab2, ac2)) * cross2) * (1 + std::ldexp(1.0, -40));
    if (!(s < kDegenerate)) s = kDegenerate;
    out.slot_slack[k] = std::nextafter(float(s), INFINITY);
  }
  // Depth-first layout (core/sdf/bvh.h): children come after their parent.
  out.node_slack.assign(d.nodes.size(), 0.0f);
  for (std::size_t i = d.nodes.size(); i-- > 0;) {
    const BvhNode& node = d.nodes[i];
    float s = 0;
    if (node.count > 0)
      for (uint32_t k = node.index; k < node.index + node.count; ++k) s = std::max(s, out.slot_slack[k]);
    else s = std::max(out.node_slack[i + 1], out.node_slack[node.index]);
    out.node_slack[i] = s;
  }
  return out;
}

std::size_t DeviceScene::bytes() const {
  return nodes.size() * sizeof(BvhNode) + slot_triangle.size() * 4 + slot_features.size() * 4 +
         4 * (wide_boxes.size() + wide_links.size() + leaf_bounds.size() + leaf_slot.size()) +
         8 * (slot_corners.size() + face_normals.size() + edge_normals.size() + vertex_normals.size());
}

}  // namespace mchex
