#include "core/device_scene.h"

#include <algorithm>
#include <cmath>
#include <span>
#include <stdexcept>
#include <string>

#include "core/local_refinement.h"
#include "core/mc33.h"
#include "core/parallel.h"

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

namespace {

// A box in its own orthonormal frame (float axes, extents along exactly those axes).
struct OrientedBox {
  float axis[3][3];
  float lo[3], hi[3];
};

Vec3 to_float(Vec3 a) { return {float(a.x), float(a.y), float(a.z)}; }

// The box of a group of triangles. Frame: the group's mean normal when the group is nearly flat
// (the summed area vector at least half the summed area), else the coordinate axes. Extents are
// computed in double along the float axes the kernel projects on and rounded outward, so every
// triangle lies inside its box.
OrientedBox bound_triangles(const TriangleSurface& s, std::span<const uint32_t> triangles) {
  Vec3 normal{};
  double area = 0;
  for (uint32_t t : triangles) {
    const auto& v = s.triangles[t];
    const Vec3 c = cross(s.vertices[v[1]] - s.vertices[v[0]], s.vertices[v[2]] - s.vertices[v[0]]);
    normal += c;
    area += norm(c);
  }
  Vec3 a0{0, 0, 1}, a1{1, 0, 0};
  if (norm(normal) > 0.5 * area && area > 0) {
    a0 = normalized(normal);
    a1 = normalized(cross(a0, std::abs(a0.x) < 0.6 ? Vec3{1, 0, 0} : Vec3{0, 1, 0}));
  }
  const Vec3 axes[3] = {to_float(a0), to_float(a1), to_float(cross(a0, a1))};
  OrientedBox out;
  for (int a = 0; a < 3; ++a) {
    double lo = INFINITY, hi = -INFINITY;
    for (uint32_t t : triangles)
      for (uint32_t v : s.triangles[t]) lo = std::min(lo, dot(axes[a], s.vertices[v])), hi = std::max(hi, dot(axes[a], s.vertices[v]));
    for (int i = 0; i < 3; ++i) out.axis[a][i] = float(axes[a][i]);
    out.lo[a] = std::nextafter(float(lo), -INFINITY);
    out.hi[a] = std::nextafter(float(hi), INFINITY);
  }
  return out;
}

// One leaf's triangles (up to four, lane c = slot first + c) bounded by plane and edge lines, in
// the leaf_bounds layout. For x on the triangle, p - x splits into a part along the unit normal
// n, at least p's distance from the interval of n.x over the triangle, and an in-plane part at
// least p's distance beyond any edge line (m_e: unit, in-plane, pointing away from the triangle,
// m_e.x <= edge_hi[e] on it); so |p - x|^2 >= plane^2 + edge^2. Absent lanes: an empty plane
// interval (never in range); degenerate triangles: a coordinate axis and no edge lines.
void bound_leaf(const TriangleSurface& s, std::span<const uint32_t> triangles, float* out) {
  auto at = [&](int group, int lane) -> float& { return out[4 * group + lane]; };
  for (int c = 0; c < 4; ++c) {
    for (int g = 0; g < kLeafBoundFloats / 4; ++g) at(g, c) = 0;
    at(3, c) = INFINITY, at(4, c) = -INFINITY;
  }
  for (int c = 0; c < int(triangles.size()); ++c) {
    const auto& tri = s.triangles[triangles[c]];
    const Vec3 v[3] = {s.vertices[tri[0]], s.vertices[tri[1]], s.vertices[tri[2]]};
    const Vec3 cr = cross(v[1] - v[0], v[2] - v[0]);
    const bool flat = norm(cr) > 0 && std::isfinite(norm(cr));
    const Vec3 n = to_float(flat ? normalized(cr) : Vec3{1, 0, 0});
    double lo = INFINITY, hi = -INFINITY;
    for (const Vec3& x : v) lo = std::min(lo, dot(n, x)), hi = std::max(hi, dot(n, x));
    for (int i = 0; i < 3; ++i) at(i, c) = float(n[i]);
    at(3, c) = std::nextafter(float(lo), -INFINITY);
    at(4, c) = std::nextafter(float(hi), INFINITY);
    if (!flat) continue;
    for (int e = 0; e < 3; ++e) {
      Vec3 m = normalized(cross(v[(e + 1) % 3] - v[e], normalized(cr)));
      if (dot(m, v[(e + 2) % 3] - v[e]) > 0) m = -1.0 * m;
      const Vec3 mf = to_float(m);
      double top = -INFINITY;
      for (const Vec3& x : v) top = std::max(top, dot(mf, x));
      for (int i = 0; i < 3; ++i) at(5 + 3 * e + i, c) = float(mf[i]);
      at(14 + e, c) = std::nextafter(float(top), INFINITY);
    }
  }
}

// The wide tree (DeviceScene's wide_* and leaf_* arrays) from the binary BVH: each wide node
// takes its binary node's two children and keeps opening the inner one holding the most
// triangles until it has four (half the depth, four boxes per step), as core/sdf.cpp's search
// tree does. Depth first: a node's index is below its children's.
void build_wide_tree(const TriangleSurface& s, const TriangleBvh& bvh, DeviceScene& out) {
  if (bvh.nodes.empty()) return;
  const auto slots = bvh.subtree_slots();
  const std::span<const uint32_t> all(bvh.leaf_triangles);
  auto subtree = [&](uint32_t n) { return all.subspan(slots[n].first, slots[n].second - slots[n].first); };
  std::vector<OrientedBox> boxes(bvh.nodes.size());
  parallel_for(bvh.nodes.size(), [&](std::size_t n) { boxes[n] = bound_triangles(s, subtree(uint32_t(n))); });

  auto leaf = [&](uint32_t n) {
    const BvhNode& node = bvh.nodes[n];
    if (node.count > 4) throw std::logic_error("device SDF tree: a BVH leaf holds more than four triangles");
    const std::size_t l = out.leaf_slot.size();
    out.leaf_slot.push_back(node.index);
    out.leaf_bounds.resize(out.leaf_bounds.size() + kLeafBoundFloats);
    bound_leaf(s, all.subspan(node.index, node.count), &out.leaf_bounds[l * kLeafBoundFloats]);
    return uint32_t(l);
  };
  // Returns the wide node's index and the stack entries a walk below it can need once it is
  // popped: it pushes its k inner children, and while the first of them is searched the other
  // k - 1 wait underneath.
  auto build = [&](auto&& self, std::vector<uint32_t> kids) -> std::pair<uint32_t, uint32_t> {
    while (kids.size() < 4) {
      int open = -1;
      for (int k = 0; k < int(kids.size()); ++k)
        if (bvh.nodes[kids[k]].count == 0 && (open < 0 || subtree(kids[k]).size() > subtree(kids[open]).size())) open = k;
      if (open < 0) break;
      const uint32_t n = kids[open];
      kids[open] = n + 1;
      kids.push_back(bvh.nodes[n].index);
    }
    const uint32_t index = uint32_t(out.wide_links.size() / kWideNodeLinks);
    out.wide_links.resize(out.wide_links.size() + kWideNodeLinks, 0);
    out.wide_boxes.resize(out.wide_boxes.size() + kWideNodeFloats, 0.0f);
    for (int c = 0; c < 4; ++c)
      for (int a = 0; a < 3; ++a)
        out.wide_boxes[std::size_t(index) * kWideNodeFloats + 4 * (9 + a) + c] = INFINITY,
        out.wide_boxes[std::size_t(index) * kWideNodeFloats + 4 * (12 + a) + c] = -INFINITY;
    uint32_t inner = 0, deepest = 0;
    for (int c = 0; c < int(kids.size()); ++c) {
      const BvhNode& node = bvh.nodes[kids[c]];
      uint32_t child = 0;
      if (node.count) {
        child = leaf(kids[c]);
      } else {
        const auto [w, need] = self(self, {kids[c] + 1, node.index});
        child = w, ++inner, deepest = std::max(deepest, need);
      }
      // (re-indexed: out's arrays may have grown under the recursive call)
      float* box = &out.wide_boxes[std::size_t(index) * kWideNodeFloats];
      const OrientedBox& b = boxes[kids[c]];
      for (int a = 0; a < 3; ++a) {
        for (int i = 0; i < 3; ++i) box[4 * (3 * a + i) + c] = b.axis[a][i];
        box[4 * (9 + a) + c] = b.lo[a];
        box[4 * (12 + a) + c] = b.hi[a];
      }
      out.wide_links[std::size_t(index) * kWideNodeLinks + c] = child;
      out.wide_links[std::size_t(index) * kWideNodeLinks + 4 + c] = node.count;
    }
    return {index, inner == 0 ? 0 : std::max(inner, inner - 1 + deepest)};
  };
  const auto [root, need] = bvh.nodes[0].count ? build(build, {0}) : build(build, {1, bvh.nodes[0].index});
  (void)root;
  out.wide_stack = std::max<uint32_t>(1, need);
  if (out.wide_stack > uint32_t(kSdfWideStack))
    throw std::logic_error("device SDF tree: the walk needs " + std::to_string(out.wide_stack) + " stack entries, over " +
                           std::to_string(kSdfWideStack));
}

}  // namespace

DeviceScene DeviceScene::build(const TriangleSurface& s) {
  DeviceScene out;
  const TriangleBvh bvh = TriangleBvh::build(s);
  const Pseudonormals normals(s);
  out.nodes = bvh.nodes;
  out.slot_triangle = bvh.leaf_triangles;
  const std::size_t n = out.slot_triangle.size();
  out.slot_corners.resize(9 * n);
  out.slot_features.resize(6 * n);
  out.face_normals.resize(3 * n);
  for (std::size_t k = 0; k < n; ++k) {
    const uint32_t t = out.slot_triangle[k];
    for (int c = 0; c < 3; ++c) {
      const Vec3 v = s.vertices[s.triangles[t][c]];
      for (int i = 0; i < 3; ++i) out.slot_corners[9 * k + 3 * c + i] = v[i];
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
    double s = 12 * std::ldexp(1.0, -41) * ab2 * ac2 / (std::sqrt(std::min(ab2, ac2)) * cross2) * (1 + std::ldexp(1.0, -40));
    if (!(s < kDegenerate)) s = kDegenerate;
    out.slot_slack[k] = std::nextafter(float(s), INFINITY);
  }
  // Depth-first layout (core/bvh.h): children come after their parent.
  out.node_slack.assign(d.nodes.size(), 0.0f);
  for (std::size_t i = d.nodes.size(); i-- > 0;) {
    const BvhNode& node = d.nodes[i];
    float s = 0;
    if (node.count > 0)
      for (uint32_t k = node.index; k < node.index + node.count; ++k) s = std::max(s, out.slot_slack[k]);
    else
      s = std::max(out.node_slack[i + 1], out.node_slack[node.index]);
    out.node_slack[i] = s;
  }
  return out;
}

std::size_t DeviceScene::bytes() const {
  return nodes.size() * sizeof(BvhNode) + slot_triangle.size() * 4 + slot_features.size() * 4 +
         4 * (wide_boxes.size() + wide_links.size() + leaf_bounds.size() + leaf_slot.size()) +
         8 * (slot_corners.size() + face_normals.size() + edge_normals.size() + vertex_normals.size());
}

std::vector<uint32_t> packed_mc33_configs() {
  std::vector<uint32_t> words(kConfigWords);
  for (int mask = 0; mask < 256; ++mask)
    for (int faces = 0; faces < 64; ++faces) {
      const Mc33Config& c = mc33_config(uint8_t(mask), uint8_t(faces));
      words[mask * 64 + faces] = uint32_t(c.subcase) | uint32_t(c.map[0]) << kConfigMap0Shift |
                                 uint32_t(c.map[1]) << kConfigMap1Shift | uint32_t(c.preferred) << kConfigPreferredShift;
    }
  for (int s = 0; s < kNumSubcases; ++s) {
    const auto& info = kSubcaseInfo[s];
    words.push_back(uint32_t(info.tunnel_partner) | uint32_t(info.tunnel + 1) << kConfigTunnelShift |
                    uint32_t(local_refinement_hexes(Subcase(s))) << kConfigHexesShift);
  }
  return words;
}

}  // namespace mchex
