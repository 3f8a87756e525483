#include "core/sdf.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#include "core/bvh.h"
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

// Angle-weighted pseudonormals: one per face, per edge and per vertex. For a closed, consistently
// oriented manifold, the sign of dot(p - q, N) with q the closest point and N the pseudonormal of
// the feature q lies on is the side of p (Baerentzen & Aanaes, IEEE TVCG 2005, Theorem 1).
struct Pseudonormals {
  std::vector<Vec3> face, vertex, edge;
  std::vector<std::array<uint32_t, 3>> triangle_edges;  // edge ids of (ab, bc, ca)

  explicit Pseudonormals(const TriangleSurface& s) {
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
      for (std::size_t k = i; k < j; ++k)
        triangle_edges[half[k].second / 3][half[k].second % 3] = uint32_t(edge.size());
      edge.push_back(sum);
      i = j;
    }
  }

  Vec3 of(uint32_t t, int region, const TriangleSurface& s) const {
    if (region < 3) return vertex[s.triangles[t][region]];
    if (region < 6) return edge[triangle_edges[t][region - 3]];
    return face[t];
  }
};

// The sign rule in one place (both the BVH path and brute force use it). A point exactly on the
// surface gets 0; a point whose offset is orthogonal to the pseudonormal (possible only on
// non-manifold or inconsistent input) is called outside.
double signed_value(Vec3 p, const ClosestPoint& cp, Vec3 pseudonormal) {
  const double d = std::sqrt(cp.squared_distance);
  if (d == 0) return 0;
  return dot(p - cp.point, pseudonormal) > 0 ? -d : d;
}


// The triangles under a node inside a box aligned with their mean normal. Low in the tree a node
// is a nearly flat piece of surface, so this box is thin where the axis-aligned one is fat, and
// its distance is a much tighter lower bound: for a point far above a patch, the axis-aligned
// boxes of tilted pieces a whole patch wide come within the search radius, oriented ones only
// right under the point. High in the tree the normals cancel and the frame is arbitrary, which
// is why the search takes the larger of the two distances.
struct NodeFrame {
  Vec3 axis[3];
  double lo[3], hi[3];

  double distance2(Vec3 p) const {
    double d2 = 0;
    for (int a = 0; a < 3; ++a) {
      const double t = dot(axis[a], p);
      const double d = t < lo[a] ? lo[a] - t : (t > hi[a] ? t - hi[a] : 0);
      d2 += d * d;
    }
    return d2;
  }
};

std::vector<NodeFrame> node_frames(const TriangleSurface& s, const TriangleBvh& bvh) {
  // Depth-first layout: the leaf slots under a node are one contiguous range.
  std::vector<std::pair<uint32_t, uint32_t>> slots(bvh.nodes.size());
  for (std::size_t n = bvh.nodes.size(); n-- > 0;) {
    const BvhNode& node = bvh.nodes[n];
    slots[n] = node.count ? std::pair{node.index, node.index + node.count}
                          : std::pair{slots[n + 1].first, slots[node.index].second};
  }
  std::vector<NodeFrame> frames(bvh.nodes.size());
  parallel_for(bvh.nodes.size(), [&](std::size_t n) {
    const auto [first, last] = slots[n];
    Vec3 normal{};
    for (uint32_t k = first; k < last; ++k) {
      const auto& t = s.triangles[bvh.leaf_triangles[k]];
      normal += cross(s.vertices[t[1]] - s.vertices[t[0]], s.vertices[t[2]] - s.vertices[t[0]]);
    }
    NodeFrame& f = frames[n];
    f.axis[0] = normalized(normal);
    if (squared_norm(f.axis[0]) == 0) f.axis[0] = {0, 0, 1};  // normals cancel: any frame is a box
    const Vec3 helper = std::abs(f.axis[0].x) < 0.6 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
    f.axis[1] = normalized(cross(f.axis[0], helper));
    f.axis[2] = cross(f.axis[0], f.axis[1]);
    double scale = 0;
    for (int a = 0; a < 3; ++a) f.lo[a] = std::numeric_limits<double>::infinity(), f.hi[a] = -f.lo[a];
    for (uint32_t k = first; k < last; ++k)
      for (uint32_t v : s.triangles[bvh.leaf_triangles[k]])
        for (int a = 0; a < 3; ++a) {
          const double t = dot(f.axis[a], s.vertices[v]);
          f.lo[a] = std::min(f.lo[a], t), f.hi[a] = std::max(f.hi[a], t);
          scale = std::max(scale, std::abs(t));
        }
  // Rounding in the projections is a few ulps of the coordinates: pad by far more than that so
    // the bound stays a bound.
    for (int a = 0; a < 3; ++a) f.lo[a] -= 1e-12 * scale, f.hi[a] += 1e-12 * scale;
  });
  return frames;
}

}  // namespace

struct SurfaceSdf::Impl {
  TriangleSurface surface;
  Pseudonormals normals;
  TriangleBvh bvh;
  std::vector<NodeFrame> frames;
  Box box;

  explicit Impl(const TriangleSurface& s)
      : surface(s), normals(s), bvh(TriangleBvh::build(s)), frames(node_frames(s, bvh)), box(s.bounds()) {}

  // Lower bound of the squared distance from p to the triangles under node n; the oriented box
  // is only consulted when the axis-aligned one does not already rule the node out.
  double node_distance2(uint32_t n, Vec3 p, double best2) const {
    const double d2 = bvh.box_distance2(n, p);
    return d2 > best2 ? d2 : std::max(d2, frames[n].distance2(p));
  }

  struct Query {
    ClosestPoint best;
    uint32_t best_triangle;
  };

  // Nearest triangle to p, nearest boxes first, starting from a candidate triangle (the previous
  // point's answer: on a grid it is usually the answer here too, so the search starts with an
  // exact bound and only has to prove it). Ties go to the lower triangle index, so the answer does
  // not depend on the candidate, the tree's shape or the traversal order.
  Query closest(Vec3 p, uint32_t candidate) const {
    const auto& c = surface.triangles[candidate];
    Query q{closest_point_on_triangle(p, surface.vertices[c[0]], surface.vertices[c[1]], surface.vertices[c[2]]),
            candidate};
    uint32_t stack[128];
    double stack_d2[128];
    int top = 0;
    stack[top] = 0;
    stack_d2[top++] = node_distance2(0, p, q.best.squared_distance);
    while (top > 0) {
      --top;
      if (stack_d2[top] > q.best.squared_distance) continue;
      const BvhNode& n = bvh.nodes[stack[top]];
      if (n.count > 0) {
        for (uint32_t k = n.index; k < n.index + n.count; ++k) {
          const uint32_t t = bvh.leaf_triangles[k];
          const auto& tri = surface.triangles[t];
          const ClosestPoint cp = closest_point_on_triangle(p, surface.vertices[tri[0]],
                                                            surface.vertices[tri[1]], surface.vertices[tri[2]]);
          if (cp.squared_distance < q.best.squared_distance ||
              (cp.squared_distance == q.best.squared_distance && t < q.best_triangle)) {
            q.best = cp;
            q.best_triangle = t;
          }
        }
        continue;
      }
      const uint32_t a = stack[top] + 1, b = n.index;
      double da = node_distance2(a, p, q.best.squared_distance), db = node_distance2(b, p, q.best.squared_distance);
      // Push the farther child first so the nearer one is searched first and shrinks the bound.
      const bool swap = da < db;
      const uint32_t first = swap ? b : a, second = swap ? a : b;
      if (swap) std::swap(da, db);
      if (da <= q.best.squared_distance) stack[top] = first, stack_d2[top++] = da;
      if (db <= q.best.squared_distance) stack[top] = second, stack_d2[top++] = db;
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
