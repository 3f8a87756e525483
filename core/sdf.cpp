#include "core/sdf.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#if defined(__SSE__)
#include <xmmintrin.h>
#endif

#include "core/bvh.h"
#include "core/device_scene.h"
#include "core/parallel.h"

namespace mchex {

ClosestPoint closest_point_on_triangle(Vec3 p, Vec3 a, Vec3 b, Vec3 c) {
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

namespace {

// The sign rule (core/device_scene.h) applied to a closest-point answer.
double signed_value(Vec3 p, const ClosestPoint& cp, Vec3 pseudonormal) {
  return pseudonormal_signed_value(p, cp.point, cp.squared_distance, pseudonormal);
}

// The search tree of the reference SDF: the topology of the Embree-built TriangleBvh, with each
// node's triangles bounded by a box in a frame of its own, collapsed to four children per node.
//
// Why oriented boxes: a point far from a smooth surface is at nearly the same distance from a
// whole patch of it (distance grows only quadratically sideways), so a search must rule out
// every node whose bound is below the answer. An axis-aligned box around a tilted, nearly flat
// piece of surface is as thick as the piece is wide, and comes within range a whole patch away;
// a box aligned with the piece's mean normal is thin and comes within range only right under the
// point. Low in the tree nodes are nearly flat pieces. Where the normals of a node's triangles
// cancel (high in the tree, around corners) the node keeps the axis-aligned frame.
struct OrientedBox {
  float axis[3][3];    // orthonormal frame (to float precision)
  float lo[3], hi[3];  // extents along the axes, rounded outward
};

// Four children's oriented boxes side by side (structure of arrays), so that one search step
// measures all four at once in vector registers. An absent child has an empty box (lo > hi),
// which is at infinite distance.
struct alignas(64) WideNode {
  float axis[3][3][4];  // [axis][component][child]
  float lo[3][4], hi[3][4];
  uint32_t child[4];  // inner: wide node; leaf: first leaf slot
  uint32_t count[4];  // triangles of a leaf child; 0 for an inner child

  // Lower bounds of the squared distance from p to each child's triangles. `slack` (per query)
  // covers float rounding of the projections and the axes' departure from orthonormality, so a
  // bound never exceeds the true distance.
  void distance2(const float p[3], float slack, float out[4]) const {
#if defined(__SSE__)
    // The same arithmetic as the portable loop below, four children per instruction (SSE is
    // part of x86-64, so this needs no special build).
    const __m128 px = _mm_set1_ps(p[0]), py = _mm_set1_ps(p[1]), pz = _mm_set1_ps(p[2]);
    const __m128 s = _mm_set1_ps(slack), zero = _mm_setzero_ps();
    __m128 d2 = zero;
    for (int a = 0; a < 3; ++a) {
      const __m128 t = _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_load_ps(axis[a][0]), px), _mm_mul_ps(_mm_load_ps(axis[a][1]), py)),
                                  _mm_mul_ps(_mm_load_ps(axis[a][2]), pz));
      const __m128 d = _mm_max_ps(
          _mm_sub_ps(_mm_max_ps(_mm_sub_ps(_mm_load_ps(lo[a]), t), _mm_sub_ps(t, _mm_load_ps(hi[a]))), s), zero);
      d2 = _mm_add_ps(d2, _mm_mul_ps(d, d));
    }
    _mm_storeu_ps(out, d2);
#else
    float d2[4] = {0, 0, 0, 0};
    for (int a = 0; a < 3; ++a)
      for (int c = 0; c < 4; ++c) {
        const float t = axis[a][0][c] * p[0] + axis[a][1][c] * p[1] + axis[a][2][c] * p[2];
        const float d = std::max(std::max(lo[a][c] - t, t - hi[a][c]) - slack, 0.0f);
        d2[c] += d * d;
      }
    for (int c = 0; c < 4; ++c) out[c] = d2[c];
#endif
  }
};

std::vector<OrientedBox> oriented_boxes(const TriangleSurface& s, const TriangleBvh& bvh) {
  const auto slots = bvh.subtree_slots();
  std::vector<OrientedBox> nodes(bvh.nodes.size());
  parallel_for(bvh.nodes.size(), [&](std::size_t n) {
    const auto [first, last] = slots[n];
    Vec3 normal{};
    double area = 0;
    for (uint32_t k = first; k < last; ++k) {
      const auto& t = s.triangles[bvh.leaf_triangles[k]];
      const Vec3 c = cross(s.vertices[t[1]] - s.vertices[t[0]], s.vertices[t[2]] - s.vertices[t[0]]);
      normal += c;
      area += norm(c);
    }
    Vec3 a0{0, 0, 1}, a1{1, 0, 0};
    if (norm(normal) > 0.5 * area && area > 0) {  // a nearly flat piece: its own frame
      a0 = normalized(normal);
      a1 = normalized(cross(a0, std::abs(a0.x) < 0.6 ? Vec3{1, 0, 0} : Vec3{0, 1, 0}));
    }
    OrientedBox& out = nodes[n];
    const Vec3 a2 = cross(a0, a1);
    for (int i = 0; i < 3; ++i) out.axis[0][i] = float(a0[i]), out.axis[1][i] = float(a1[i]), out.axis[2][i] = float(a2[i]);
    // Extents along exactly the float axes that distance2() will use, computed in double and
    // rounded outward, so every triangle lies inside its box.
    Vec3 axes[3];
    for (int a = 0; a < 3; ++a) axes[a] = {out.axis[a][0], out.axis[a][1], out.axis[a][2]};
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t k = first; k < last; ++k)
      for (uint32_t v : s.triangles[bvh.leaf_triangles[k]])
        for (int a = 0; a < 3; ++a) {
          const double t = dot(axes[a], s.vertices[v]);
          lo[a] = std::min(lo[a], t), hi[a] = std::max(hi[a], t);
        }
    for (int a = 0; a < 3; ++a) {
      out.lo[a] = std::nextafter(float(lo[a]), -INFINITY);
      out.hi[a] = std::nextafter(float(hi[a]), INFINITY);
    }
  });
  return nodes;
}

// Collapses the binary tree into one of four children per node: each node takes its two
// children and keeps opening the inner one holding the most triangles until it has four. Half
// the depth, so a search takes half the steps, each measuring four boxes together.
std::vector<WideNode> collapse(const TriangleBvh& bvh, const std::vector<OrientedBox>& boxes) {
  const auto slots = bvh.subtree_slots();
  auto size = [&](uint32_t n) { return slots[n].second - slots[n].first; };
  std::vector<WideNode> wide;
  auto build = [&](auto&& self, std::vector<uint32_t> kids) -> uint32_t {
    while (kids.size() < 4) {
      int open = -1;
      for (int k = 0; k < int(kids.size()); ++k)
        if (bvh.nodes[kids[k]].count == 0 && (open < 0 || size(kids[k]) > size(kids[open]))) open = k;
      if (open < 0) break;
      const uint32_t n = kids[open];
      kids[open] = n + 1;
      kids.push_back(bvh.nodes[n].index);
    }
    const uint32_t self_index = uint32_t(wide.size());
    wide.emplace_back();
    WideNode w{};
    for (int c = 0; c < 4; ++c) {
      for (int a = 0; a < 3; ++a) w.lo[a][c] = INFINITY, w.hi[a][c] = -INFINITY;
      w.child[c] = 0;
      w.count[c] = 0;
    }
    for (int c = 0; c < int(kids.size()); ++c) {
      const OrientedBox& b = boxes[kids[c]];
      for (int a = 0; a < 3; ++a) {
        for (int i = 0; i < 3; ++i) w.axis[a][i][c] = b.axis[a][i];
        w.lo[a][c] = b.lo[a];
        w.hi[a][c] = b.hi[a];
      }
      const BvhNode& node = bvh.nodes[kids[c]];
      w.count[c] = node.count;
      w.child[c] = node.count ? node.index : self(self, {kids[c] + 1, node.index});
    }
    wide[self_index] = w;
    return self_index;
  };
  if (bvh.nodes.empty()) return wide;
  if (bvh.nodes[0].count) build(build, {0});  // a single leaf
  else build(build, {1, bvh.nodes[0].index});
  return wide;
}

}  // namespace

struct SurfaceSdf::Impl {
  TriangleSurface surface;
  Pseudonormals normals;
  std::vector<WideNode> nodes;
  std::vector<uint32_t> leaf_triangles;          // triangle id of each leaf slot
  std::vector<std::array<Vec3, 3>> leaf_corners;  // its corners, in slot order for locality
  Box box;
  double scale = 0;  // largest coordinate magnitude of the surface

  explicit Impl(const TriangleSurface& s) : surface(s), normals(s), box(s.bounds()) {
    const TriangleBvh bvh = TriangleBvh::build(s);
    if (bvh.leaf_triangles.size() >= (1u << 29)) throw std::length_error("too many triangles for the SDF search tree");
    nodes = collapse(bvh, oriented_boxes(s, bvh));
    scale = std::max({std::abs(box.lo.x), std::abs(box.lo.y), std::abs(box.lo.z), std::abs(box.hi.x),
                      std::abs(box.hi.y), std::abs(box.hi.z)});
    leaf_triangles = bvh.leaf_triangles;
    leaf_corners.resize(leaf_triangles.size());
    for (std::size_t k = 0; k < leaf_triangles.size(); ++k)
      for (int c = 0; c < 3; ++c) leaf_corners[k][c] = s.vertices[s.triangles[leaf_triangles[k]][c]];
  }

  struct Query {
    ClosestPoint best;
    uint32_t best_triangle;
  };

  // Nearest triangle to p, nearest nodes first, starting from a candidate triangle (the previous
  // point's answer: on a grid it is usually the answer here too, so the search starts with an
  // exact bound and only has to prove it). Ties go to the lower triangle index, so the answer does
  // not depend on the candidate, the tree's shape or the traversal order.
  Query closest(Vec3 p, uint32_t candidate) const {
    const auto& c = surface.triangles[candidate];
    Query q{closest_point_on_triangle(p, surface.vertices[c[0]], surface.vertices[c[1]], surface.vertices[c[2]]),
            candidate};
    // Float projections err by a few ulps of |p| + |extent| (and the axes by ~1e-7 from unit
    // length and right angles): 1e-6 of that magnitude is a safe margin.
    const float pf[3] = {float(p.x), float(p.y), float(p.z)};
    const float slack = float(1e-6 * (3 * std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}) + 2 * scale));
    float best2 = std::nextafter(float(q.best.squared_distance), INFINITY);
    uint32_t stack[64 * 3];
    float stack_d2[64 * 3];
    int top = 0;
    stack[top] = 0;
    stack_d2[top++] = 0;
    while (top > 0) {
      --top;
      if (stack_d2[top] > best2) continue;
      const WideNode& w = nodes[stack[top]];
      float d2[4];
      w.distance2(pf, slack, d2);
      // Children nearest first: leaves are searched at once (shrinking the bound), inner
      // children pushed farthest first so that the nearest is popped next.
      int order[4] = {0, 1, 2, 3};
      for (int i = 1; i < 4; ++i)
        for (int j = i; j > 0 && d2[order[j]] < d2[order[j - 1]]; --j) std::swap(order[j], order[j - 1]);
      for (int i = 0; i < 4; ++i) {
        const int c = order[i];
        if (d2[c] > best2 || w.count[c] == 0) continue;
        for (uint32_t k = w.child[c]; k < w.child[c] + w.count[c]; ++k) {
          const auto& v = leaf_corners[k];
          const ClosestPoint cp = closest_point_on_triangle(p, v[0], v[1], v[2]);
          const uint32_t t = leaf_triangles[k];
          if (cp.squared_distance < q.best.squared_distance ||
              (cp.squared_distance == q.best.squared_distance && t < q.best_triangle)) {
            q.best = cp;
            q.best_triangle = t;
            // Rounded up, so that float comparisons against it never prune a node at the bound.
            best2 = std::nextafter(float(cp.squared_distance), INFINITY);
          }
        }
      }
      for (int i = 3; i >= 0; --i) {
        const int c = order[i];
        if (d2[c] <= best2 && w.count[c] == 0) stack[top] = w.child[c], stack_d2[top++] = d2[c];
      }
    }
    return q;
  }

  template <class Out>
  void run(std::span<const Vec3> points, std::span<double> values, Out out) const {
    if (points.size() != values.size()) throw std::invalid_argument("SDF batch size mismatch");
    if (surface.triangles.empty()) {
      std::fill(values.begin(), values.end(), -std::numeric_limits<double>::infinity());
      return;
    }
    parallel_chunks(points.size(), 256, [&](std::size_t b, std::size_t e) {
      uint32_t candidate = 0;
      for (std::size_t i = b; i < e; ++i) {
        const Query q = closest(points[i], candidate);
        values[i] = out(points[i], q);
        candidate = q.best_triangle;
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
