// The generalized winding number of a triangle surface (Jacobson, Kavan & Sorkine-Hornung,
// "Robust inside-outside segmentation using generalized winding numbers", 2013, eq. 4):
// w(p) = sum over triangles of the signed solid angle at p / (4 pi), each solid angle by Van
// Oosterom & Strackee's formula. For a closed, consistently outward-oriented surface w is 1
// inside and 0 outside; on open surfaces, soups, folded or inconsistently oriented input it
// degrades gracefully, and "inside" is w > 1/2 (Jacobson et al., section 3). That is the robust
// sign of the signed distance (core/sdf/sdf.h, SignRule::kWindingNumber), where the closest
// feature's pseudonormal is wrong.
//
// Evaluated fast over a tree (Barill, Dickson, Schmidt, Levin & Jacobson, "Fast winding numbers
// for soups and clouds", 2018, section 3.2): a node of the BVH (core/sdf/bvh.h) whose triangles
// lie within radius R of its centre c is "far" from p when d = |c - p| > beta * R, and then
// contributes its Taylor expansion about c to second order (the area-weighted normal sum N, a
// dipole, and the first moment M = sum_t a_t (g_t - c)^T with a_t the area vector and g_t the
// centroid of triangle t) instead of its triangles' exact solid angles. The tree is built over
// the triangles with those longer than a 64th of the box's diagonal bisected (the solid angles
// add up; a long sliver is otherwise near every point along it and summed exactly everywhere).
//
// Error bound of a far node (stated here, checked by tests/test_winding_number.cpp): with
// I = sum_t int_t |x - c|^2 dA the node's second moment of area about c (at most A R^2) and
// q = R / d < 1, the far field errs from the node's exact winding number by at most
//   eps = I / (4 pi d^4) * min(3 / (1 - q)^4,  (3.5 - 2.5 q) / (1 - q)^2).
// The first is the Taylor remainder of the integrand (x - p) / |x - p|^3 about c, whose second
// derivative has norm 6 / |x - p|^4 <= 6 / (d - R)^4 on the node. The second comes from the
// Legendre expansion 1/|x - p| = sum_l |h|^l / d^(l+1) P_l (h = x - c): the gradient of its
// degree-l term is at most sqrt(l (l + 1)) |h|^(l-1) / d^(l+1) (from P_l^2 + (1 - x^2) P_l'^2 /
// (l (l + 1)) <= 1), and int |h|^(l-1) dA <= R^(l-3) I, summed over the dropped degrees l >= 3
// with sqrt(l (l + 1)) <= l + 1/2. Weighting by I rather than by A R^2 made queries 3.3x faster
// on the 52k torus: at beta = 2 the first pass decides 78 % of a grid's points over its box.
//
// Guarantee: the inside/outside decision never rests on the approximation. A query sums the
// bounds of the far nodes it used; while |w_approx - 1/2| is within that sum (plus a rounding
// allowance, kRoundingAllowance) the far nodes whose bounds exceed an equal share of the margin
// are replaced by their children (deeper descent; a leaf by its exact solid angles), until the
// sum decides or nothing is far. So inside(p) equals the exact test w(p) > 1/2 except for points whose exact w is
// within rounding of 1/2. Each point is computed alone, in an order that depends on it alone: deterministic on any
// thread count.
#pragma once

#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "core/base/geometry.h"
#include "core/mesh/surface.h"
#include "core/sdf/bvh.h"

namespace mchex {

class WindingNumber {
 public:
  // Far-node criterion d > kBeta * R (Barill et al. use 2).
  static constexpr double kBeta = 2.0;
  // What the exact sums may err by through rounding (the solid angles err by a few ulps each).
  static constexpr double kRoundingAllowance = 1e-9;

  // What inside() decides. kHalf: w > 1/2 (Jacobson et al.). kParity: the nearest integer to w
  // is odd, the inside of several closed shells taken together as an arrangement (core/pipeline/
  // regions.h): crossing any one shell, whichever way it faces, flips the parity, so the parity
  // field's zero set is every shell at once. at() is then exact enough to lie between the same
  // two half-integers as the exact value.
  enum class Decision { kHalf, kParity };

  explicit WindingNumber(const TriangleSurface& surface, Decision decision = Decision::kHalf);
  // Shares a hierarchy that was built for the surface (SurfaceSdf has one), unless the surface
  // has triangles to bisect.
  WindingNumber(const TriangleSurface& surface, const TriangleBvh& bvh, Decision decision = Decision::kHalf);

  // w(p), accurate enough to lie on the same side of 1/2 (kParity: of every half-integer) as the
  // exact value (but within rounding of it): its error is below that distance, not small in itself.
  double at(Vec3 p) const;
  bool inside(Vec3 p) const { return decides_inside(at(p)); }
  // Whether the surface is a 2-cycle: every edge is used as often from a to b as from b to a
  // (closed and consistently oriented, shells nested or touching included). Then w is an integer
  // off the surface and constant on each component of its complement, so a point within distance
  // |f(q)| of a point q is on q's side (sign_by_winding relies on it). On open surfaces, soups and
  // inconsistently oriented input w varies continuously off the surface and this is false.
  bool constant_off_surface() const { return constant_off_surface_; }
  bool decides_inside(double w) const { return decision_ == Decision::kHalf ? w > 0.5 : std::llround(w) % 2 != 0; }
  Decision decision() const { return decision_; }
  // Batch at(); threaded, deterministic.
  void at(std::span<const Vec3> points, std::span<double> values) const;

  // One pass at a given beta (infinity: exact), for tests and benchmarks: the value and the sum
  // of the far nodes' error bounds, |value - w(p)| <= bound (up to rounding).
  struct Estimate {
    double value;
    double bound;
  };
  Estimate estimate(Vec3 p, double beta) const;

 private:
  struct Node {
    Vec3 centre;
    double radius;         // of a ball about centre that holds the node's triangles
    double second_moment;  // I = sum_t int_t |x - centre|^2 dA
    Vec3 normal;           // sum of the area vectors (half the edge cross products)
    double moment[3][3];   // sum_t a_t[i] (g_t - centre)[j]
    uint32_t index;        // inner: right child; leaf: first slot
    uint32_t count;        // leaf: triangles; 0 for an inner node
  };
  void build(const TriangleSurface& surface, const TriangleBvh& bvh);
  // Sums the exact solid angles of the near leaves under `root` and hands each far node to
  // far(node, value, bound).
  template <class Far>
  double descend(uint32_t root, Vec3 p, double beta, Far&& far) const;

  std::vector<Node> nodes_;
  Decision decision_ = Decision::kHalf;
  bool constant_off_surface_ = false;
  std::vector<Vec3> corners_;  // three per leaf slot, in the hierarchy's order
};

// The definition, every triangle in index order: the reference of the tests. O(triangles). A
// triangle's share is its signed solid angle over 4 pi (Van Oosterom & Strackee, "The solid
// angle of a plane triangle", 1983), positive where p sees its back (the side its normal
// (b - a) x (c - a) points away from).
double winding_number_exact(const TriangleSurface& surface, Vec3 p);

// Re-signs a batch of signed (or unsigned) distances computed by any backend with the winding
// number's decision: values[i] becomes +|v| where inside(points[i]), -|v| elsewhere; 0 stays 0.
// A device backend keeps its pseudonormal kernel and the host decides the sign, so every backend
// gives the same field. |values[i]| must be the distance from points[i] to the surface.
void apply_winding_sign(const WindingNumber& winding, std::span<const Vec3> points, std::span<double> values);
// The same, visiting the points in `order` (a permutation of their indices, best a Morton order:
// core/sdf/sdf.h morton_order). Where the winding number is constant off the surface, a point
// whose surface-free ball (radius |f|) overlaps that of one of the 64 points just before it in its
// chunk, or of the chunk's point farthest from the surface so far, takes that point's sign
// without a winding-number query: the union of the two open balls is connected and misses the
// surface. Most grid points are decided so, near the surface too
// (the winding number was 40 % of a default run). The answer is the winding number's own, point for point, on any
// thread count. Returns how many points needed a query (for the tests; every nonzero one without the property).
std::size_t apply_winding_sign(const WindingNumber& winding, std::span<const Vec3> points,
                               std::span<const uint32_t> order, std::span<double> values);

}  // namespace mchex
