// Element quality of one trilinear hexahedron, given its 8 corners in VTK_HEXAHEDRON order,
// which is the node order of the paper's Eq. 8:
//   0 (0,0,0)  1 (1,0,0)  2 (1,1,0)  3 (0,1,0)  4 (0,0,1)  5 (1,0,1)  6 (1,1,1)  7 (0,1,1)
// in reference coordinates (xi, eta, zeta) in [0,1]^3.
//
// The map x(xi,eta,zeta) = X N(xi,eta,zeta) (Eq. 7-8) is trilinear, so each column of its
// Jacobian J (Eq. 9) is bilinear in the two other coordinates and det J is a tensor
// polynomial of degree (2,2,2). Two families of measures follow:
//  - the certificate: the 27 Bernstein coefficients of det J (Theorem 5.1 / Eq. 10 gives them
//    from the monomial form; we build them directly from products of edge vectors, see
//    quality.cpp). All 27 > 0 proves det J > 0 on the whole closed element.
//  - the customary sampled measures (ParaView/Verdict): scaled Jacobian at the 8 corners and
//    the centre, edge ratio, dihedral angles and the inverse condition number at the corners.
//    These can be positive on an element whose det J is negative somewhere inside; the tests
//    construct such an element. docs/quality.md defines each one.
#pragma once

#include <array>
#include <cstddef>

#include "core/base/geometry.h"

namespace mchex {

using HexCorners = std::array<Vec3, 8>;

// The 27 Bernstein coefficients beta_{ijk}, i, j, k in {0,1,2} indexing (xi, eta, zeta).
using BernsteinCoefficients = std::array<double, 27>;
constexpr int bernstein_index(int i, int j, int k) { return i + 3 * j + 9 * k; }

// The element map (paper Eq. 7, shape functions Eq. 8): the point of the hex with corners c at
// parametric point t in the unit cube. Every cell of a complex is this map of the unit cube.
// Nested linear interpolation (x, then y, then z) by exact_lerp, so a point on a cell face whose
// corners share a coordinate (a face on the box) keeps it exactly, whatever the other corners.
inline Vec3 trilinear_map(const HexCorners& c, Vec3 t) {
  auto lerp = [](const Vec3& a, const Vec3& b, double s) {
    return Vec3{exact_lerp(a.x, b.x, s), exact_lerp(a.y, b.y, s), exact_lerp(a.z, b.z, s)};
  };
  const Vec3 y0 = lerp(lerp(c[0], c[1], t.x), lerp(c[3], c[2], t.x), t.y);
  const Vec3 y1 = lerp(lerp(c[4], c[5], t.x), lerp(c[7], c[6], t.x), t.y);
  return lerp(y0, y1, t.z);
}

// The unit cube itself, corners in VTK order.
inline constexpr HexCorners kUnitCubeCorners = {
    {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}}};

// Columns of J (Eq. 9): dx/dxi, dx/deta, dx/dzeta at (xi, eta, zeta).
std::array<Vec3, 3> jacobian(const HexCorners& c, double xi, double eta, double zeta);
double jacobian_determinant(const HexCorners& c, double xi, double eta, double zeta);

// det J = sum_{ijk} beta_{ijk} B_i^2(xi) B_j^2(eta) B_k^2(zeta), with B_i^2 the quadratic
// Bernstein basis. beta at i,j,k in {0,2} are the corner values of det J.
BernsteinCoefficients bernstein_jacobian(const HexCorners& c);
// True when every beta > 0, which proves det J > 0 everywhere on [0,1]^3 (see quality.cpp
// for why this is strict and not the paper's min >= 0 && max > 0).
bool bernstein_certified(const HexCorners& c);
double min_bernstein(const HexCorners& c);
// min beta / (mean edge length)^3: beta has units of volume, so this ratio is comparable
// across element sizes (1 for a unit cube, det A / (mean |A e_i|)^3 for an affine element).
double min_bernstein_scaled(const HexCorners& c);

// Mean of the 12 edge lengths.
double mean_edge_length(const HexCorners& c);
// bernstein_jacobian(c), and mean_edge_length(c) in `mean_length`, from one pass over the edges:
// the same doubles as the two calls, for callers that check millions of hexes (certify).
BernsteinCoefficients bernstein_jacobian(const HexCorners& c, double& mean_length);
// max / min of the 12 edge lengths; +inf when an edge has zero length.
double edge_ratio(const HexCorners& c);
// Exact volume of the trilinear element: the integral of det J over [0,1]^3.
double hex_volume(const HexCorners& c);

// det J at the 8 corners, in corner order: the triple product of the three edge vectors
// leaving each corner in the +xi, +eta, +zeta directions (not normalized).
std::array<double, 8> corner_jacobians(const HexCorners& c);
// Scaled Jacobian at the 9 points: [0..7] the corners in corner order, [8] the centre. Each is
// det of J's columns normalized to unit length, so a cube (of any size) gives 1, and an edge
// of zero length gives 0.
std::array<double, 9> scaled_jacobians(const HexCorners& c);
double scaled_jacobian(const HexCorners& c);  // min of scaled_jacobians

// scaled_jacobians and edge_ratio of a hex while one of its corners moves, for a caller that
// tries many positions of one vertex (the optimiser, core/optimize/optimize.cpp). Of the 9 points
// only the moving corner, its 3 edge neighbours and the centre depend on its position (each of the
// other 4 corners' Jacobian columns are edges that do not touch it); the 9 edges that do not touch
// it, those 4 values, the centre's half sums of the fixed edges and the extremes of the 9 fixed
// lengths are computed once here. A position then costs its 3 edges, 6 normalisations and 5
// triple products, done by the same operations on the same doubles as scaled_jacobians and
// edge_ratio: the results are bit for bit theirs (tests: quality.MovingCornerIsBitIdentical).
class MovingCorner {
 public:
  MovingCorner() = default;
  MovingCorner(const HexCorners& c, int corner);
  // scaled_jacobians(c) with c[corner] = y into `s`; false as soon as one of the 9 is below
  // `floor` (the values are finite for finite corners, so then so is their minimum), `s` unfinished.
  bool scaled_jacobians(Vec3 y, double floor, std::array<double, 9>& s) const;
  // The least of those 9, as scaled_jacobian(c) has it; -infinity when it is below `floor`.
  double scaled_jacobian(Vec3 y, double floor) const;
  // edge_ratio(c) with c[corner] = y.
  double edge_ratio(Vec3 y) const;

 private:
  int a_ = 0, b_ = 0, c_ = 0;  // reference coordinates of the corner
  Vec3 end_[3];                // the far ends of its xi, eta and zeta edges
  // Unit fixed edges of its neighbours along xi, eta, zeta: the two columns that do not touch it,
  // in the order (xi, eta, zeta) with the moving one left out.
  Vec3 neighbour_[3][2];
  Vec3 xi_cross_;  // cross(neighbour_[0][0], neighbour_[0][1])
  // Per direction, the centre's column is the bilinear mean (0.5, 0.5) of the 4 edges: half the
  // edge paired with the moving one, and half the mean of the other pair.
  Vec3 half_partner_[3], half_other_[3];
  std::array<double, 9> fixed_{};                // the 4 fixed corners' values in place (the others unset)
  double fixed_min_ = 0, short_ = 0, long_ = 0;  // min of those 4; shortest and longest fixed edge
};

// Dihedral angles in degrees, [3 * corner + d] for the edge leaving `corner` along reference axis
// d (0 xi, 1 eta, 2 zeta): the interior angle between the two faces of the hex at that edge,
// from the faces' normals at the corner (each the cross product of the face's two edges there).
// In [0, 360): below 180 where det J > 0 at the corner, above 180 where it is negative; 0 for a
// zero-length edge. Each edge has two values, one at each end (equal where its faces are planar).
std::array<double, 24> dihedral_angles(const HexCorners& c);
// 1 / kappa(J) at the 8 corners, kappa = |J|_F |J^-1|_F / 3 (Knupp's condition number) with J the
// three edge vectors leaving the corner: in (0, 1] where det J > 0 (1 for a cube), its sign, and 0
// where det J = 0.
std::array<double, 8> inverse_conditions(const HexCorners& c);
double inverse_condition(const HexCorners& c);  // min of inverse_conditions

// Everything above that a mesh check needs, computed once per element.
struct HexQuality {
  double min_corner_jacobian = 0;  // min over the 8 corners of det J
  double min_bernstein = 0;
  double min_bernstein_scaled = 0;
  double scaled_jacobian = 0;  // min over the 9 points
  double edge_ratio = 0;
  double min_dihedral_angle = 0;  // degrees, min and max of dihedral_angles
  double max_dihedral_angle = 0;
  double inverse_condition = 0;  // min of inverse_conditions
  double volume = 0;
  bool certified() const { return min_bernstein > 0; }
};
HexQuality hex_quality(const HexCorners& c);
// Whether the four edges of each direction are the same vector, bit for bit (then hex_quality
// computes each product of edge vectors once: the same results, for less work).
bool is_parallelepiped(const HexCorners& c);

// hex_quality for a caller that measures millions of hexes (the mesh check). A parallelepiped's
// quality is a function of its three edge vectors alone, bit for bit (every product hex_quality
// forms is of those doubles), and a mesh has few of them: the 3.97 M outside hexes of the bumpy
// torus at depth 4 have 96,220 distinct triples, and in the mesher's order a table of 512 slots
// holds 97 % of the triples asked for (simulated on that mesh). So this keeps the quality of the
// last parallelepiped per slot and answers from it when all nine doubles match: the value
// hex_quality would compute (tests: quality.CachedQualityIsBitIdentical). The check of that mesh
// pair took 0.80-1.00 s with it, 0.99-1.35 s without (alternating runs). Not shared between
// threads; one per thread keeps the results independent of the thread count.
class QualityCache {
 public:
  HexQuality operator()(const HexCorners& c);
  std::size_t hits() const { return hits_; }  // answers from the table so far

 private:
  static constexpr int kSlotBits = 9, kSlots = 1 << kSlotBits;
  struct Slot {
    std::array<double, 9> key;  // the xi, eta and zeta edges
    HexQuality quality;
    bool used = false;
  };
  std::array<Slot, kSlots> slots_;
  std::size_t hits_ = 0;
};

namespace detail {
// hex_quality computing every product of edge vectors, also where a parallelepiped's are equal
// (for the test that the shortcut changes no bit).
HexQuality hex_quality_without_shortcuts(const HexCorners& c);
// Whether hex_quality takes its axis-aligned box path for these corners (for the test that the
// path changes no bit and is taken where it should be).
bool takes_axis_box_path(const HexCorners& c);
}  // namespace detail

}  // namespace mchex
