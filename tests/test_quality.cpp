// Element quality of one trilinear hex (core/mesh/quality.h): the Bernstein certificate of det J
// (paper Section 5, Eq. 7-10), the 9-point scaled Jacobian, edge ratio and exact volume.
// References here are independent of the library's formulas: det J sampled from the Jacobian
// columns, the Bernstein polynomial summed from its basis, coefficients rebuilt from values at
// {0, 1/2, 1}^3, volumes by Gauss and midpoint quadrature, and closed forms for affine hexes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include "core/mesh/quality.h"

namespace mchex {
namespace {

const HexCorners kUnitCube = {{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}}};

// Reference coordinates of each corner (paper Eq. 8 order).
Vec3 reference_corner(int i) { return kUnitCube[i]; }

HexCorners map_corners(const HexCorners& c, auto&& f) {
  HexCorners out;
  for (int i = 0; i < 8; ++i) out[i] = f(c[i]);
  return out;
}

struct Affine {
  Vec3 col[3];  // A's columns
  Vec3 b;
  Vec3 operator()(Vec3 p) const { return p.x * col[0] + p.y * col[1] + p.z * col[2] + b; }
  double det() const { return triple(col[0], col[1], col[2]); }
};

// A random affine map with det A > 0. Integer entries keep every product exact in doubles.
Affine random_affine(std::mt19937_64& rng, bool integer) {
  std::uniform_int_distribution<int> small(-3, 3);
  std::uniform_real_distribution<double> real(-2.0, 2.0);
  auto draw = [&] { return integer ? static_cast<double>(small(rng)) : real(rng); };
  while (true) {
    Affine a{{{draw(), draw(), draw()}, {draw(), draw(), draw()}, {draw(), draw(), draw()}}, {draw(), draw(), draw()}};
    const double d = a.det();
    if (d > 0.1) return a;
    if (d < -0.1) {  // flip one column to make it positive
      a.col[0] = -a.col[0];
      return a;
    }
  }
}

// The unit cube with each corner moved by up to `amount` in each coordinate.
HexCorners random_hex(std::mt19937_64& rng, double amount) {
  std::uniform_real_distribution<double> d(-amount, amount);
  return map_corners(kUnitCube, [&](Vec3 p) { return p + Vec3{d(rng), d(rng), d(rng)}; });
}

double bernstein2(int i, double t) { return i == 0 ? (1 - t) * (1 - t) : (i == 1 ? 2 * t * (1 - t) : t * t); }

// sum beta_ijk B_i(xi) B_j(eta) B_k(zeta), written out here rather than taken from the library.
double evaluate_bernstein(const BernsteinCoefficients& beta, double xi, double eta, double zeta) {
  double sum = 0;
  for (int k = 0; k < 3; ++k) {
    for (int j = 0; j < 3; ++j) {
      for (int i = 0; i < 3; ++i) {
        sum += beta[i + 3 * j + 9 * k] * bernstein2(i, xi) * bernstein2(j, eta) * bernstein2(k, zeta);
      }
    }
  }
  return sum;
}

// Coefficients from det J at {0, 1/2, 1}^3: per axis a quadratic with values p0, pm, p1 has
// Bernstein coefficients p0, 2 pm - (p0 + p1) / 2, p1 (since p(1/2) = (b0 + 2 b1 + b2) / 4).
BernsteinCoefficients coefficients_from_values(const HexCorners& c) {
  double v[3][3][3];  // [k][j][i]
  for (int k = 0; k < 3; ++k) {
    for (int j = 0; j < 3; ++j) {
      for (int i = 0; i < 3; ++i) v[k][j][i] = jacobian_determinant(c, i / 2.0, j / 2.0, k / 2.0);
    }
  }
  auto convert = [](double& p0, double& pm, double& p1) { pm = 2 * pm - (p0 + p1) / 2; };
  for (int k = 0; k < 3; ++k) {
    for (int j = 0; j < 3; ++j) convert(v[k][j][0], v[k][j][1], v[k][j][2]);
  }
  for (int k = 0; k < 3; ++k) {
    for (int i = 0; i < 3; ++i) convert(v[k][0][i], v[k][1][i], v[k][2][i]);
  }
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 3; ++i) convert(v[0][j][i], v[1][j][i], v[2][j][i]);
  }
  BernsteinCoefficients beta{};
  for (int k = 0; k < 3; ++k) {
    for (int j = 0; j < 3; ++j) {
      for (int i = 0; i < 3; ++i) beta[bernstein_index(i, j, k)] = v[k][j][i];
    }
  }
  return beta;
}

double sampled_min_det(const HexCorners& c, int n) {
  double m = std::numeric_limits<double>::infinity();
  for (int k = 0; k <= n; ++k) {
    for (int j = 0; j <= n; ++j) {
      for (int i = 0; i <= n; ++i) {
        m = std::min(m, jacobian_determinant(c, double(i) / n, double(j) / n, double(k) / n));
      }
    }
  }
  return m;
}

// Swapping the bottom and top faces mirrors zeta -> 1 - zeta.
HexCorners mirrored(const HexCorners& c) {
  HexCorners m;
  for (int i = 0; i < 4; ++i) {
    m[i] = c[i + 4];
    m[i + 4] = c[i];
  }
  return m;
}

// A point of a cell face whose four corners share a coordinate keeps it exactly, whatever the
// other four corners: subdivision points on the box stay on the box when repel moves the corners
// inside it. Every face of random cells, at random parameters and at the subdivision's 0, 1/3,
// 1/2, 2/3, 1; and exact_lerp's ends.
TEST(quality, TrilinearMapKeepsAFacesSharedCoordinate) {
  std::mt19937_64 rng(20261205);
  std::uniform_real_distribution<double> coord(-3.7, 2.9), param(0.0, 1.0);
  const double fixed[] = {0.0, 1.0 / 3, 0.5, 2.0 / 3, 1.0};
  int points = 0;
  for (int trial = 0; trial < 200; ++trial) {
    for (int axis = 0; axis < 3; ++axis) {
      for (int side = 0; side < 2; ++side) {
        HexCorners c;
        for (Vec3& p : c) p = {coord(rng), coord(rng), coord(rng)};
        const double plane = coord(rng);
        for (int i = 0; i < 8; ++i)
          if (static_cast<int>(reference_corner(i)[axis]) == side) c[i][axis] = plane;
        for (int k = 0; k < 40; ++k) {
          Vec3 t{k < 25 ? fixed[k % 5] : param(rng), k < 25 ? fixed[k / 5] : param(rng), 0};
          std::swap(t[axis], t[2]);  // the two free parameters on the face's axes
          t[axis] = side;
          ASSERT_EQ(trilinear_map(c, t)[axis], plane) << trial << " axis " << axis << " side " << side;
          ++points;
        }
      }
    }
  }
  EXPECT_EQ(points, 200 * 6 * 40);
  for (int trial = 0; trial < 1000; ++trial) {
    const double a = coord(rng), b = coord(rng), s = param(rng);
    ASSERT_EQ(exact_lerp(a, b, 0.0), a);
    ASSERT_EQ(exact_lerp(a, b, 1.0), b);
    ASSERT_EQ(exact_lerp(a, a, s), a);
  }
}

TEST(quality, UnitCube) {
  const BernsteinCoefficients beta = bernstein_jacobian(kUnitCube);
  for (double b : beta) EXPECT_EQ(b, 1.0);
  EXPECT_TRUE(bernstein_certified(kUnitCube));
  EXPECT_EQ(min_bernstein(kUnitCube), 1.0);
  EXPECT_EQ(min_bernstein_scaled(kUnitCube), 1.0);
  for (double s : scaled_jacobians(kUnitCube)) EXPECT_EQ(s, 1.0);
  EXPECT_EQ(scaled_jacobian(kUnitCube), 1.0);
  for (double d : corner_jacobians(kUnitCube)) EXPECT_EQ(d, 1.0);
  EXPECT_EQ(edge_ratio(kUnitCube), 1.0);
  EXPECT_EQ(mean_edge_length(kUnitCube), 1.0);
  EXPECT_EQ(hex_volume(kUnitCube), 1.0);
  EXPECT_EQ(jacobian_determinant(kUnitCube, 0.3, 0.7, 0.1), 1.0);
  const auto j = jacobian(kUnitCube, 0.5, 0.25, 0.75);
  EXPECT_EQ(j[0], (Vec3{1, 0, 0}));
  EXPECT_EQ(j[1], (Vec3{0, 1, 0}));
  EXPECT_EQ(j[2], (Vec3{0, 0, 1}));
  const HexQuality q = hex_quality(kUnitCube);
  EXPECT_EQ(q.min_corner_jacobian, 1.0);
  EXPECT_EQ(q.min_bernstein, 1.0);
  EXPECT_EQ(q.scaled_jacobian, 1.0);
  EXPECT_EQ(q.volume, 1.0);
  EXPECT_TRUE(q.certified());
}

// x -> A x + b has J = A everywhere, so det J is the constant det A and so is every Bernstein
// coefficient. With small integer A and b every operation is exact: compare with ==.
TEST(quality, AffineIntegerHexesHaveEveryCoefficientEqualToDetA) {
  std::mt19937_64 rng(11);
  for (int t = 0; t < 200; ++t) {
    const Affine a = random_affine(rng, true);
    const HexCorners c = map_corners(kUnitCube, a);
    const double d = a.det();
    for (double b : bernstein_jacobian(c)) ASSERT_EQ(b, d) << "trial " << t;
    for (double x : corner_jacobians(c)) ASSERT_EQ(x, d);
    EXPECT_EQ(hex_volume(c), d);
    EXPECT_EQ(min_bernstein(c), d);
    EXPECT_TRUE(bernstein_certified(c));
    EXPECT_EQ(jacobian_determinant(c, 0.25, 0.5, 0.75), d);
    // Scaled Jacobian: det of A's normalized columns, the same at all 9 points.
    const double expected = triple(normalized(a.col[0]), normalized(a.col[1]), normalized(a.col[2]));
    for (double s : scaled_jacobians(c)) EXPECT_NEAR(s, expected, 1e-15);
    const double h = (4 * norm(a.col[0]) + 4 * norm(a.col[1]) + 4 * norm(a.col[2])) / 12;
    EXPECT_NEAR(min_bernstein_scaled(c), d / (h * h * h), 1e-14 * d / (h * h * h));
  }
}

// hex_quality computes each product of edge vectors once for a parallelepiped (the four edges
// of each direction equal bit for bit); every field must be the same double as computing them all.
TEST(quality, ParallelepipedShortcutIsBitIdentical) {
  auto same_bits = [](double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  auto expect_identical = [&](const HexCorners& c, const char* what, int t) {
    const HexQuality q = hex_quality(c), full = detail::hex_quality_without_shortcuts(c);
    EXPECT_TRUE(same_bits(q.min_corner_jacobian, full.min_corner_jacobian)) << what << " " << t;
    EXPECT_TRUE(same_bits(q.min_bernstein, full.min_bernstein)) << what << " " << t;
    EXPECT_TRUE(same_bits(q.min_bernstein_scaled, full.min_bernstein_scaled)) << what << " " << t;
    EXPECT_TRUE(same_bits(q.scaled_jacobian, full.scaled_jacobian)) << what << " " << t;
    EXPECT_TRUE(same_bits(q.edge_ratio, full.edge_ratio)) << what << " " << t;
    EXPECT_TRUE(same_bits(q.volume, full.volume)) << what << " " << t;
    EXPECT_TRUE(same_bits(q.min_dihedral_angle, full.min_dihedral_angle)) << what << " " << t;
    EXPECT_TRUE(same_bits(q.max_dihedral_angle, full.max_dihedral_angle)) << what << " " << t;
    EXPECT_TRUE(same_bits(q.inverse_condition, full.inverse_condition)) << what << " " << t;
  };
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> coord(-3, 3);
  for (int t = 0; t < 500; ++t) {
    // Exact arithmetic (small integer maps): a parallelepiped, sheared, possibly inverted.
    const HexCorners sheared = map_corners(kUnitCube, random_affine(rng, true));
    ASSERT_TRUE(is_parallelepiped(sheared)) << t;
    expect_identical(sheared, "integer affine", t);
    // Axis-aligned boxes with any coordinates (the uncut cells of a grid and their subdivision),
    // either way round in each axis, some flat.
    double x[2] = {coord(rng), coord(rng)}, y[2] = {coord(rng), coord(rng)}, z[2] = {coord(rng), coord(rng)};
    if (t % 50 == 0) z[1] = z[0];
    HexCorners box;
    for (int i = 0; i < 8; ++i) box[i] = {x[kUnitCube[i].x > 0], y[kUnitCube[i].y > 0], z[kUnitCube[i].z > 0]};
    ASSERT_TRUE(is_parallelepiped(box)) << t;
    expect_identical(box, "box", t);
    // One corner moved by an ulp: not a parallelepiped, the full computation.
    HexCorners nudged = box;
    nudged[6].x = std::nextafter(nudged[6].x, 10.0);
    EXPECT_FALSE(is_parallelepiped(nudged)) << t;
    expect_identical(nudged, "nudged", t);
  }
}

// Every measure of a HexQuality, in one order, for comparing two bit for bit.
std::array<double, 9> measures_of(const HexQuality& q) {
  return {q.min_corner_jacobian, q.min_bernstein,      q.min_bernstein_scaled,
          q.scaled_jacobian,     q.edge_ratio,         q.volume,
          q.min_dihedral_angle,  q.max_dihedral_angle, q.inverse_condition};
}

// hex_quality's axis-aligned box path (quality.cpp axis_box_quality) against the general
// computation with no shortcut, bit for bit, on boxes in every one of the 48 orientations a hex's
// corner numbering can give them (which axis each reference direction takes, and which way), with
// random sizes and positions spanning 1e-90 to 1e90; the path must be taken exactly for the
// positively oriented ones, and never for a box whose edge leaves an axis by an ulp.
TEST(quality, AxisAlignedBoxesAreBitIdentical) {
  auto same_bits = [](double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  std::mt19937_64 rng(29);
  std::uniform_real_distribution<double> unit(-1, 1);
  std::uniform_int_distribution<int> exponent(-300, 300);
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  int taken = 0;
  for (int t = 0; t < 40; ++t) {
    const double scale = std::ldexp(1.0, exponent(rng) % (t < 20 ? 4 : 300));
    const Vec3 origin{unit(rng) * scale, unit(rng) * scale, unit(rng) * scale};
    const double size[3] = {(1.5 + unit(rng)) * scale, (1.5 + unit(rng)) * scale * (t % 7 == 0 ? 1e-3 : 1),
                            (1.5 + unit(rng)) * scale};
    for (const auto& perm : perms)
      for (int signs = 0; signs < 8; ++signs) {
        // Reference direction d runs along axis perm[d], forwards or backwards.
        HexCorners c;
        for (int i = 0; i < 8; ++i) {
          Vec3 p = origin;
          const double r[3] = {kUnitCube[i].x, kUnitCube[i].y, kUnitCube[i].z};
          for (int d = 0; d < 3; ++d) p[perm[d]] += (signs >> d & 1 ? -r[d] : r[d]) * size[d];
          c[i] = p;
        }
        const HexQuality q = hex_quality(c), full = detail::hex_quality_without_shortcuts(c);
        const bool positive = full.min_corner_jacobian > 0;
        EXPECT_EQ(detail::takes_axis_box_path(c), positive) << t << " " << signs;
        taken += detail::takes_axis_box_path(c) ? 1 : 0;
        const auto got = measures_of(q), want = measures_of(full);
        for (int k = 0; k < 9; ++k) EXPECT_TRUE(same_bits(got[k], want[k])) << t << " " << signs << " measure " << k;
        if (positive) {
          EXPECT_EQ(q.scaled_jacobian, 1.0);
          EXPECT_EQ(q.min_dihedral_angle, 90.0);
        }
        // An edge off its axis by an ulp: no longer a box for the path.
        HexCorners tilted = c;
        for (int i = 0; i < 8; ++i)
          if (kUnitCube[i].x > 0) tilted[i][perm[1]] = std::nextafter(tilted[i][perm[1]], INFINITY);
        EXPECT_FALSE(detail::takes_axis_box_path(tilted)) << t << " " << signs;
      }
  }
  EXPECT_EQ(taken, 40 * 6 * 4);  // half the orientations are positive
}

// QualityCache against hex_quality, every field bit for bit, over a stream like a mesh's: the
// midpoint-subdivided cells of a grid with rounded coordinates (boxes whose edges repeat, some
// equal to an ulp), sheared parallelepipeds, hexes with one corner nudged off (no longer
// parallelepipeds) and flat or inverted boxes, in an order that makes slots collide; the table
// must answer a good part of them, or this would test nothing but the miss path.
TEST(quality, CachedQualityIsBitIdentical) {
  auto same_bits = [](double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> unit(-1, 1);
  QualityCache cache;
  std::size_t n = 0;
  auto expect_same = [&](const HexCorners& c) {
    const auto g = measures_of(cache(c)), w = measures_of(hex_quality(c));
    for (int k = 0; k < 9; ++k) EXPECT_TRUE(same_bits(g[k], w[k])) << n << " measure " << k;
    ++n;
  };
  const double h = 0.1 + 1e-3 * unit(rng);
  for (int cell = 0; cell < 3000; ++cell) {
    const int i = cell % 17, j = cell / 17 % 13, k = cell / 221;
    // Cell corners as a grid computes them (origin + index * h), children at the midpoints.
    const double x[3] = {-1 + i * h, -1 + (i + 0.5) * h, -1 + (i + 1) * h};
    const double y[3] = {-2 + j * h, -2 + (j + 0.5) * h, -2 + (j + 1) * h};
    const double z[3] = {3 + k * h, 3 + (k + 0.5) * h, 3 + (k + 1) * h};
    for (int child = 0; child < 8; ++child) {
      HexCorners c;
      for (int v = 0; v < 8; ++v)
        c[v] = {x[(child & 1) + (kUnitCube[v].x > 0)], y[(child >> 1 & 1) + (kUnitCube[v].y > 0)],
                z[(child >> 2 & 1) + (kUnitCube[v].z > 0)]};
      expect_same(c);
      if (cell % 7 == 0) {
        HexCorners nudged = c;
        nudged[6].y = std::nextafter(nudged[6].y, 10.0);
        expect_same(nudged);
      }
      if (cell % 11 == 0) {
        HexCorners flat = c;
        for (int v = 4; v < 8; ++v) flat[v].z = c[0].z;
        expect_same(flat);
        HexCorners inverted = c;
        for (int v = 0; v < 4; ++v) std::swap(inverted[v], inverted[v + 4]);
        expect_same(inverted);
      }
    }
    if (cell % 5 == 0) expect_same(map_corners(kUnitCube, random_affine(rng, true)));
  }
  EXPECT_GT(cache.hits(), n / 2) << n;
}

// bernstein_jacobian's coefficients are the means of their triple products (quality.cpp, "Collecting
// terms"), summed from 0 in the order a, then b, then c ascending, and the mean edge length the mean
// of norm() of the 12 edges in Edges::for_each order; the library lays both out for speed. Written
// here straight from the formulas, every value must be the same double: the certificate (and which
// centre the repair search picks, core/cutting/repair.h) rests on them.
TEST(quality, BernsteinCoefficientsAndMeanEdgeFollowTheirFormulasBitForBit) {
  auto at = [](const HexCorners& c, int a, int b, int d) { return c[4 * d + (b == 0 ? a : 3 - a)]; };
  auto same_bits = [](double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> scale(1e-3, 1e3);
  for (int t = 0; t < 2000; ++t) {
    const double s = scale(rng);
    const HexCorners c = map_corners(random_hex(rng, t % 2 ? 0.45 : 0.8), [&](Vec3 p) { return s * p; });
    Vec3 xi[2][2], eta[2][2], zeta[2][2];
    for (int u = 0; u < 2; ++u)
      for (int v = 0; v < 2; ++v) {
        xi[u][v] = at(c, 1, u, v) - at(c, 0, u, v);
        eta[u][v] = at(c, u, 1, v) - at(c, u, 0, v);
        zeta[u][v] = at(c, u, v, 1) - at(c, u, v, 0);
      }
    double sum = 0;
    for (int u = 0; u < 2; ++u)
      for (int v = 0; v < 2; ++v) sum = sum + norm(xi[u][v]) + norm(eta[u][v]) + norm(zeta[u][v]);
    double mean = 0;
    const BernsteinCoefficients both = bernstein_jacobian(c, mean);
    ASSERT_TRUE(same_bits(mean, sum / 12)) << t;
    ASSERT_TRUE(same_bits(mean_edge_length(c), sum / 12)) << t;
    const BernsteinCoefficients beta = bernstein_jacobian(c);
    ASSERT_EQ(std::memcmp(both.data(), beta.data(), sizeof beta), 0) << t;
    for (int k = 0; k < 3; ++k)
      for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 3; ++i) {
          double sum = 0;
          int terms = 0;
          for (int a = i == 2 ? 1 : 0; a <= (i == 0 ? 0 : 1); ++a)
            for (int b = j == 2 ? 1 : 0; b <= (j == 0 ? 0 : 1); ++b)
              for (int d = k == 2 ? 1 : 0; d <= (k == 0 ? 0 : 1); ++d, ++terms)
                sum += triple(xi[b][d], eta[a][k - d], zeta[i - a][j - b]);
          const double mean = sum * (1.0 / terms);  // terms is 1, 2, 4 or 8: exact
          ASSERT_TRUE(same_bits(beta[bernstein_index(i, j, k)], mean)) << t << " " << i << j << k;
        }
  }
}

TEST(quality, AffineRealHexesHaveEveryCoefficientEqualToDetA) {
  std::mt19937_64 rng(12);
  for (int t = 0; t < 200; ++t) {
    const Affine a = random_affine(rng, false);
    const HexCorners c = map_corners(kUnitCube, a);
    const double d = a.det();
    // Rounding in the corners is relative to their size, a few units: scale the tolerance.
    const double tol = 1e-13 * std::pow(norm(a.col[0]) + norm(a.col[1]) + norm(a.col[2]) + norm(a.b), 3);
    for (double b : bernstein_jacobian(c)) ASSERT_NEAR(b, d, tol) << "trial " << t;
    EXPECT_NEAR(hex_volume(c), d, tol);
  }
}

TEST(quality, MirroredHexHasEveryCoefficientNegated) {
  for (double b : bernstein_jacobian(mirrored(kUnitCube))) EXPECT_EQ(b, -1.0);
  EXPECT_FALSE(bernstein_certified(mirrored(kUnitCube)));
  EXPECT_EQ(scaled_jacobian(mirrored(kUnitCube)), -1.0);
  EXPECT_EQ(hex_volume(mirrored(kUnitCube)), -1.0);

  // In general det J of the mirror at zeta is -det J at 1 - zeta: beta'_ijk = -beta_ij(2-k).
  std::mt19937_64 rng(13);
  for (int t = 0; t < 100; ++t) {
    const HexCorners c = random_hex(rng, 0.15);
    ASSERT_TRUE(bernstein_certified(c));
    const BernsteinCoefficients beta = bernstein_jacobian(c);
    const BernsteinCoefficients m = bernstein_jacobian(mirrored(c));
    for (int k = 0; k < 3; ++k) {
      for (int j = 0; j < 3; ++j) {
        for (int i = 0; i < 3; ++i) {
          EXPECT_NEAR(m[bernstein_index(i, j, k)], -beta[bernstein_index(i, j, 2 - k)], 1e-12);
          EXPECT_LT(m[bernstein_index(i, j, k)], 0);
        }
      }
    }
    EXPECT_FALSE(bernstein_certified(mirrored(c)));
    EXPECT_LT(scaled_jacobian(mirrored(c)), 0);
  }
}

// Corner 6 pushed through the centre to (1/4, 1/4, 1/4): the element folds over itself.
TEST(quality, CornerPushedThroughIsNotCertified) {
  HexCorners c = kUnitCube;
  c[6] = {0.25, 0.25, 0.25};
  EXPECT_FALSE(bernstein_certified(c));
  EXPECT_LT(min_bernstein(c), 0);
  EXPECT_LT(corner_jacobians(c)[6], 0);
  EXPECT_LT(sampled_min_det(c, 16), 0);
  EXPECT_LE(min_bernstein(c), sampled_min_det(c, 16));
}

// An element that the customary 9-point measure passes but that folds inside: det J > 0 at the
// 8 corners and the centre, det J < 0 elsewhere. Found by a search over corners on a 1/4
// lattice (two corners moved); all coordinates are dyadic, so the values below are exact.
TEST(quality, NinePointMeasurePassesAnElementThatFoldsInside) {
  HexCorners c = kUnitCube;
  c[3] = {-1.25, 2, 2};
  c[6] = {0.25, 3, 0.75};
  for (double d : corner_jacobians(c)) EXPECT_GT(d, 0);
  EXPECT_GT(jacobian_determinant(c, 0.5, 0.5, 0.5), 0);
  EXPECT_GT(scaled_jacobian(c), 0);  // all 9 scaled values positive

  const double sampled = sampled_min_det(c, 32);
  EXPECT_LT(sampled, -0.4);
  EXPECT_FALSE(bernstein_certified(c));
  EXPECT_LE(min_bernstein(c), sampled);
  EXPECT_FALSE(hex_quality(c).certified());
}

// The library's coefficients against independent references on random, sometimes inverted,
// trilinear hexes: (1) the Bernstein polynomial summed here equals det J from the Jacobian
// columns at grid and random points; (2) coefficients rebuilt from det J at {0,1/2,1}^3
// agree; (3) min beta bounds det J from below (convex hull property); (4) corner coefficients
// are det J at the corners.
TEST(quality, BernsteinCoefficientsMatchSampledDeterminant) {
  std::mt19937_64 rng(14);
  std::uniform_real_distribution<double> u(0, 1);
  int uncertified = 0;
  for (int t = 0; t < 300; ++t) {
    const HexCorners c = random_hex(rng, t < 150 ? 0.3 : 0.6);
    const BernsteinCoefficients beta = bernstein_jacobian(c);
    const BernsteinCoefficients rebuilt = coefficients_from_values(c);
    for (int i = 0; i < 27; ++i) ASSERT_NEAR(beta[i], rebuilt[i], 1e-12) << "trial " << t;

    const double lo = min_bernstein(c);
    const int n = 10;
    for (int k = 0; k <= n; ++k) {
      for (int j = 0; j <= n; ++j) {
        for (int i = 0; i <= n; ++i) {
          const double x = double(i) / n, y = double(j) / n, z = double(k) / n;
          const double d = jacobian_determinant(c, x, y, z);
          ASSERT_NEAR(evaluate_bernstein(beta, x, y, z), d, 1e-12);
          ASSERT_GE(d, lo - 1e-12);
        }
      }
    }
    for (int s = 0; s < 200; ++s) {
      const double x = u(rng), y = u(rng), z = u(rng);
      ASSERT_NEAR(evaluate_bernstein(beta, x, y, z), jacobian_determinant(c, x, y, z), 1e-12);
    }
    const auto corners = corner_jacobians(c);
    for (int i = 0; i < 8; ++i) {
      const Vec3 r = reference_corner(i);
      const double at = jacobian_determinant(c, r.x, r.y, r.z);
      EXPECT_NEAR(corners[i], at, 1e-12);
      EXPECT_EQ(corners[i], beta[bernstein_index(2 * int(r.x), 2 * int(r.y), 2 * int(r.z))]);
    }
    if (bernstein_certified(c)) {
      EXPECT_GT(sampled_min_det(c, 8), 0);
    } else {
      ++uncertified;
    }
    EXPECT_EQ(hex_quality(c).min_bernstein, lo);
    EXPECT_EQ(bernstein_certified(c), lo > 0);
  }
  EXPECT_GT(uncertified, 10);  // the sample covers both outcomes
}

double gauss_volume(const HexCorners& c) {
  // 2-point Gauss-Legendre per axis on [0,1] is exact up to degree 3 >= 2 per axis.
  const double g[2] = {0.5 - 0.5 / std::sqrt(3.0), 0.5 + 0.5 / std::sqrt(3.0)};
  double v = 0;
  for (double x : g) {
    for (double y : g) {
      for (double z : g) v += jacobian_determinant(c, x, y, z) / 8;
    }
  }
  return v;
}

double midpoint_volume(const HexCorners& c, int n) {
  double v = 0;
  for (int k = 0; k < n; ++k) {
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        v += jacobian_determinant(c, (i + 0.5) / n, (j + 0.5) / n, (k + 0.5) / n);
      }
    }
  }
  return v / (double(n) * n * n);
}

TEST(quality, VolumeIsExactForTrilinearHexes) {
  std::mt19937_64 rng(15);
  for (int t = 0; t < 100; ++t) {
    const HexCorners c = random_hex(rng, 0.4);
    const double v = hex_volume(c);
    EXPECT_NEAR(v, gauss_volume(c), 1e-13);
    // The midpoint rule converges as 1/n^2 (error about h^2/24 times a second derivative).
    EXPECT_NEAR(v, midpoint_volume(c, 48), 2e-3 * std::abs(v));
    EXPECT_EQ(hex_quality(c).volume, v);
  }
  // A frustum: square base 2 x 2, top 1 x 1 centred one unit above. Its faces are planar, so
  // the trilinear element is the polyhedron: V = h (A1 + A2 + sqrt(A1 A2)) / 3 = 7/3.
  const HexCorners frustum = {
      {{0, 0, 0}, {2, 0, 0}, {2, 2, 0}, {0, 2, 0}, {0.5, 0.5, 1}, {1.5, 0.5, 1}, {1.5, 1.5, 1}, {0.5, 1.5, 1}}};
  EXPECT_NEAR(hex_volume(frustum), 7.0 / 3.0, 1e-15);
  EXPECT_TRUE(bernstein_certified(frustum));
}

TEST(quality, EdgeRatioAndScaledJacobianOfSimpleShapes) {
  const HexCorners box = map_corners(kUnitCube, [](Vec3 p) { return Vec3{p.x, 2 * p.y, 3 * p.z}; });
  EXPECT_EQ(edge_ratio(box), 3.0);
  EXPECT_EQ(scaled_jacobian(box), 1.0);
  EXPECT_EQ(hex_volume(box), 6.0);
  EXPECT_EQ(mean_edge_length(box), 2.0);
  EXPECT_DOUBLE_EQ(min_bernstein_scaled(box), 6.0 / 8.0);

  // Shear x += s y: columns (1,0,0), (s,1,0), (0,0,1); scaled Jacobian 1 / sqrt(1 + s^2).
  const double s = 0.75;
  const HexCorners sheared = map_corners(kUnitCube, [&](Vec3 p) { return Vec3{p.x + s * p.y, p.y, p.z}; });
  for (double v : scaled_jacobians(sheared)) EXPECT_NEAR(v, 1 / std::sqrt(1 + s * s), 1e-15);
  EXPECT_EQ(hex_volume(sheared), 1.0);

  // A collapsed edge: corners 6 and 7 coincide. Scaled Jacobian 0 there, edge ratio infinite.
  HexCorners collapsed = kUnitCube;
  collapsed[6] = collapsed[7];
  EXPECT_EQ(edge_ratio(collapsed), std::numeric_limits<double>::infinity());
  EXPECT_EQ(scaled_jacobians(collapsed)[6], 0.0);
  EXPECT_EQ(scaled_jacobians(collapsed)[7], 0.0);
  EXPECT_FALSE(bernstein_certified(collapsed));  // det J = 0 on that edge: not > 0

  // A hex collapsed to one point: no division by zero.
  HexCorners point{};
  EXPECT_EQ(min_bernstein_scaled(point), 0.0);
  EXPECT_EQ(scaled_jacobian(point), 0.0);
}

// The scaled minimum coefficient is invariant under uniform scaling and translation; the raw
// one scales with the cube of the size.
TEST(quality, ScaledBernsteinIsSizeIndependent) {
  std::mt19937_64 rng(16);
  for (int t = 0; t < 50; ++t) {
    const HexCorners c = random_hex(rng, 0.3);
    const HexCorners big = map_corners(c, [](Vec3 p) { return 8.0 * p + Vec3{100, -50, 3}; });
    EXPECT_NEAR(min_bernstein_scaled(big), min_bernstein_scaled(c), 1e-12);
    EXPECT_NEAR(min_bernstein(big), 512 * min_bernstein(c), 1e-9);
    EXPECT_NEAR(scaled_jacobian(big), scaled_jacobian(c), 1e-12);
    EXPECT_NEAR(edge_ratio(big), edge_ratio(c), 1e-12);
  }
}

// ---------------------------------------------------------------------------------------------
// Dihedral angles and the inverse condition number (docs/quality.md), against closed forms and
// against references built here from the matrix itself: the angle between two faces from the
// edges projected off their common edge (acos), kappa from an inverse by cofactors.

constexpr double kPi = 3.14159265358979323846;
double deg(double radians) { return radians * 180 / kPi; }

// The interior angle along edge x between the faces (x, y) and (x, z), in degrees: the angle
// between y and z with their components along x removed.
double projected_angle(Vec3 x, Vec3 y, Vec3 z) {
  const Vec3 ux = normalized(x);
  const Vec3 py = y - dot(y, ux) * ux, pz = z - dot(z, ux) * ux;
  return deg(std::acos(std::clamp(dot(py, pz) / (norm(py) * norm(pz)), -1.0, 1.0)));
}

// Knupp's kappa = |A|_F |A^-1|_F / 3 with A^-1 = adj(A) / det A, the adjugate entry by entry.
double reference_inverse_condition(const std::array<Vec3, 3>& columns) {
  double a[3][3];
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) a[r][c] = columns[c][r];
  const double det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
                     a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                     a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
  double f = 0, g = 0;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      f += a[r][c] * a[r][c];
      // Cofactor of (r, c): the 2 x 2 minor without row r and column c, signed.
      const int r0 = (r + 1) % 3, r1 = (r + 2) % 3, c0 = (c + 1) % 3, c1 = (c + 2) % 3;
      const double cof = a[r0][c0] * a[r1][c1] - a[r0][c1] * a[r1][c0];
      g += cof * cof / (det * det);
    }
  return 3 / (std::sqrt(f) * std::sqrt(g));
}

TEST(quality, CubeHasRightDihedralAnglesAndInverseConditionOne) {
  for (double a : dihedral_angles(kUnitCube)) EXPECT_EQ(a, 90.0);
  for (double k : inverse_conditions(kUnitCube)) EXPECT_EQ(k, 1.0);
  EXPECT_EQ(inverse_condition(kUnitCube), 1.0);
  const HexQuality q = hex_quality(kUnitCube);
  EXPECT_EQ(q.min_dihedral_angle, 90.0);
  EXPECT_EQ(q.max_dihedral_angle, 90.0);
  EXPECT_EQ(q.inverse_condition, 1.0);
  EXPECT_EQ(q.edge_ratio, 1.0);
  EXPECT_EQ(q.scaled_jacobian, 1.0);
  // Any size and place: a box keeps its right angles; kappa sees the aspect ratio.
  const HexCorners box = map_corners(kUnitCube, [](Vec3 p) { return Vec3{1e-9 * p.x - 5e-9, 2e-9 * p.y, 3e-9 * p.z}; });
  for (double a : dihedral_angles(box)) EXPECT_EQ(a, 90.0);
  // |A|_F = sqrt(14), |A^-1|_F = sqrt(1 + 1/4 + 1/9) = 7/6.
  for (double k : inverse_conditions(box)) EXPECT_NEAR(k, 18 / (7 * std::sqrt(14.0)), 1e-15);
  EXPECT_NEAR(hex_quality(box).inverse_condition, 18 / (7 * std::sqrt(14.0)), 1e-15);
  EXPECT_NEAR(hex_quality(box).edge_ratio, 3.0, 1e-15);
}

// x += s y: the faces along z meet at atan(1/s) and 180 - atan(1/s); every other edge has 90.
// J = [[1, s, 0], [0, 1, 0], [0, 0, 1]], J^-1 = [[1, -s, 0], ...]: kappa = (3 + s^2) / 3.
TEST(quality, ShearedHexAngles) {
  for (const double s : {0.75, 0.1, 3.0, -2.0}) {
    const HexCorners c = map_corners(kUnitCube, [&](Vec3 p) { return Vec3{p.x + s * p.y, p.y, p.z}; });
    const double acute = deg(std::atan(1 / std::abs(s)));
    const auto angles = dihedral_angles(c);
    for (int corner = 0; corner < 8; ++corner) {
      EXPECT_NEAR(angles[3 * corner + 0], 90.0, 1e-12) << s << " " << corner;
      EXPECT_NEAR(angles[3 * corner + 1], 90.0, 1e-12) << s << " " << corner;
      const double z = angles[3 * corner + 2];
      EXPECT_TRUE(std::abs(z - acute) < 1e-12 || std::abs(z - (180 - acute)) < 1e-12) << s << " " << z;
    }
    const HexQuality q = hex_quality(c);
    EXPECT_NEAR(q.min_dihedral_angle, acute, 1e-12) << s;
    EXPECT_NEAR(q.max_dihedral_angle, 180 - acute, 1e-12) << s;
    EXPECT_NEAR(q.inverse_condition, 3 / (3 + s * s), 1e-15) << s;
  }
}

// A square frustum (base 2 x 2, top 1 x 1, height 1): planar faces, so both ends of each edge
// agree. Base edges atan(2), top edges 180 - atan(2); along the lateral edges the outward side
// normals (0, -1, 1/2) and (1, 0, 1/2) have cos 1/5 between them, the interior angle acos(-1/5).
TEST(quality, FrustumAngles) {
  const HexCorners f = {
      {{0, 0, 0}, {2, 0, 0}, {2, 2, 0}, {0, 2, 0}, {0.5, 0.5, 1}, {1.5, 0.5, 1}, {1.5, 1.5, 1}, {0.5, 1.5, 1}}};
  const double base = deg(std::atan(2.0)), lateral = deg(std::acos(-0.2));
  const auto angles = dihedral_angles(f);
  for (int corner = 0; corner < 8; ++corner) {
    const double along_face = corner < 4 ? base : 180 - base;
    EXPECT_NEAR(angles[3 * corner + 0], along_face, 1e-12) << corner;
    EXPECT_NEAR(angles[3 * corner + 1], along_face, 1e-12) << corner;
    EXPECT_NEAR(angles[3 * corner + 2], lateral, 1e-12) << corner;
  }
  const HexQuality q = hex_quality(f);
  EXPECT_NEAR(q.min_dihedral_angle, base, 1e-12);
  EXPECT_NEAR(q.max_dihedral_angle, 180 - base, 1e-12);
  // The corner matrices: base corners 2 U, 2 V and a lateral edge, top corners 1, 1 and one.
  const auto k = inverse_conditions(f);
  EXPECT_NEAR(k[0], reference_inverse_condition({Vec3{2, 0, 0}, Vec3{0, 2, 0}, Vec3{0.5, 0.5, 1}}), 1e-14);
  EXPECT_NEAR(k[6], reference_inverse_condition({Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{-0.5, -0.5, 1}}), 1e-14);
  EXPECT_NEAR(q.inverse_condition, *std::min_element(k.begin(), k.end()), 0.0);
}

// Affine hexes: along each direction's 4 parallel edges the cross-section is a parallelogram,
// angles theta and 180 - theta; 1 / kappa is that of A at every corner.
TEST(quality, AffineHexAnglesAndConditionAgainstReferences) {
  std::mt19937_64 rng(21);
  for (int t = 0; t < 200; ++t) {
    const Affine a = random_affine(rng, t % 2 == 0);
    const HexCorners c = map_corners(kUnitCube, a);
    double lo = 360, hi = 0;
    for (int d = 0; d < 3; ++d) {
      const double theta = projected_angle(a.col[d], a.col[(d + 1) % 3], a.col[(d + 2) % 3]);
      lo = std::min({lo, theta, 180 - theta});
      hi = std::max({hi, theta, 180 - theta});
    }
    const HexQuality q = hex_quality(c);
    EXPECT_NEAR(q.min_dihedral_angle, lo, 1e-9) << t;
    EXPECT_NEAR(q.max_dihedral_angle, hi, 1e-9) << t;
    const double kappa = reference_inverse_condition({a.col[0], a.col[1], a.col[2]});
    for (double k : inverse_conditions(c)) EXPECT_NEAR(k, kappa, 1e-12) << t;
    EXPECT_NEAR(q.inverse_condition, kappa, 1e-12) << t;
    EXPECT_GT(q.inverse_condition, 0);
    EXPECT_LE(q.inverse_condition, 1 + 1e-15);
  }
}

// General hexes: each of the 24 angles against the projected-edge reference at its corner.
TEST(quality, DihedralAnglesOfDistortedHexesAgainstReference) {
  std::mt19937_64 rng(22);
  for (int t = 0; t < 200; ++t) {
    const HexCorners c = random_hex(rng, 0.3);
    const auto angles = dihedral_angles(c);
    const auto kappas = inverse_conditions(c);
    for (int corner = 0; corner < 8; ++corner) {
      const Vec3 r = reference_corner(corner);
      // The edges leaving the corner, to the neighbours along xi, eta, zeta.
      Vec3 e[3];
      for (int d = 0; d < 3; ++d) {
        Vec3 n = r;
        n[d] = 1 - n[d];
        const int other = static_cast<int>(std::find(kUnitCube.begin(), kUnitCube.end(), n) - kUnitCube.begin());
        e[d] = c[other] - c[corner];
      }
      // Where the hex folds over at the corner (det J < 0) the interior angle is the reflex one,
      // and 1 / kappa takes the sign of det J.
      const bool folded = corner_jacobians(c)[corner] < 0;
      for (int d = 0; d < 3; ++d) {
        const double a = projected_angle(e[d], e[(d + 1) % 3], e[(d + 2) % 3]);
        EXPECT_NEAR(angles[3 * corner + d], folded ? 360 - a : a, 1e-9) << t;
      }
      // Reversing an edge leaves kappa alone: the +xi, +eta, +zeta columns or the leaving edges.
      const double k = reference_inverse_condition({e[0], e[1], e[2]});
      EXPECT_NEAR(kappas[corner], folded ? -k : k, 1e-12) << t;
    }
    const HexQuality q = hex_quality(c);
    EXPECT_EQ(q.min_dihedral_angle, *std::min_element(angles.begin(), angles.end())) << t;
    EXPECT_EQ(q.max_dihedral_angle, *std::max_element(angles.begin(), angles.end())) << t;
    EXPECT_EQ(q.inverse_condition, *std::min_element(kappas.begin(), kappas.end())) << t;
  }
}

// Folded and degenerate corners: the mirrored cube is inverted at every corner (270 degrees,
// 1 / kappa = -1); a collapsed edge has angle 0 and 1 / kappa = 0 at its ends.
TEST(quality, InvertedAndDegenerateCorners) {
  for (double a : dihedral_angles(mirrored(kUnitCube))) EXPECT_EQ(a, 270.0);
  for (double k : inverse_conditions(mirrored(kUnitCube))) EXPECT_EQ(k, -1.0);
  const HexQuality m = hex_quality(mirrored(kUnitCube));
  EXPECT_EQ(m.min_dihedral_angle, 270.0);
  EXPECT_EQ(m.inverse_condition, -1.0);
  // Corner 6 pushed through the centre: the angles there pass 180.
  HexCorners pushed = kUnitCube;
  pushed[6] = {0.25, 0.25, 0.25};
  EXPECT_GT(hex_quality(pushed).max_dihedral_angle, 180.0);
  EXPECT_LT(hex_quality(pushed).inverse_condition, 0.0);

  HexCorners collapsed = kUnitCube;
  collapsed[6] = collapsed[7];
  const auto angles = dihedral_angles(collapsed);
  EXPECT_EQ(angles[3 * 6 + 0], 0.0);  // the xi edge from 7 to 6 has zero length
  EXPECT_EQ(angles[3 * 7 + 0], 0.0);
  EXPECT_EQ(inverse_conditions(collapsed)[6], 0.0);
  EXPECT_EQ(hex_quality(collapsed).min_dihedral_angle, 0.0);
  EXPECT_EQ(hex_quality(collapsed).inverse_condition, 0.0);

  HexCorners point{};
  EXPECT_EQ(hex_quality(point).inverse_condition, 0.0);
  EXPECT_EQ(hex_quality(point).min_dihedral_angle, 0.0);
}

// scaled_jacobian (the .vtu field) and hex_quality (the check) give the same double.
TEST(quality, ScaledJacobianAloneEqualsHexQuality) {
  std::mt19937_64 rng(24);
  auto same_bits = [](double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  for (int t = 0; t < 300; ++t) {
    const HexCorners c = t % 3 == 0 ? map_corners(kUnitCube, random_affine(rng, t % 2 == 0)) : random_hex(rng, 0.4);
    EXPECT_TRUE(same_bits(scaled_jacobian(c), hex_quality(c).scaled_jacobian)) << t;
  }
}

// MovingCorner (the optimiser's per-candidate measures) against scaled_jacobians and edge_ratio of
// the moved hex, bit for bit, for every corner of random, affine and box-shaped hexes moved to
// random points, onto another corner (a zero-length edge) and by an ulp; and its early stop: false
// exactly when the minimum of the 9 falls below the floor.
TEST(quality, MovingCornerIsBitIdentical) {
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> step(-0.7, 0.7), unit(0, 1);
  auto same_bits = [](double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  for (int t = 0; t < 400; ++t) {
    HexCorners c = t % 4 == 0 ? map_corners(kUnitCube, random_affine(rng, t % 8 == 0)) : random_hex(rng, 0.35);
    if (t % 4 == 1) {
      const double h = 1 + unit(rng);
      c = map_corners(kUnitCube, [&](Vec3 p) { return h * p; });
    }
    for (int corner = 0; corner < 8; ++corner) {
      const MovingCorner moving(c, corner);
      for (int k = 0; k < 6; ++k) {
        Vec3 y = c[corner] + Vec3{step(rng), step(rng), step(rng)};
        if (k == 0) y = c[corner];
        if (k == 1) y = c[(corner + 1) % 8];
        if (k == 2) y = {std::nextafter(c[corner].x, 9.0), c[corner].y, c[corner].z};
        HexCorners moved = c;
        moved[corner] = y;
        const std::array<double, 9> want = scaled_jacobians(moved);
        std::array<double, 9> got{};
        ASSERT_TRUE(moving.scaled_jacobians(y, -std::numeric_limits<double>::infinity(), got)) << t;
        for (int i = 0; i < 9; ++i)
          EXPECT_TRUE(same_bits(got[i], want[i])) << t << " " << corner << " " << k << " " << i;
        EXPECT_TRUE(same_bits(moving.edge_ratio(y), edge_ratio(moved))) << t << " " << corner << " " << k;
        const double lowest = *std::min_element(want.begin(), want.end());
        for (double floor : {lowest, std::nextafter(lowest, 2.0), lowest - 0.1 * unit(rng), lowest + 0.1 * unit(rng)}) {
          EXPECT_EQ(moving.scaled_jacobians(y, floor, got), !(lowest < floor)) << t << " " << corner << " " << k;
          const double least = moving.scaled_jacobian(y, floor);
          EXPECT_TRUE(lowest < floor ? least == -std::numeric_limits<double>::infinity() : same_bits(least, lowest))
              << t << " " << corner << " " << k;
        }
      }
    }
  }
}

TEST(quality, AnglesAndConditionAreSizeIndependent) {
  std::mt19937_64 rng(23);
  for (int t = 0; t < 50; ++t) {
    const HexCorners c = random_hex(rng, 0.3);
    for (const double scale : {1e-150, 1e150}) {
      const HexCorners s = map_corners(c, [&](Vec3 p) { return scale * p; });
      EXPECT_NEAR(hex_quality(s).min_dihedral_angle, hex_quality(c).min_dihedral_angle, 1e-9);
      EXPECT_NEAR(hex_quality(s).max_dihedral_angle, hex_quality(c).max_dihedral_angle, 1e-9);
      EXPECT_NEAR(hex_quality(s).inverse_condition, hex_quality(c).inverse_condition, 1e-12);
    }
  }
}

}  // namespace
}  // namespace mchex
