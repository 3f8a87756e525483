#include "core/sdf/sdf.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <mutex>
#include <numbers>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <string>

#if defined(__SSE__)
#include <xmmintrin.h>
#endif

#include "core/base/parallel.h"
#include "core/sdf/bvh.h"
#include "core/sdf/pseudonormals.h"
#include "core/sdf/search_tree.h"
#include "core/sdf/winding_number.h"

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

// The sign rule (core/device/device_scene.h) applied to a closest-point answer.
double signed_value(Vec3 p, const ClosestPoint& cp, Vec3 pseudonormal) {
  return pseudonormal_signed_value(p, cp.point, cp.squared_distance, pseudonormal);
}

// Points searched together: a 4x4x2 brick of a grid in Morton order. A step of the walk costs a
// fixed part (the node's loads, ordering its children, pushing them) and a part per point in
// range; 32 points share the fixed part 9 % better than 8 on the 52k torus, while the points that
// drop out of a subtree cost only a bit of a mask each.
constexpr int kPacket = 32;
static_assert(kPacket % 4 == 0 && kPacket <= 32, "lane masks are 32-bit, points go four to a vector");

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

}  // namespace

struct SurfaceSdf::Impl {
  TriangleSurface surface;
  TriangleBvh bvh;
  SearchTree tree;
  // Corners of each leaf slot's triangle, for locality: for a surface searched many times; one
  // searched by one batch reads them through its triangles (72 bytes a triangle less, at the
  // moment of the run's peak memory for the fidelity's mesh boundary).
  std::vector<std::array<Vec3, 3>> leaf_corners;
  Box box;
  double scale = 0;  // largest coordinate magnitude of the surface
  SignRule sign;
  std::optional<WindingNumber> winding;  // under SignRule::kWindingNumber and kWindingParity
  // Made at the first query signed by the pseudonormal rule: a surface measured only for its
  // distances (the fidelity's mesh boundary, rebuilt for every mesh) never needs them.
  mutable std::once_flag normals_once;
  mutable std::optional<Pseudonormals> normals_made;
  const Pseudonormals& normals() const {
    std::call_once(normals_once, [this] { normals_made.emplace(surface); });
    return *normals_made;
  }

  Impl(TriangleSurface moved, SignRule rule, SearchUse use)
      : surface(std::move(moved)),
        bvh(TriangleBvh::build(surface, use == SearchUse::kRepeated ? BvhBuilder::kSah : BvhBuilder::kMortonFours)),
        tree(surface, bvh,
             use == SearchUse::kRepeated ? SearchTree::Frames::kFitted : SearchTree::Frames::kAxisAligned),
        box(surface.bounds()),
        sign(rule) {
    const TriangleSurface& s = surface;
    if (sign == SignRule::kWindingNumber) winding.emplace(s, bvh);
    if (sign == SignRule::kWindingParity) winding.emplace(s, bvh, WindingNumber::Decision::kParity);
    if (bvh.leaf_triangles.size() >= (1u << 29)) throw std::length_error("too many triangles for the SDF search tree");
    scale = std::max({std::abs(box.lo.x), std::abs(box.lo.y), std::abs(box.lo.z), std::abs(box.hi.x),
                      std::abs(box.hi.y), std::abs(box.hi.z)});
    if (use != SearchUse::kRepeated) return;
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
      unsigned active = 0;            // the points this node is (still) in range of
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
            const uint32_t id = bvh.leaf_triangles[slot];
            std::array<Vec3, 3> own;
            const Vec3* v = leaf_corners.empty() ? nullptr : leaf_corners[slot].data();
            if (!v) {
              for (int k = 0; k < 3; ++k) own[k] = surface.vertices[surface.triangles[id][k]];
              v = own.data();
            }
            const ClosestPoint cp = closest_point_inline(p[l], v[0], v[1], v[2]);
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
    run(points, morton_order(points), values, out);
  }
  // The same with the points' Morton order given (the caller reuses it).
  template <class Out>
  void run(std::span<const Vec3> points, std::span<const uint32_t> order, std::span<double> values, Out out) const {
    if (points.size() != values.size()) throw std::invalid_argument("SDF batch size mismatch");
    if (surface.triangles.empty()) {
      std::fill(values.begin(), values.end(), -std::numeric_limits<double>::infinity());
      return;
    }
    search(points, order, [&](std::size_t i, Vec3 p, const Query& q) { values[i] = out(p, q); });
  }

  // Every point's nearest triangle, handed to sink(index, point, query) (each index once, on any
  // thread). The surface has triangles.
  template <class Sink>
  void search(std::span<const Vec3> points, Sink sink) const {
    search(points, morton_order(points), sink);
  }
  // The same in a given order. The points are searched in Morton order whatever order they come
  // in: consecutive points are then neighbours in all three directions, so a packet is a compact
  // group (its walk shared best), each candidate is a near neighbour's answer, and successive
  // searches touch the same nodes while they are in cache. On grid rows this is 1.6x faster than
  // row order.
  template <class Sink>
  void search(std::span<const Vec3> points, std::span<const uint32_t> order, Sink sink) const {
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
          sink(order[i + l], p[l], q[l]);
          seed_x[l / 4][l % 4] = float(q[l].best.point.x);
          seed_y[l / 4][l % 4] = float(q[l].best.point.y);
          seed_z[l / 4][l % 4] = float(q[l].best.point.z);
          seed_triangle[l] = q[l].best_triangle;
        }
      }
    });
  }
};

SurfaceSdf::SurfaceSdf(TriangleSurface surface, SignRule sign, SearchUse use)
    : impl_(std::make_unique<Impl>(std::move(surface), sign, use)) {}
SurfaceSdf::~SurfaceSdf() = default;

Box SurfaceSdf::bounds() const { return impl_->box; }
SignRule SurfaceSdf::sign_rule() const { return impl_->sign; }
const WindingNumber* SurfaceSdf::winding() const { return impl_->winding ? &*impl_->winding : nullptr; }

void SurfaceSdf::evaluate(std::span<const Vec3> points, std::span<double> values) const {
  const Impl& m = *impl_;
  if (m.winding) {
    // Distances first, then the signs in the same Morton order, where most points far from the
    // surface inherit a neighbour's (apply_winding_sign).
    const std::vector<uint32_t> order = morton_order(points);
    m.run(points, order, values, [](Vec3, const Impl::Query& q) { return std::sqrt(q.best.squared_distance); });
    if (!m.surface.triangles.empty()) apply_winding_sign(*m.winding, points, order, values);
    return;
  }
  evaluate_pseudonormal(points, values);
}

void SurfaceSdf::evaluate_pseudonormal(std::span<const Vec3> points, std::span<double> values) const {
  const Impl& m = *impl_;
  const Pseudonormals& normals = m.normals();
  m.run(points, values, [&m, &normals](Vec3 p, const Impl::Query& q) {
    return signed_value(p, q.best, normals.of(q.best_triangle, q.best.region, m.surface));
  });
}

void SurfaceSdf::distance(std::span<const Vec3> points, std::span<double> values) const {
  impl_->run(points, values, [](Vec3, const Impl::Query& q) { return std::sqrt(q.best.squared_distance); });
}

void SurfaceSdf::closest_points(std::span<const Vec3> points, std::span<Vec3> closest) const {
  if (points.size() != closest.size()) throw std::invalid_argument("closest-point batch size mismatch");
  if (impl_->surface.triangles.empty()) throw std::invalid_argument("closest points on a surface without triangles");
  impl_->search(points, [&](std::size_t i, Vec3, const Impl::Query& q) { closest[i] = q.best.point; });
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
  parallel_sort(keys.begin(), keys.end());
  std::vector<uint32_t> order(points.size());
  for (std::size_t i = 0; i < keys.size(); ++i) order[i] = keys[i].second;
  return order;
}

void brute_force_sdf(const TriangleSurface& surface, std::span<const Vec3> points, std::span<double> values) {
  const Pseudonormals normals(surface);
  parallel_for(points.size(), [&](std::size_t i) {
    ClosestPoint best{points[i], std::numeric_limits<double>::infinity(), -1};
    uint32_t best_t = 0;
    for (uint32_t t = 0; t < surface.triangles.size(); ++t) {
      const auto& tri = surface.triangles[t];
      const ClosestPoint cp = closest_point_on_triangle(points[i], surface.vertices[tri[0]], surface.vertices[tri[1]],
                                                        surface.vertices[tri[2]]);
      if (cp.squared_distance < best.squared_distance) best = cp, best_t = t;
    }
    values[i] = best.region < 0 ? -std::numeric_limits<double>::infinity()
                                : signed_value(points[i], best, normals.of(best_t, best.region, surface));
  });
}

}  // namespace mchex
