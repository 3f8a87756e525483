#include "core/sdf/winding_number.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "core/base/parallel.h"
#include "core/sdf/sdf.h"

namespace mchex {

namespace {

constexpr double kInv4Pi = 0.25 * std::numbers::inv_pi;

// Van Oosterom & Strackee: tan(Omega / 2) = a . (b x c) / (|a||b||c| + (a.b)|c| + (a.c)|b| +
// (b.c)|a|), with a, b, c the corners seen from p; atan2 keeps the quadrant (|Omega| up to 2 pi).
inline double solid_angle_over_4pi(Vec3 p, Vec3 a, Vec3 b, Vec3 c) {
  a -= p, b -= p, c -= p;
  const double la = norm(a), lb = norm(b), lc = norm(c);
  const double num = triple(a, b, c);
  const double den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
  return 2 * std::atan2(num, den) * kInv4Pi;
}

// Longest-edge bisection of every triangle until no edge is longer than max_edge, orientation
// kept ((a, b, c) with ab longest -> (a, m, c), (m, b, c)): the solid angles add up to the
// triangle's, and no piece is much longer than it is wide. for_piece(a, b, c) in a fixed order.
template <class F>
void bisect(Vec3 a, Vec3 b, Vec3 c, double max_edge, const F& for_piece) {
  const double ab = squared_norm(b - a), bc = squared_norm(c - b), ca = squared_norm(a - c);
  const double longest = std::max({ab, bc, ca});
  if (!(longest > max_edge * max_edge)) return for_piece(a, b, c);
  if (ab == longest) {
    const Vec3 m = 0.5 * (a + b);
    bisect(a, m, c, max_edge, for_piece), bisect(m, b, c, max_edge, for_piece);
  } else if (bc == longest) {
    bisect(b, c, a, max_edge, for_piece);
  } else {
    bisect(c, a, b, max_edge, for_piece);
  }
}

// The triangles the tree is built over: the surface's, with those longer than a 16th of the box's
// diagonal bisected. A long sliver is near every point along it, so without this it is summed
// exactly almost everywhere (on the gearwheel model, 2,444 triangles spanning the part, most of
// them per query). The length doubles while the pieces would outnumber
// max(4 T, 2^20), so that memory stays linear. Empty when nothing is split. Why a 16th: on the
// npm gearwheel a 64th made about 290k pieces, 60 MB of tree held through the whole run (a sixth
// of its default mesh's peak), for no speed: queries 0.25 M/s per thread against 0.31 M/s at a
// 16th (perf/bench_sdf --model gear --grid 50) and 0.08 M/s unsplit; the default mesh took 11 %
// less time at a 16th, its peak 40 MiB less.
TriangleSurface split_long_triangles(const TriangleSurface& s) {
  TriangleSurface out;
  if (s.triangles.empty()) return out;
  const std::size_t cap = std::max<std::size_t>(4 * s.triangles.size(), std::size_t(1) << 20);
  double max_edge = s.bounds().diagonal() / 16;
  auto corner = [&](uint32_t t, int k) { return s.vertices[s.triangles[t][k]]; };
  for (;; max_edge *= 2) {
    if (!(max_edge > 0)) return out;
    std::size_t pieces = 0;
    for (uint32_t t = 0; t < s.triangles.size() && pieces <= cap; ++t)
      bisect(corner(t, 0), corner(t, 1), corner(t, 2), max_edge, [&](Vec3, Vec3, Vec3) { ++pieces; });
    if (pieces == s.triangles.size()) return out;
    if (pieces <= cap) break;
  }
  for (uint32_t t = 0; t < s.triangles.size(); ++t)
    bisect(corner(t, 0), corner(t, 1), corner(t, 2), max_edge, [&](Vec3 a, Vec3 b, Vec3 c) {
      const uint32_t o = uint32_t(out.vertices.size());
      out.vertices.insert(out.vertices.end(), {a, b, c});
      out.triangles.push_back({o, o + 1, o + 2});
    });
  return out;
}

// Whether every edge is used as often in each direction (edges of a zero-length side skipped: a
// degenerate triangle bounds nothing). Directed edges as (low, high) keys with the sign of their
// direction, sorted, summed per key.
bool is_two_cycle(const TriangleSurface& s) {
  if (s.triangles.empty()) return false;
  std::vector<std::pair<uint64_t, int>> edges;
  edges.reserve(3 * s.triangles.size());
  for (const auto& t : s.triangles)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = t[k], b = t[(k + 1) % 3];
      if (a != b) edges.push_back({uint64_t(std::min(a, b)) << 32 | std::max(a, b), a < b ? 1 : -1});
    }
  parallel_sort(edges.begin(), edges.end());
  for (std::size_t i = 0; i < edges.size();) {
    int sum = 0;
    const uint64_t key = edges[i].first;
    for (; i < edges.size() && edges[i].first == key; ++i) sum += edges[i].second;
    if (sum != 0) return false;
  }
  return true;
}

}  // namespace

double winding_number_exact(const TriangleSurface& s, Vec3 p) {
  double w = 0;
  for (const auto& t : s.triangles) w += solid_angle_over_4pi(p, s.vertices[t[0]], s.vertices[t[1]], s.vertices[t[2]]);
  return w;
}

WindingNumber::WindingNumber(const TriangleSurface& surface, Decision decision)
    : decision_(decision), constant_off_surface_(is_two_cycle(surface)) {
  const TriangleSurface split = split_long_triangles(surface);
  const TriangleSurface& s = split.triangles.empty() ? surface : split;
  build(s, TriangleBvh::build(s));
}
WindingNumber::WindingNumber(const TriangleSurface& surface, const TriangleBvh& bvh, Decision decision)
    : decision_(decision), constant_off_surface_(is_two_cycle(surface)) {
  const TriangleSurface split = split_long_triangles(surface);
  if (split.triangles.empty()) {
    build(surface, bvh);
  } else {
    build(split, TriangleBvh::build(split));
  }
}

void WindingNumber::build(const TriangleSurface& s, const TriangleBvh& bvh) {
  corners_.resize(3 * bvh.leaf_triangles.size());
  for (std::size_t k = 0; k < bvh.leaf_triangles.size(); ++k)
    for (int c = 0; c < 3; ++c) corners_[3 * k + c] = s.vertices[s.triangles[bvh.leaf_triangles[k]][c]];
  const auto slots = bvh.subtree_slots();
  nodes_.resize(bvh.nodes.size());
  // Each node from its own triangles (not its children's summaries): the centre is the middle of
  // the corners' box in double, the radius the farthest corner from it (a triangle lies within
  // the ball of its corners), so the bound's R is exact for the ball used. O(T log T) in all.
  parallel_for(bvh.nodes.size(), [&](std::size_t n) {
    Node& node = nodes_[n];
    node.index = bvh.nodes[n].index;
    node.count = bvh.nodes[n].count;
    const auto [first, last] = slots[n];
    Box box;
    for (std::size_t k = 3 * std::size_t(first); k < 3 * std::size_t(last); ++k) box.extend(corners_[k]);
    node.centre = box.center();
    node.radius = 0;
    node.second_moment = 0;
    node.normal = {};
    for (auto& row : node.moment)
      for (double& m : row) m = 0;
    for (std::size_t k = first; k < last; ++k) {
      const Vec3 a = corners_[3 * k], b = corners_[3 * k + 1], c = corners_[3 * k + 2];
      for (Vec3 v : {a, b, c}) node.radius = std::max(node.radius, norm(v - node.centre));
      const Vec3 av = 0.5 * cross(b - a, c - a);
      const Vec3 g = (1.0 / 3) * (a + b + c) - node.centre;
      // The second moment of the triangle about the centre, int |x - c|^2 dA =
      // area / 6 (sum |v_i|^2 + sum_{i<j} v_i . v_j), v the corners from the centre.
      const Vec3 va = a - node.centre, vb = b - node.centre, vc = c - node.centre;
      node.second_moment +=
          norm(av) / 6 *
          (squared_norm(va) + squared_norm(vb) + squared_norm(vc) + dot(va, vb) + dot(vb, vc) + dot(vc, va));
      node.normal += av;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) node.moment[i][j] += av[i] * g[j];
    }
    // Rounding of the corners' distances: a hair more keeps the ball around every corner.
    node.radius *= 1 + 1e-12;
  });
}

template <class Far>
double WindingNumber::descend(uint32_t root, Vec3 p, double beta, Far&& far) const {
  double exact = 0;
  uint32_t stack[128];
  int top = 0;
  stack[top++] = root;
  while (top > 0) {
    const uint32_t id = stack[--top];
    const Node& node = nodes_[id];
    const Vec3 D = node.centre - p;
    const double d2 = squared_norm(D), d = std::sqrt(d2);
    if (d > beta * node.radius) {
      // Far (Barill et al., eq. 8 to second order): the integrand (x - p) / |x - p|^3 expanded
      // about the centre, K = D / d^3 and its derivative (I - 3 D^ D^T) / d^3, against N and M.
      const Vec3 u = D / d;
      const auto& M = node.moment;
      double uMu = 0;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) uMu += u[i] * M[i][j] * u[j];
      const double trace = M[0][0] + M[1][1] + M[2][2];
      const double q = node.radius / d, r = 1 - q;
      const double taylor = 3 / (r * r * r * r);
      const double legendre = (2 - q) / (r * r) + 1.5 / r;
      far(id, (dot(u, node.normal) + (trace - 3 * uMu) / d) / d2 * kInv4Pi,
          node.second_moment / (d2 * d2) * std::min(taylor, legendre) * kInv4Pi);
      continue;
    }
    if (node.count) {
      for (uint32_t k = node.index; k < node.index + node.count; ++k)
        exact += solid_angle_over_4pi(p, corners_[3 * k], corners_[3 * k + 1], corners_[3 * k + 2]);
      continue;
    }
    // Left child (the next node) popped first, so the sum's order is the hierarchy's.
    if (top + 2 > 128) throw std::logic_error("winding number hierarchy deeper than its stack");
    stack[top++] = node.index;
    stack[top++] = id + 1;
  }
  return exact;
}

WindingNumber::Estimate WindingNumber::estimate(Vec3 p, double beta) const {
  Estimate e{0, 0};
  if (nodes_.empty()) return e;
  double far_sum = 0;
  e.value = descend(0, p, beta, [&](uint32_t, double value, double bound) { far_sum += value, e.bound += bound; });
  e.value += far_sum;
  return e;
}

double WindingNumber::at(Vec3 p) const {
  if (nodes_.empty()) return 0;
  if (!is_finite(p)) return std::numeric_limits<double>::quiet_NaN();
  // The far nodes in use, and the next round's list.
  struct Far {
    uint32_t node;
    double value, bound;
  };
  thread_local std::vector<Far> far, next;
  far.clear();
  double exact = descend(0, p, kBeta, [](uint32_t node, double value, double bound) {
    far.push_back({node, value, bound});
  });
  for (;;) {
    // Sums in the list's order, which depends on the point alone.
    double w = exact, bound = 0;
    for (const Far& f : far) w += f.value, bound += f.bound;
    // The distance to the threshold that decides: 1/2, or under kParity the nearest half-integer.
    const double threshold = decision_ == Decision::kHalf ? 0.5 : std::floor(w) + 0.5;
    const double margin = std::abs(w - threshold) - kRoundingAllowance;
    if (bound < margin || far.empty()) return w;
    // Deeper descent: a round refines every far node whose bound is above an equal share of the
    // margin (were all at most that, their sum would decide), each into its children at the same
    // beta (nearer in angle, so their bounds sum to a fraction of the node's), a leaf into its
    // exact solid angles. Refining the largest bound alone costs a pass over the list per node.
    const double share = std::max(margin, 0.0) / double(far.size());
    next.clear();
    bool refined = false;
    auto keep = [](uint32_t node, double value, double bound) { next.push_back({node, value, bound}); };
    for (const Far& f : far) {
      if (f.bound <= share) {
        next.push_back(f);
        continue;
      }
      refined = true;
      const Node& n = nodes_[f.node];
      if (n.count) {
        exact += descend(f.node, p, std::numeric_limits<double>::infinity(), keep);
      } else {
        exact += descend(f.node + 1, p, kBeta, keep);
        exact += descend(n.index, p, kBeta, keep);
      }
    }
    std::swap(far, next);
    // Within rounding of the threshold with only bound-free far nodes left (no area: nothing to refine).
    if (!refined) return w;
  }
}

void WindingNumber::at(std::span<const Vec3> points, std::span<double> values) const {
  if (points.size() != values.size()) throw std::invalid_argument("winding number batch size mismatch");
  parallel_for(points.size(), [&](std::size_t i) { values[i] = at(points[i]); });
}

void apply_winding_sign(const WindingNumber& winding, std::span<const Vec3> points, std::span<double> values) {
  if (points.size() != values.size()) throw std::invalid_argument("winding sign batch size mismatch");
  if (winding.constant_off_surface()) {
    apply_winding_sign(winding, points, morton_order(points), values);
    return;
  }
  parallel_for(points.size(), [&](std::size_t i) {
    const double v = values[i];
    if (v == 0) return;
    values[i] = winding.inside(points[i]) ? std::abs(v) : -std::abs(v);
  });
}

std::size_t apply_winding_sign(const WindingNumber& winding, std::span<const Vec3> points,
                               std::span<const uint32_t> order, std::span<double> values) {
  if (points.size() != values.size() || order.size() != points.size())
    throw std::invalid_argument("winding sign batch size mismatch");
  const bool inherit = winding.constant_off_surface();
  // A ball's radius is a computed distance: shrunk by far more than its rounding (and than a
  // device's float distance refined on the host would differ by), so that two balls taken to
  // overlap truly do and neither truly reaches the surface.
  constexpr double kShrink = 1 - 1e-6;
  // The first point of a chunk has nothing to inherit from; 1024 keeps that to a few per mille.
  constexpr std::size_t kChunk = 1024;
  // One chunk of the order, on one thread; returns its queries.
  auto sign_chunk = [&](std::size_t c) {
    std::size_t queries = 0;
    // The points to inherit from: the last kRecent ones (neighbours along the curve, which
    // doubles back on itself every few points) and the one farthest from the surface seen in the
    // chunk (far from the surface its ball covers runs of points). p takes q's side when the open
    // balls of radius |f| about p and q, which hold no point of the surface, overlap: their union
    // is connected and holds the segment pq, so p and q lie in one component of the complement.
    // Near the surface, where the octree samples, a point is rarely inside a neighbour's ball but
    // the two balls often overlap. Queries at the deepest level of the bumpy torus's fitted
    // octree (577,796 points): 218,810 when p had to lie in the previous point's ball, 116,708
    // with overlapping balls, 72,734 / 53,917 / 43,927 looking back over 8 / 32 / 64 points; the
    // octree stage 1.40 -> 0.57 s, the whole default run 3.64 -> 2.44 s, the mesh the same bytes.
    constexpr int kRecent = 64;
    Vec3 recent[kRecent]{}, big{};
    double recent_f[kRecent]{}, big_f = 0;
    int next = 0;
    auto within = [](Vec3 p, double d, Vec3 q, double f) {
      return f != 0 && std::isfinite(f) && std::isfinite(d) && norm(p - q) < (d + std::abs(f)) * kShrink;
    };
    for (std::size_t k = c * kChunk; k < std::min(points.size(), (c + 1) * kChunk); ++k) {
      const uint32_t i = order[k];
      const Vec3 p = points[i];
      const double d = std::abs(values[i]);
      if (d == 0) {
        values[i] = 0;
        continue;
      }
      int from = -1;  // 0 .. kRecent - 1: a recent point; kRecent: the big one
      if (inherit) {
        for (int r = 1; r <= kRecent && from < 0; ++r) {
          const int j = (next - r + kRecent) % kRecent;  // the most recent first
          if (within(p, d, recent[j], recent_f[j])) from = j;
        }
        if (from < 0 && within(p, d, big, big_f)) from = kRecent;
      }
      bool in;
      if (from >= 0) {
        in = (from == kRecent ? big_f : recent_f[from]) > 0;
      } else {
        in = winding.inside(p);
        ++queries;
      }
      values[i] = in ? d : -d;
      recent[next] = p, recent_f[next] = values[i];
      next = (next + 1) % kRecent;
      if (!(d <= std::abs(big_f))) big = p, big_f = values[i];
    }
    return queries;
  };
  return parallel_reduce((points.size() + kChunk - 1) / kChunk, 1, std::size_t(0),
                         [&](std::size_t cb, std::size_t ce, std::size_t queries) {
                           for (std::size_t c = cb; c < ce; ++c) queries += sign_chunk(c);
                           return queries;
                         },
                         std::plus<>());
}

}  // namespace mchex
