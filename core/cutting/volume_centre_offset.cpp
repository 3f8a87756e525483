// Volume-centre offsets (paper Section 5, Eq. 14); see volume_centre_offset.h.
#include "core/cutting/volume_centre_offset.h"

#include <cmath>

namespace mchex {
namespace {

// The polyhedron of corners {0,1,5,6} of case 11's representative (kSubcaseInfo: positive
// corners 0x63), cut on Table-1 edges 2, 3, 4, 7, 9, 12 (0-based 1, 2, 3, 6, 8, 11). The
// coefficients are the output of OffsetSearchFindsTheBuiltInRule (tests/test_volume_centre_offset.cpp)
// rounded to 5 decimals; the certificate tests check the rounded numbers.
constexpr VolumeCentreOffsetRule kRule = {
    {Subcase::k11, Subcase::k14},
    0x63,
    {1, 2, 3, 6, 8, 11},
    {{
        {+0.09602, +0.03023, +0.02135, +0.01688, +0.02218, +0.07446, -0.02003},
        {-0.09667, -0.01994, +0.02195, +0.07352, +0.02157, +0.01759, +0.02999},
        {-0.00006, +0.01262, +0.00236, -0.03368, +0.00250, -0.03332, +0.01236},
    }},
};

Vec3 corner_parameter(int i) {
  return {double(kCubeCorners[i][0]), double(kCubeCorners[i][1]), double(kCubeCorners[i][2])};
}

std::uint8_t image_of(std::uint8_t corners, const CubeSymmetry& g) {
  std::uint8_t out = 0;
  for (int i = 0; i < 8; ++i)
    if (corners >> i & 1) out |= static_cast<std::uint8_t>(1u << g.corner[i]);
  return out;
}

}  // namespace

const VolumeCentreOffsetRule& volume_centre_offset_rule() { return kRule; }

Vec3 cell_point_parameter(CellPointKey k, const CellClass& c) {
  if (is_corner_key(k)) return corner_parameter(k);
  const int e = key_edge(k);
  const double s = c.crossing[e];
  return (1 - s) * corner_parameter(kCubeEdges[e][0]) + s * corner_parameter(kCubeEdges[e][1]);
}

Vec3 trilinear_point(const std::array<Vec3, 8>& corners, const Vec3& u) {
  Vec3 x{};
  for (int c = 0; c < 8; ++c) {
    double w = 1;
    for (int i = 0; i < 3; ++i) w *= kCubeCorners[c][i] ? u[i] : 1 - u[i];
    x += w * corners[c];
  }
  return x;
}

Vec3 parametric_volume_centre(const Polyhedron& p, const CellClass& c) {
  Vec3 sum{};
  for (CellPointKey k : p.keys) sum += cell_point_parameter(k, c);
  return sum / static_cast<double>(p.keys.size());
}

Vec3 rule_offset(const VolumeCentreOffsetRule& rule, const std::array<double, 12>& s) {
  Vec3 v{};
  for (int i = 0; i < 3; ++i) {
    double x = rule.coefficients[i][0];
    for (int j = 0; j < 6; ++j) x += rule.coefficients[i][1 + j] * (s[rule.edges[j]] - 0.5);
    v[i] = x;
  }
  return v;
}

Vec3 offset_to_cell(const Vec3& v, int symmetry) {
  // The symmetry maps a cell point p to p'[i] = p[axis[i]] (or 1 - p[axis[i]] where bit i of
  // flip is set), so a displacement d of the cell becomes d'[i] = +-d[axis[i]]; invert that.
  const CubeSymmetry& g = kCubeSymmetries[symmetry];
  Vec3 d{};
  for (int i = 0; i < 3; ++i) d[g.axis[i]] = (g.flip >> i & 1) ? -v[i] : v[i];
  return d;
}

std::optional<Vec3> volume_centre_offset(const CellClass& c, std::uint8_t region_corners) {
  const VolumeCentreOffsetRule& rule = kRule;
  if (c.subcase != rule.subcases[0] && c.subcase != rule.subcases[1]) return std::nullopt;
  // The first symmetry (rotations first) that carries the region onto the rule's: the cell's
  // crossings move with it (an edge whose direction reverses takes 1 - s), the offset comes back.
  for (int h = 0; h < kNumCubeSymmetries; ++h) {
    const CubeSymmetry& g = kCubeSymmetries[h];
    if (image_of(region_corners, g) != rule.region_corners) continue;
    std::array<double, 12> s{};
    for (int e = 0; e < 12; ++e) {
      const double x = c.crossing[e];
      s[g.edge[e]] = (g.edge_reversed >> e & 1) ? 1 - x : x;
    }
    return offset_to_cell(rule_offset(rule, s), h);
  }
  return std::nullopt;  // a region that is not an image of the rule's (the other regions' sizes)
}

CellShape cell_shape(const std::array<Vec3, 8>& x) {
  // X(u) = sum_c w_c(u) x_c; its coefficients of u0 u1, u0 u2, u1 u2 and u0 u1 u2 (Eq. 8).
  const Vec3 k01 = x[0] - x[1] + x[2] - x[3];
  const Vec3 k02 = x[0] - x[1] - x[4] + x[5];
  const Vec3 k12 = x[0] - x[3] - x[4] + x[7];
  const Vec3 k012 = x[1] - x[0] - x[2] + x[3] + x[4] - x[5] + x[6] - x[7];
  double size = 0;
  for (const auto& e : kCubeEdges) size = std::max(size, norm(x[e[1]] - x[e[0]]));
  const double tol = 1e-9 * size;
  for (const Vec3& k : {k01, k02, k12, k012})
    if (!(norm(k) <= tol)) return CellShape::kGeneral;
  return CellShape::kAffine;
}

}  // namespace mchex
