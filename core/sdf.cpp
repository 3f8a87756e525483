#include "core/sdf.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <stdexcept>
#include <string>

#include <tbb/parallel_sort.h>
#if defined(__SSE__)
#include <xmmintrin.h>
#endif

#include "core/bvh.h"
#include "core/device_scene.h"
#include "core/parallel.h"

namespace mchex {

namespace {

// The body of closest_point_on_triangle, inlined into the search's inner loop (the call cost 3 %
// of the search).
[[gnu::always_inline]] inline ClosestPoint closest_point_inline(Vec3 p, Vec3 a, Vec3 b, Vec3 c) {
  // Voronoi-region walk over the triangle's features (Ericson, Real-Time Collision Detection,
  // 5.1.5): the region is what decides which pseudonormal gives the sign.
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return {a, squared_norm(ap), 0};
  const Vec3 bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return {b, squared_norm(bp), 1};
  const Vec3 cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return {c, squared_norm(cp), 2};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const Vec3 q = a + (d1 / (d1 - d3)) * ab;
    return {q, squared_norm(p - q), 3};
  }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const Vec3 q = a + (d2 / (d2 - d6)) * ac;
    return {q, squared_norm(p - q), 5};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
    const Vec3 q = b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
    return {q, squared_norm(p - q), 4};
  }
  const double sum = va + vb + vc;
  if (sum > 0 && std::isfinite(sum)) {
    const Vec3 q = a + (vb / sum) * ab + (vc / sum) * ac;
    return {q, squared_norm(p - q), 6};
  }
  // Zero-area triangle that slipped past every edge test through rounding: the nearest of its
  // three edges is its closest point.
  ClosestPoint best{a, squared_norm(ap), 0};
  const Vec3 ends[3][2] = {{a, b}, {b, c}, {c, a}};
  for (int e = 0; e < 3; ++e) {
    const Vec3 u = ends[e][0], v = ends[e][1], uv = v - u;
    const double len2 = squared_norm(uv);
    const double t = len2 > 0 ? std::clamp(dot(p - u, uv) / len2, 0.0, 1.0) : 0.0;
    const Vec3 q = u + t * uv;
    const double d = squared_norm(p - q);
    if (d < best.squared_distance) best = {q, d, 3 + e};
  }
  return best;
}

}  // namespace

ClosestPoint closest_point_on_triangle(Vec3 p, Vec3 a, Vec3 b, Vec3 c) { return closest_point_inline(p, a, b, c); }

namespace {

// The sign rule (core/device_scene.h) applied to a closest-point answer.
double signed_value(Vec3 p, const ClosestPoint& cp, Vec3 pseudonormal) {
  return pseudonormal_signed_value(p, cp.point, cp.squared_distance, pseudonormal);
}

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

// Points searched together: a 4x4x2 brick of a grid in Morton order. A step of the walk costs a
// fixed part (the node's loads, ordering its children, pushing them) and a part per point in
// range; 32 points share the fixed part 9 % better than 8 on the 52k torus, while the points that
// drop out of a subtree cost only a bit of a mask each.
constexpr int kPacket = 32;
static_assert(kPacket % 4 == 0 && kPacket <= 32, "lane masks are 32-bit, points go four to a vector");

// Four children's values side by side (GCC/Clang vector extension: one SSE register on x86-64,
// whatever the target has elsewhere), so that one search step measures four boxes at once.
using Four = float __attribute__((vector_size(16)));
using Four32 = int __attribute__((vector_size(16)));  // a comparison of two Fours

inline Four max4(Four a, Four b) { return a > b ? a : b; }

// The lanes of a comparison as four bits (lane i -> bit i): one instruction on SSE (the portable
// form made the whole search 6 % slower).
inline unsigned mask_of(Four32 m) {
#if defined(__SSE__)
  return unsigned(_mm_movemask_ps(reinterpret_cast<__m128>(m)));
#else
  return (m[0] & 1) | (m[1] & 2) | (m[2] & 4) | (m[3] & 8);
#endif
}

constexpr int kBitCount[16] = {0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4};

// Four rows of four side by side -> out[c][k] = {rows[0][c], .., rows[3][c]}: a 4x4 transpose,
// from (point, child) to (child, point).
inline void transpose(const Four* rows, Four (*out)[kPacket / 4], int k) {
  const Four t0 = __builtin_shufflevector(rows[0], rows[1], 0, 4, 1, 5);
  const Four t1 = __builtin_shufflevector(rows[0], rows[1], 2, 6, 3, 7);
  const Four t2 = __builtin_shufflevector(rows[2], rows[3], 0, 4, 1, 5);
  const Four t3 = __builtin_shufflevector(rows[2], rows[3], 2, 6, 3, 7);
  out[0][k] = __builtin_shufflevector(t0, t2, 0, 1, 4, 5);
  out[1][k] = __builtin_shufflevector(t0, t2, 2, 3, 6, 7);
  out[2][k] = __builtin_shufflevector(t1, t3, 0, 1, 4, 5);
  out[3][k] = __builtin_shufflevector(t1, t3, 2, 3, 6, 7);
}

// A float above x >= 0 (nextafter(float(x), inf), without libm's call): a point's bound in float
// that never prunes a node at the bound itself.
inline float round_up(double x) {
  const float f = float(x);
  return f < INFINITY ? std::bit_cast<float>(std::bit_cast<uint32_t>(f) + 1) : f;
}

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

// The box of a group of triangles. Frame: the group's mean normal when the group is nearly flat,
// with the in-plane axes of least area (a box is only as tight sideways as its rectangle fits the
// piece), else the coordinate axes. `seen` (one entry per surface vertex, never equal to `stamp`
// on entry) lets each vertex be visited once (a closed mesh's vertex is in about six triangles).
OrientedBox bound_triangles(const TriangleSurface& s, std::span<const uint32_t> triangles, std::vector<uint32_t>& seen,
                            uint32_t stamp) {
  Vec3 normal{};
  double area = 0;
  std::vector<Vec3> corners;
  corners.reserve(triangles.size() + 2);
  for (uint32_t t : triangles) {
    const auto& v = s.triangles[t];
    const Vec3 c = cross(s.vertices[v[1]] - s.vertices[v[0]], s.vertices[v[2]] - s.vertices[v[0]]);
    normal += c;
    area += norm(c);
    for (uint32_t i : v)
      if (seen[i] != stamp) seen[i] = stamp, corners.push_back(s.vertices[i]);
  }
  Vec3 a0{0, 0, 1}, a1{1, 0, 0};
  if (norm(normal) > 0.5 * area && area > 0) {  // a nearly flat piece: its own frame
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
  for (int i = 0; i < 3; ++i) out.axis[0][i] = float(a0[i]), out.axis[1][i] = float(a1[i]), out.axis[2][i] = float(a2[i]);
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

  TriangleLeaf(const TriangleSurface& s, std::span<const uint32_t> triangles, uint32_t first_slot) {
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
};

// The search tree: wide nodes collapsed from the binary tree (each node takes its two children
// and keeps opening the inner one holding the most triangles until it has four: half the depth,
// four boxes per step), and the triangle layer, one node per leaf.
struct SearchTree {
  std::vector<WideNode> nodes;
  std::vector<TriangleLeaf> leaves;

  SearchTree(const TriangleSurface& s, const TriangleBvh& bvh) {
    if (bvh.nodes.empty()) return;
    const auto slots = bvh.subtree_slots();
    const std::span<const uint32_t> all(bvh.leaf_triangles);
    auto subtree = [&](uint32_t n) { return all.subspan(slots[n].first, slots[n].second - slots[n].first); };
    std::vector<OrientedBox> boxes(bvh.nodes.size());
    parallel_chunks(bvh.nodes.size(), 1024, [&](std::size_t b, std::size_t e) {
      std::vector<uint32_t> seen(s.vertices.size(), UINT32_MAX);
      for (std::size_t n = b; n < e; ++n) boxes[n] = bound_triangles(s, subtree(uint32_t(n)), seen, uint32_t(n));
    });

    auto leaf = [&](uint32_t n) {
      const BvhNode& node = bvh.nodes[n];
      if (node.count > 4) throw std::logic_error("SDF search tree: a leaf holds more than four triangles");
      leaves.emplace_back(s, all.subspan(node.index, node.count), node.index);
      return uint32_t(leaves.size() - 1);
    };
    auto build = [&](auto&& self, std::vector<uint32_t> kids) -> uint32_t {
      while (kids.size() < 4) {
        int open = -1;
        for (int k = 0; k < int(kids.size()); ++k)
          if (bvh.nodes[kids[k]].count == 0 && (open < 0 || subtree(kids[k]).size() > subtree(kids[open]).size())) open = k;
        if (open < 0) break;
        const uint32_t n = kids[open];
        kids[open] = n + 1;
        kids.push_back(bvh.nodes[n].index);
      }
      const uint32_t self_index = uint32_t(nodes.size());
      nodes.emplace_back();
      WideNode w = WideNode::empty();
      for (int c = 0; c < int(kids.size()); ++c) {
        const BvhNode& node = bvh.nodes[kids[c]];
        w.set(c, boxes[kids[c]], node.count ? leaf(kids[c]) : self(self, {kids[c] + 1, node.index}), node.count);
      }
      nodes[self_index] = w;
      return self_index;
    };
    if (bvh.nodes[0].count) build(build, {0});  // a single leaf
    else build(build, {1, bvh.nodes[0].index});
  }
};

}  // namespace

struct SurfaceSdf::Impl {
  TriangleSurface surface;
  Pseudonormals normals;
  TriangleBvh bvh;
  SearchTree tree;
  std::vector<std::array<Vec3, 3>> leaf_corners;  // corners of each leaf slot's triangle, for locality
  Box box;
  double scale = 0;  // largest coordinate magnitude of the surface

  explicit Impl(const TriangleSurface& s)
      : surface(s), normals(s), bvh(TriangleBvh::build(s)), tree(s, bvh), box(s.bounds()) {
    if (bvh.leaf_triangles.size() >= (1u << 29)) throw std::length_error("too many triangles for the SDF search tree");
    scale = std::max({std::abs(box.lo.x), std::abs(box.lo.y), std::abs(box.lo.z), std::abs(box.hi.x),
                      std::abs(box.hi.y), std::abs(box.hi.z)});
    leaf_corners.resize(bvh.leaf_triangles.size());
    for (std::size_t k = 0; k < leaf_corners.size(); ++k)
      for (int c = 0; c < 3; ++c) leaf_corners[k][c] = s.vertices[s.triangles[bvh.leaf_triangles[k]][c]];
  }

  struct Query {
    ClosestPoint best;
    uint32_t best_triangle;
  };

  // Nearest triangles to a packet of up to kPacket points (neighbours in Morton order), searched
  // together: one nearest-first walk of the tree opens a node when it is in range of any of the
  // points, a point stops measuring where its own bound rules a node out, and each point measures
  // exactly only the triangles whose TriangleLeaf bound is in its range. Neighbouring points need
  // nearly the same nodes, so the walk's loads and branches are shared by the packet, and each
  // node's four child distances are one vector. Which points are still in range (of a node, a
  // child, a triangle) are bit masks, walked by their set bits: a step costs nothing for the
  // points that have left its subtree, and no branch guesses which points remain.
  //
  // Each point starts from a candidate triangle (the answer of a point nearby: far from the
  // surface it is usually the answer here too, so the search starts with a near-exact bound and
  // mostly has to prove it). Ties go to the lower triangle index, so the answer does not depend
  // on the candidate, the packet, the tree's shape or the traversal order; every triangle that
  // ties with the answer (all those around a nearest vertex) is measured, since no bound in
  // float can tell an exact tie from a near miss.
  void closest(const Vec3* p, int n, const uint32_t* candidate, Query* q) const {
    float pf[kPacket][3], slack[kPacket];
    Four best2v[kPacket / 4];
    float* best2 = reinterpret_cast<float*>(best2v);
    for (int l = 0; l < kPacket; ++l) {
      const Vec3 x = p[std::min(l, n - 1)];
      for (int a = 0; a < 3; ++a) pf[l][a] = float(x[a]);
      // Float projections err by a few ulps of |p| + |extent| (and the axes by ~1e-7 from unit
      // length and right angles): 1e-6 of that magnitude is a safe margin.
      slack[l] = float(1e-6 * (3 * std::max({std::abs(x.x), std::abs(x.y), std::abs(x.z)}) + 2 * scale));
      best2[l] = -1;  // lanes past n never open anything
      if (l >= n) continue;
      const auto& c = surface.triangles[candidate[l]];
      q[l] = {closest_point_on_triangle(x, surface.vertices[c[0]], surface.vertices[c[1]], surface.vertices[c[2]]),
              candidate[l]};
      // Rounded up, so that float comparisons against it never prune a node at the bound.
      best2[l] = round_up(q[l].best.squared_distance);
    }
    struct Entry {
      Four d2[kPacket / 4];
      uint32_t node;
    };
    // Each step pops one entry and writes four (keeping the live ones); the tree is at most 64
    // deep.
    Entry stack[4 * 64];
    int top = 0;
    stack[top++] = {{}, 0};
    const Four far = {INFINITY, INFINITY, INFINITY, INFINITY};
    while (top > 0) {
      const Entry& e = stack[--top];  // read before this step's pushes overwrite its slot
      unsigned active = 0;  // the points this node is (still) in range of
      for (int k = 0; k < kPacket / 4; ++k) active |= mask_of(e.d2[k] <= best2v[k]) << (4 * k);
      if (!active) continue;
      const WideNode& w = tree.nodes[e.node];
      Four d2[kPacket];  // [point], one child per lane
      Four key = far;    // a child's distance from the nearest point it is in range of
      for (int l = 0; l < kPacket; ++l) d2[l] = far;
      for (unsigned bits = active; bits; bits &= bits - 1) {
        const int l = __builtin_ctz(bits);
        d2[l] = w.distance2(pf[l], slack[l]);
        key = d2[l] <= best2[l] && d2[l] < key ? d2[l] : key;
      }
      // Children nearest first, ranked without branches (ties by child index: the rank of c is
      // the number of children before it): leaves are searched at once (shrinking the bounds),
      // inner children pushed farthest first so that the nearest is popped next.
      const unsigned live = mask_of(key < far);
      if (!live) continue;
      int order[4];
      for (int c = 0; c < 4; ++c) {
        const Four kc = {key[c], key[c], key[c], key[c]};
        order[kBitCount[mask_of(key < kc) | (mask_of(key == kc) & ((1u << c) - 1))]] = c;
      }
      // Per child: its distances from the packet's points (the transpose of d2), and the points
      // it is in range of.
      Four by_child[4][kPacket / 4];
      unsigned lanes[4] = {0, 0, 0, 0};
      for (int k = 0; k < kPacket / 4; ++k) {
        transpose(d2 + 4 * k, by_child, k);
        for (int c = 0; c < 4; ++c) lanes[c] |= mask_of(by_child[c][k] <= best2v[k]) << (4 * k);
      }
      // Leaf children in rank order, gathered without branches.
      int leaf_order[4], leaves_live = 0;
      for (int i = 0; i < 4; ++i) {
        leaf_order[leaves_live] = order[i];
        leaves_live += (live & w.leaf_mask) >> order[i] & 1;
      }
      for (int i = 0; i < leaves_live; ++i) {
        const int c = leaf_order[i];
        const TriangleLeaf& leaf = tree.leaves[w.child[c]];
        for (unsigned bits = lanes[c]; bits; bits &= bits - 1) {
          const int l = __builtin_ctz(bits);
          if (d2[l][c] > best2[l]) continue;
          const Four t2 = leaf.distance2(pf[l], slack[l]);
          for (unsigned tb = mask_of(t2 <= best2[l]) & ((1u << w.count[c]) - 1); tb; tb &= tb - 1) {
            const int t = __builtin_ctz(tb);
            if (t2[t] > best2[l]) continue;
            const uint32_t slot = leaf.slot[t];
            const auto& v = leaf_corners[slot];
            const ClosestPoint cp = closest_point_inline(p[l], v[0], v[1], v[2]);
            const uint32_t id = bvh.leaf_triangles[slot];
            if (cp.squared_distance < q[l].best.squared_distance ||
                (cp.squared_distance == q[l].best.squared_distance && id < q[l].best_triangle)) {
              q[l] = {cp, id};
              best2[l] = round_up(cp.squared_distance);
            }
          }
        }
      }
      // Inner children pushed farthest first, each written and kept only if live (no branch).
      const unsigned live_inner = live & ~w.leaf_mask;
      for (int i = 3; i >= 0; --i) {
        const int c = order[i];
        Entry& child = stack[top];
        for (int k = 0; k < kPacket / 4; ++k) child.d2[k] = by_child[c][k];
        child.node = w.child[c];
        top += live_inner >> c & 1;
      }
    }
  }

  template <class Out>
  void run(std::span<const Vec3> points, std::span<double> values, Out out) const {
    if (points.size() != values.size()) throw std::invalid_argument("SDF batch size mismatch");
    if (surface.triangles.empty()) {
      std::fill(values.begin(), values.end(), -std::numeric_limits<double>::infinity());
      return;
    }
    // The points are searched in Morton order whatever order they come in: consecutive points
    // are then neighbours in all three directions, so a packet is a compact group (its walk
    // shared best), each candidate is a near neighbour's answer, and successive searches touch
    // the same nodes while they are in cache. On grid rows this is 1.6x faster than row order.
    const std::vector<uint32_t> order = morton_order(points);
    parallel_chunks(points.size(), 256, [&](std::size_t b, std::size_t e) {
      // Each point's candidate: the triangle of the previous packet's closest point nearest to it
      // (a surface point near p bounds p's distance, and its triangle is usually near p's
      // answer). On the 52k torus this measures 28 % fewer triangles exactly than the answer of
      // the point in the same place of the previous packet. The closest points are kept as
      // floats, structure of arrays (they only choose, never decide); absent ones at infinity.
      Four seed_x[kPacket / 4], seed_y[kPacket / 4], seed_z[kPacket / 4];
      uint32_t seed_triangle[kPacket] = {}, candidate[kPacket] = {};
      for (int k = 0; k < kPacket / 4; ++k) seed_x[k] = seed_y[k] = seed_z[k] = Four{} + INFINITY;
      for (std::size_t i = b; i < e; i += kPacket) {
        const int n = int(std::min<std::size_t>(kPacket, e - i));
        Vec3 p[kPacket];
        for (int l = 0; l < n; ++l) p[l] = points[order[i + l]];
        for (int l = 0; l < n; ++l) {
          const Four x = Four{} + float(p[l].x), y = Four{} + float(p[l].y), z = Four{} + float(p[l].z);
          Four best = Four{} + INFINITY;
          Four32 at = {}, lane = {0, 1, 2, 3};
          for (int k = 0; k < kPacket / 4; ++k, lane += 4) {
            const Four dx = seed_x[k] - x, dy = seed_y[k] - y, dz = seed_z[k] - z;
            const Four d = dx * dx + dy * dy + dz * dz;
            const Four32 nearer = d < best;
            best = nearer ? d : best;
            at = nearer ? lane : at;
          }
          int k = 0;
          for (int j = 1; j < 4; ++j)
            if (best[j] < best[k]) k = j;
          candidate[l] = seed_triangle[at[k]];
        }
        Query q[kPacket];
        closest(p, n, candidate, q);
        for (int l = 0; l < n; ++l) {
          values[order[i + l]] = out(p[l], q[l]);
          seed_x[l / 4][l % 4] = float(q[l].best.point.x);
          seed_y[l / 4][l % 4] = float(q[l].best.point.y);
          seed_z[l / 4][l % 4] = float(q[l].best.point.z);
          seed_triangle[l] = q[l].best_triangle;
        }
      }
    });
  }
};

SurfaceSdf::SurfaceSdf(const TriangleSurface& surface) : impl_(std::make_unique<Impl>(surface)) {}
SurfaceSdf::~SurfaceSdf() = default;

Box SurfaceSdf::bounds() const { return impl_->box; }

void SurfaceSdf::evaluate(std::span<const Vec3> points, std::span<double> values) const {
  const Impl& m = *impl_;
  m.run(points, values, [&m](Vec3 p, const Impl::Query& q) {
    return signed_value(p, q.best, m.normals.of(q.best_triangle, q.best.region, m.surface));
  });
}

void SurfaceSdf::distance(std::span<const Vec3> points, std::span<double> values) const {
  impl_->run(points, values,
             [](Vec3, const Impl::Query& q) { return std::sqrt(q.best.squared_distance); });
}

std::vector<uint32_t> morton_order(std::span<const Vec3> points) {
  if (points.size() >= (std::size_t(1) << 32)) throw std::length_error("SDF batch too large");
  Box box{{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
  for (const Vec3& p : points)
    for (int a = 0; a < 3; ++a)
      if (std::isfinite(p[a])) box.lo[a] = std::min(box.lo[a], p[a]), box.hi[a] = std::max(box.hi[a], p[a]);
  auto spread = [](uint64_t x) {  // bit i of x to bit 3i
    x &= 0x1fffff;
    x = (x | x << 32) & 0x1f00000000ffffull;
    x = (x | x << 16) & 0x1f0000ff0000ffull;
    x = (x | x << 8) & 0x100f00f00f00f00full;
    x = (x | x << 4) & 0x10c30c30c30c30c3ull;
    x = (x | x << 2) & 0x1249249249249249ull;
    return x;
  };
  std::vector<std::pair<uint64_t, uint32_t>> keys(points.size());
  parallel_for(points.size(), [&](std::size_t i) {
    uint64_t key = 0;
    for (int a = 0; a < 3; ++a) {
      const double extent = box.hi[a] - box.lo[a];
      const double t = extent > 0 && std::isfinite(points[i][a]) ? (points[i][a] - box.lo[a]) / extent : 0;
      key |= spread(uint64_t(std::clamp(t, 0.0, 1.0) * double(0x1fffff))) << a;
    }
    keys[i] = {key, uint32_t(i)};
  });
  tbb::parallel_sort(keys.begin(), keys.end());
  std::vector<uint32_t> order(points.size());
  for (std::size_t i = 0; i < keys.size(); ++i) order[i] = keys[i].second;
  return order;
}


void brute_force_sdf(const TriangleSurface& surface, std::span<const Vec3> points,
                     std::span<double> values) {
  const Pseudonormals normals(surface);
  parallel_for(points.size(), [&](std::size_t i) {
    ClosestPoint best{points[i], std::numeric_limits<double>::infinity(), -1};
    uint32_t best_t = 0;
    for (uint32_t t = 0; t < surface.triangles.size(); ++t) {
      const auto& tri = surface.triangles[t];
      const ClosestPoint cp = closest_point_on_triangle(
          points[i], surface.vertices[tri[0]], surface.vertices[tri[1]], surface.vertices[tri[2]]);
      if (cp.squared_distance < best.squared_distance) best = cp, best_t = t;
    }
    values[i] = best.region < 0 ? -std::numeric_limits<double>::infinity()
                                : signed_value(points[i], best, normals.of(best_t, best.region, surface));
  });
}

}  // namespace mchex
