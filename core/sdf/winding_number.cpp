#include "core/sdf/winding_number.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "core/base/parallel.h"

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

}  // namespace

double triangle_winding_number(Vec3 p, Vec3 a, Vec3 b, Vec3 c) { return solid_angle_over_4pi(p, a, b, c); }

double winding_number_exact(const TriangleSurface& s, Vec3 p) {
  double w = 0;
  for (const auto& t : s.triangles) w += solid_angle_over_4pi(p, s.vertices[t[0]], s.vertices[t[1]], s.vertices[t[2]]);
  return w;
}

WindingNumber::WindingNumber(const TriangleSurface& surface) { build(surface, TriangleBvh::build(surface)); }
WindingNumber::WindingNumber(const TriangleSurface& surface, const TriangleBvh& bvh) { build(surface, bvh); }

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
    node.area = 0;
    node.normal = {};
    for (auto& row : node.moment)
      for (double& m : row) m = 0;
    for (std::size_t k = first; k < last; ++k) {
      const Vec3 a = corners_[3 * k], b = corners_[3 * k + 1], c = corners_[3 * k + 2];
      for (Vec3 v : {a, b, c}) node.radius = std::max(node.radius, norm(v - node.centre));
      const Vec3 av = 0.5 * cross(b - a, c - a);
      const Vec3 g = (1.0 / 3) * (a + b + c) - node.centre;
      node.area += norm(av);
      node.normal += av;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) node.moment[i][j] += av[i] * g[j];
    }
    // Rounding of the corners' distances: a hair more keeps the ball around every corner.
    node.radius *= 1 + 1e-12;
  });
}

WindingNumber::Estimate WindingNumber::estimate(Vec3 p, double beta) const {
  Estimate e{0, 0};
  if (nodes_.empty()) return e;
  uint32_t stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
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
      e.value += (dot(u, node.normal) + (trace - 3 * uMu) / d) / d2 * kInv4Pi;
      const double q = node.radius / d, r = 1 - q;
      const double taylor = 3 / (r * r * r * r);
      const double legendre = (2 - q) / (r * r) + 1.5 / r;
      e.bound += node.area / d2 * q * q * std::min(taylor, legendre) * kInv4Pi;
      continue;
    }
    if (node.count) {
      for (uint32_t k = node.index; k < node.index + node.count; ++k)
        e.value += solid_angle_over_4pi(p, corners_[3 * k], corners_[3 * k + 1], corners_[3 * k + 2]);
      continue;
    }
    // Left child (the next node) popped first, so the sum's order is the hierarchy's.
    if (top + 2 > 128) throw std::logic_error("winding number hierarchy deeper than its stack");
    stack[top++] = node.index;
    stack[top++] = uint32_t(&node - nodes_.data()) + 1;
  }
  return e;
}

double WindingNumber::at(Vec3 p) const {
  double beta = kBeta;
  for (int pass = 0; pass < kPasses; ++pass, beta *= 2) {
    const Estimate e = estimate(p, beta);
    if (std::abs(e.value - 0.5) > e.bound + kRoundingAllowance) return e.value;
  }
  return estimate(p, std::numeric_limits<double>::infinity()).value;
}

void WindingNumber::at(std::span<const Vec3> points, std::span<double> values) const {
  if (points.size() != values.size()) throw std::invalid_argument("winding number batch size mismatch");
  parallel_for(points.size(), [&](std::size_t i) { values[i] = at(points[i]); });
}

void apply_winding_sign(const WindingNumber& winding, std::span<const Vec3> points, std::span<double> values) {
  if (points.size() != values.size()) throw std::invalid_argument("winding sign batch size mismatch");
  parallel_for(points.size(), [&](std::size_t i) {
    const double v = values[i];
    if (v == 0) return;
    values[i] = winding.inside(points[i]) ? std::abs(v) : -std::abs(v);
  });
}

}  // namespace mchex
