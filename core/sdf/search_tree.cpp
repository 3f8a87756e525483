#include "core/sdf/search_tree.h"

#include <algorithm>
#include <array>
#include <numbers>
#include <stdexcept>
#include <utility>

#include "core/base/parallel.h"

namespace mchex {

namespace {

// The box of a group of triangles, from their distinct corners and the sums of their area
// vectors (`normal`) and areas. Frame: the group's mean normal when the group is nearly flat,
// with the in-plane axes of least area (a box is only as tight sideways as its rectangle fits the
// piece), else the coordinate axes.
bool nearly_flat(Vec3 normal, double area) { return norm(normal) > 0.5 * area && area > 0; }

OrientedBox bound_corners(std::span<const Vec3> corners, Vec3 normal, double area) {
  Vec3 a0{0, 0, 1}, a1{1, 0, 0};
  if (nearly_flat(normal, area)) {  // a nearly flat piece: its own frame
    a0 = normalized(normal);
    // The in-plane axes of least area (the thickness along a0 does not depend on them): eight
    // turns over a quarter turn, then eight finer turns around the best of them.
    constexpr int kTurns = 8;
    static const auto turns = [] {
      std::array<std::array<std::pair<double, double>, kTurns>, 2> cs;  // [coarse, fine offsets]
      for (int k = 0; k < kTurns; ++k) {
        const double coarse = (k + 0.5) * (std::numbers::pi / 2) / kTurns,
                     fine = (k - 3.5) * (std::numbers::pi / 2) / (kTurns * kTurns);
        cs[0][k] = {std::cos(coarse), std::sin(coarse)};
        cs[1][k] = {std::cos(fine), std::sin(fine)};
      }
      return cs;
    }();
    const Vec3 u = normalized(cross(a0, std::abs(a0.x) < 0.6 ? Vec3{1, 0, 0} : Vec3{0, 1, 0}));
    const Vec3 w = cross(a0, u);
    std::vector<std::pair<double, double>> flat(corners.size());
    for (std::size_t i = 0; i < corners.size(); ++i) flat[i] = {dot(u, corners[i]), dot(w, corners[i])};
    auto least_area = [&](const std::array<std::pair<double, double>, kTurns>& dirs) {
      double l[kTurns][2], h[kTurns][2];
      for (int k = 0; k < kTurns; ++k) l[k][0] = l[k][1] = INFINITY, h[k][0] = h[k][1] = -INFINITY;
      for (const auto& [x, y] : flat)
        for (int k = 0; k < kTurns; ++k) {
          const double p1 = dirs[k].first * x + dirs[k].second * y, p2 = dirs[k].first * y - dirs[k].second * x;
          l[k][0] = std::min(l[k][0], p1), h[k][0] = std::max(h[k][0], p1);
          l[k][1] = std::min(l[k][1], p2), h[k][1] = std::max(h[k][1], p2);
        }
      int best = 0;
      for (int k = 1; k < kTurns; ++k)
        if ((h[k][0] - l[k][0]) * (h[k][1] - l[k][1]) < (h[best][0] - l[best][0]) * (h[best][1] - l[best][1])) best = k;
      return dirs[best];
    };
    const auto [c0, s0] = least_area(turns[0]);
    std::array<std::pair<double, double>, kTurns> around;
    for (int k = 0; k < kTurns; ++k) {  // the coarse turn plus each fine offset
      const auto [c1, s1] = turns[1][k];
      around[k] = {c0 * c1 - s0 * s1, s0 * c1 + c0 * s1};
    }
    const auto [c, sn] = least_area(around);
    a1 = c * u + sn * w;
  }
  OrientedBox out;
  const Vec3 a2 = cross(a0, a1);
  for (int i = 0; i < 3; ++i)
    out.axis[0][i] = float(a0[i]), out.axis[1][i] = float(a1[i]), out.axis[2][i] = float(a2[i]);
  // Extents along exactly the float axes that distance2() will use, computed in double and
  // rounded outward, so every triangle lies inside its box.
  Vec3 axes[3];
  for (int a = 0; a < 3; ++a) axes[a] = {out.axis[a][0], out.axis[a][1], out.axis[a][2]};
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (const Vec3& c : corners)
    for (int a = 0; a < 3; ++a) {
      const double x = dot(axes[a], c);
      lo[a] = std::min(lo[a], x), hi[a] = std::max(hi[a], x);
    }
  for (int a = 0; a < 3; ++a) {
    out.lo[a] = std::nextafter(float(lo[a]), -INFINITY);
    out.hi[a] = std::nextafter(float(hi[a]), INFINITY);
  }
  return out;
}

}  // namespace

TriangleLeaf::TriangleLeaf(const TriangleSurface& s, std::span<const uint32_t> triangles, uint32_t first_slot) {
  for (int c = 0; c < 4; ++c) {  // absent lanes: an empty plane interval, never in range
    plane_lo[c] = INFINITY, plane_hi[c] = -INFINITY, slot[c] = 0;
    for (int e = 0; e < 3; ++e) {
      edge_hi[e][c] = 0;
      for (int i = 0; i < 3; ++i) edge[e][i][c] = normal[i][c] = 0;
    }
  }
  for (int c = 0; c < int(triangles.size()); ++c) {
    const auto& tri = s.triangles[triangles[c]];
    const Vec3 v[3] = {s.vertices[tri[0]], s.vertices[tri[1]], s.vertices[tri[2]]};
    slot[c] = first_slot + uint32_t(c);
    const Vec3 cr = cross(v[1] - v[0], v[2] - v[0]);
    const bool flat = norm(cr) > 0 && std::isfinite(norm(cr));
    const Vec3 n = flat ? normalized(cr) : Vec3{1, 0, 0};
    // Every interval from the float vectors the query will use, in double, rounded outward.
    auto to_float = [](Vec3 a) { return Vec3{float(a.x), float(a.y), float(a.z)}; };
    const Vec3 nf = to_float(n);
    double lo = INFINITY, hi = -INFINITY;
    for (const Vec3& x : v) lo = std::min(lo, dot(nf, x)), hi = std::max(hi, dot(nf, x));
    for (int i = 0; i < 3; ++i) normal[i][c] = float(nf[i]);
    plane_lo[c] = std::nextafter(float(lo), -INFINITY);
    plane_hi[c] = std::nextafter(float(hi), INFINITY);
    if (!flat) continue;
    for (int e = 0; e < 3; ++e) {
      Vec3 m = normalized(cross(v[(e + 1) % 3] - v[e], n));
      if (dot(m, v[(e + 2) % 3] - v[e]) > 0) m = -1.0 * m;
      const Vec3 mf = to_float(m);
      double top = -INFINITY;
      for (const Vec3& x : v) top = std::max(top, dot(mf, x));
      for (int i = 0; i < 3; ++i) edge[e][i][c] = float(mf[i]);
      edge_hi[e][c] = std::nextafter(float(top), INFINITY);
    }
  }
}

namespace {

struct Lane {
  uint32_t wide, lane, node;  // wide node, its lane, the binary node there
};

// Fitted boxes for the lanes' binary nodes; subtree(n): the triangles under node n.
template <class Subtree>
void fit_boxes(const TriangleSurface& s, const TriangleBvh& bvh, const Subtree& subtree, const std::vector<Lane>& lanes,
               std::vector<OrientedBox>& boxes) {
  const std::span<const uint32_t> all(bvh.leaf_triangles);
  // Each binary node's area-vector and area sums and corner box, bottom up (children follow
  // their parent in the hierarchy's order): what decides a node's frame, and a curved node's
  // whole box, without visiting its triangles again at every level.
  struct Sums {
    Vec3 normal{};
    double area = 0;
    Box box;
  };
  // The leaves' sums (most of the work: every triangle's cross product) in parallel, then the
  // inner nodes' in one pass up.
  std::vector<Sums> sums(bvh.nodes.size());
  parallel_for(bvh.nodes.size(), [&](std::size_t n) {
    const BvhNode& node = bvh.nodes[n];
    if (!node.count) return;
    Sums& out = sums[n];
    for (uint32_t t : all.subspan(node.index, node.count)) {
      const auto& v = s.triangles[t];
      const Vec3 c = cross(s.vertices[v[1]] - s.vertices[v[0]], s.vertices[v[2]] - s.vertices[v[0]]);
      out.normal += c;
      out.area += norm(c);
      for (uint32_t i : v) out.box.extend(s.vertices[i]);
    }
  });
  for (std::size_t n = bvh.nodes.size(); n-- > 0;) {
    const BvhNode& node = bvh.nodes[n];
    if (node.count) continue;  // a leaf: summed above
    Sums& out = sums[n];
    const Sums &l = sums[n + 1], &r = sums[node.index];
    out.normal = l.normal + r.normal;
    out.area = l.area + r.area;
    out.box = l.box;
    out.box.extend(r.box.lo);
    out.box.extend(r.box.hi);
  }

  // The boxes: a nearly flat node gets its own frame from its distinct corners; any other the
  // coordinate axes, whose extents are its corner box.
  parallel_chunks(lanes.size(), 64, [&](std::size_t b, std::size_t e) {
    std::vector<uint32_t> ids;
    std::vector<Vec3> corners;
    for (std::size_t k = b; k < e; ++k) {
      const Lane& l = lanes[k];
      const Sums& sum = sums[l.node];
      ids.clear();
      corners.clear();
      const bool own_frame = nearly_flat(sum.normal, sum.area);
      if (own_frame) {
        for (uint32_t t : subtree(l.node))
          for (uint32_t i : s.triangles[t]) ids.push_back(i);
        std::sort(ids.begin(), ids.end());
        ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
        for (uint32_t i : ids) corners.push_back(s.vertices[i]);
      } else {
        corners = {sum.box.lo, sum.box.hi};
      }
      boxes[k] = own_frame ? bound_corners(corners, sum.normal, sum.area) : bound_corners(corners, {}, 0);
    }
  });
}

}  // namespace

SearchTree::SearchTree(const TriangleSurface& s, const TriangleBvh& bvh, Frames frames) {
  if (bvh.nodes.empty()) return;
  const auto slots = bvh.subtree_slots();
  const std::span<const uint32_t> all(bvh.leaf_triangles);
  auto subtree = [&](uint32_t n) { return all.subspan(slots[n].first, slots[n].second - slots[n].first); };

  // The collapse: each wide node takes its two children and keeps opening the inner one holding
  // the most triangles until it has four. Only the binary nodes that end up as a wide node's
  // children need a box (about half of them), so the topology comes first and the boxes after.
  std::vector<Lane> lanes;
  std::vector<uint32_t> leaf_nodes;  // the binary leaf of each TriangleLeaf
  // Sized up front: growing them would fault in and copy each array several times.
  lanes.reserve(bvh.nodes.size());
  leaf_nodes.reserve(bvh.nodes.size() / 2 + 1);
  nodes.reserve(bvh.nodes.size() / 2 + 1);
  // kids: up to four binary nodes, `size` of them set (a fixed array: a vector per wide node was
  // an allocation per node).
  auto build = [&](auto&& self, std::array<uint32_t, 4> kids, int size) -> uint32_t {
    while (size < 4) {
      int open = -1;
      for (int k = 0; k < size; ++k)
        if (bvh.nodes[kids[k]].count == 0 && (open < 0 || subtree(kids[k]).size() > subtree(kids[open]).size()))
          open = k;
      if (open < 0) break;
      const uint32_t n = kids[open];
      kids[open] = n + 1;
      kids[size++] = bvh.nodes[n].index;
    }
    const uint32_t self_index = uint32_t(nodes.size());
    nodes.push_back(WideNode::empty());
    for (int c = 0; c < size; ++c) {
      const BvhNode& node = bvh.nodes[kids[c]];
      if (node.count > 4) throw std::logic_error("SDF search tree: a leaf holds more than four triangles");
      uint32_t child;
      if (node.count) {
        child = uint32_t(leaf_nodes.size());
        leaf_nodes.push_back(kids[c]);
      } else {
        child = self(self, {kids[c] + 1, node.index, 0, 0}, 2);
      }
      nodes[self_index].child[c] = child;
      nodes[self_index].count[c] = node.count;
      lanes.push_back({self_index, uint32_t(c), kids[c]});
    }
    return self_index;
  };
  if (bvh.nodes[0].count) build(build, {0, 0, 0, 0}, 1);  // a single leaf
  else build(build, {1, bvh.nodes[0].index, 0, 0}, 2);

  // Fitted boxes, or the coordinate frame around the hierarchy's own float bounds, which hold the
  // node's triangles: no sums and no corners to gather, and no array of boxes.
  std::vector<OrientedBox> boxes;
  if (frames == Frames::kFitted) {
    boxes.resize(lanes.size());
    fit_boxes(s, bvh, subtree, lanes, boxes);
  }
  auto axis_aligned = [](const BvhNode& node) {
    const Vec3 corners[2] = {{node.lo[0], node.lo[1], node.lo[2]}, {node.hi[0], node.hi[1], node.hi[2]}};
    return bound_corners(corners, {}, 0);
  };
  // Set on one thread: lanes of one wide node share its vectors and its leaf mask.
  for (std::size_t k = 0; k < lanes.size(); ++k) {
    WideNode& w = nodes[lanes[k].wide];
    const int c = int(lanes[k].lane);
    w.set(c, boxes.empty() ? axis_aligned(bvh.nodes[lanes[k].node]) : boxes[k], w.child[c], w.count[c]);
  }
  leaves.resize(leaf_nodes.size());
  parallel_for(leaf_nodes.size(), [&](std::size_t k) {
    const BvhNode& n = bvh.nodes[leaf_nodes[k]];
    leaves[k] = TriangleLeaf(s, all.subspan(n.index, n.count), n.index);
  });
}

}  // namespace mchex
