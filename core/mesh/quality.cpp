#include "core/mesh/quality.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <utility>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace mchex {
namespace {

// The correctly rounded square root of each lane, as std::sqrt gives it (SSE2 has it as one
// instruction for both lanes).
Double2 sqrt2(Double2 v) {
#if defined(__SSE2__)
  return Double2(_mm_sqrt_pd(__m128d(v)));
#else
  return Double2{std::sqrt(v[0]), std::sqrt(v[1])};
#endif
}

// Corner index of reference vertex (a, b, c), a, b, c in {0,1}, in the Eq. 8 / VTK order.
constexpr int corner_index(int a, int b, int c) { return 4 * c + (b == 0 ? a : 3 - a); }

// The 12 edge vectors, grouped by direction. Each points in the + direction of its reference
// axis, so that at corner (a,b,c) the columns of J are exactly xi[b][c], eta[a][c], zeta[a][b]
// and in between they are bilinear blends of these (Eq. 9 applied to Eq. 8):
//   dx/dxi   = sum_{b,c} B1_b(eta) B1_c(zeta) xi[b][c]     and likewise for eta, zeta,
// with B1_0(t) = 1 - t, B1_1(t) = t.
struct Edges {
  Vec3 xi[2][2];    // [b][c]
  Vec3 eta[2][2];   // [a][c]
  Vec3 zeta[2][2];  // [a][b]

  // Whether the four edges of each direction are the same vector, bit for bit: a
  // parallelepiped, such as every cell the mesher leaves uncut and the 8 hexes of its midpoint
  // subdivision (most hexes of a mesh). Then every product of edge vectors below has one value
  // per combination of directions, computed once from the same doubles: the same results as
  // computing each, for less work (tests: quality.ParallelepipedShortcutIsBitIdentical).
  bool parallel = false;

  explicit Edges(const HexCorners& p, bool shortcuts = true) {
    for (int u = 0; u < 2; ++u) {
      for (int v = 0; v < 2; ++v) {
        xi[u][v] = p[corner_index(1, u, v)] - p[corner_index(0, u, v)];
        eta[u][v] = p[corner_index(u, 1, v)] - p[corner_index(u, 0, v)];
        zeta[u][v] = p[corner_index(u, v, 1)] - p[corner_index(u, v, 0)];
      }
    }
    auto same = [](const Vec3(&e)[2][2]) {
      return std::memcmp(&e[0][0], &e[0][1], sizeof(Vec3)) == 0 && std::memcmp(&e[0][0], &e[1][0], sizeof(Vec3)) == 0 &&
             std::memcmp(&e[0][0], &e[1][1], sizeof(Vec3)) == 0;
    };
    parallel = shortcuts && same(xi) && same(eta) && same(zeta);
  }

  // The 12 edge lengths, in for_each order.
  std::array<double, 12> lengths() const {
    std::array<double, 12> l{};
    if (parallel) {
      const double x = norm(xi[0][0]), y = norm(eta[0][0]), z = norm(zeta[0][0]);
      for (int n = 0; n < 12; n += 3) {
        l[n] = x;
        l[n + 1] = y;
        l[n + 2] = z;
      }
      return l;
    }
    // norm() of each edge, two per operation (the same products and sums on each lane).
    std::array<Vec3, 12> v;
    int n = 0;
    for_each([&](Vec3 e) { v[n++] = e; });
    for (int i = 0; i < 12; i += 2) {
      const Double2 x{v[i].x, v[i + 1].x}, y{v[i].y, v[i + 1].y}, z{v[i].z, v[i + 1].z};
      const Double2 root = sqrt2(x * x + y * y + z * z);
      l[i] = root[0];
      l[i + 1] = root[1];
    }
    return l;
  }

  template <class F>
  void for_each(F&& f) const {
    for (int u = 0; u < 2; ++u) {
      for (int v = 0; v < 2; ++v) {
        f(xi[u][v]);
        f(eta[u][v]);
        f(zeta[u][v]);
      }
    }
  }
};

Vec3 bilinear(const Vec3 e[2][2], double s, double t) {
  return (1 - s) * ((1 - t) * e[0][0] + t * e[0][1]) + s * ((1 - t) * e[1][0] + t * e[1][1]);
}

// Bernstein coefficients of det J straight from the edge vectors.
//
// det J = triple(dx/dxi, dx/deta, dx/dzeta) is linear in each column. Substituting the
// bilinear Bernstein forms above and expanding, every term carries, per reference axis, a
// product of two linear Bernstein polynomials (one axis's column is constant in it, the other
// two are linear), and B1_a(t) B1_a'(t) = w B2_{a+a'}(t) with w = 1 if a + a' is 0 or 2 and
// w = 1/2 if a + a' = 1 (degree elevation). Collecting terms:
//
//   beta_{ijk} = mean over a+a'=i, b+b'=j, c+c'=k of triple(xi[b][c], eta[a][c'], zeta[a'][b'])
//
// an average of 1, 2, 4 or 8 triple products (2^(number of indices equal to 1)). This is the
// same polynomial identity as Theorem 5.1 (Eq. 10) with the monomial detour removed; it is
// exact in real arithmetic, and in floating point each coefficient is a short average of
// products of actual edge vectors, with no cancellation between large monomial terms. For an
// affine element all 64 triple products equal det A, so every coefficient is det A.
// Which of the 64 triples each coefficient averages, in the order the sum takes them (a, then b,
// then c, ascending), as indices into the triples below: a fixed table, so the per-hex work is 64
// dot products and 64 additions. The triple of xi[b][c], eta[a][c'], zeta[a'][b'] sits at
// 16 * (b * 2 + c) + 4 * (a * 2 + c') + (a' * 2 + b'): the 16 triples of one xi edge together.
struct TripleTerms {
  std::array<std::array<std::uint8_t, 8>, 27> index{};
  std::array<std::uint8_t, 27> count{};
};

constexpr TripleTerms make_triple_terms() {
  TripleTerms t;
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) {
        const int n = bernstein_index(i, j, k);
        for (int a = i == 2 ? 1 : 0; a <= (i == 0 ? 0 : 1); ++a)
          for (int b = j == 2 ? 1 : 0; b <= (j == 0 ? 0 : 1); ++b)
            for (int c = k == 2 ? 1 : 0; c <= (k == 0 ? 0 : 1); ++c)
              t.index[n][t.count[n]++] =
                  static_cast<std::uint8_t>(16 * (b * 2 + c) + 4 * (a * 2 + (k - c)) + ((i - a) * 2 + (j - b)));
      }
  return t;
}
constexpr TripleTerms kTripleTerms = make_triple_terms();

// Each coefficient, the average of its triples in the table's order.
// The mean of `terms` values from their sum: terms is 1, 2, 4 or 8, so the product by its
// reciprocal is the same double as the quotient.
double mean_of_sum(double sum, int terms) {
  return sum * (terms == 1 ? 1.0 : terms == 2 ? 0.5 : terms == 4 ? 0.25 : 0.125);
}

// Coefficient N: the sum from 0 in the table's order, with the table and the term count known at
// compile time (the loop unrolls; certify computes billions of these).
template <int N>
void coefficient_from_triples(const std::array<double, 64>& triples, BernsteinCoefficients& beta) {
  constexpr int terms = kTripleTerms.count[N];
  double sum = 0;
  for (int t = 0; t < terms; ++t) sum += triples[kTripleTerms.index[N][t]];
  beta[N] = mean_of_sum(sum, terms);
}

template <int... N>
BernsteinCoefficients bernstein_from_triples(const std::array<double, 64>& triples, std::integer_sequence<int, N...>) {
  BernsteinCoefficients beta;
  (coefficient_from_triples<N>(triples, beta), ...);
  return beta;
}

BernsteinCoefficients bernstein_from_edges(const Edges& e) {
  if (e.parallel) {
    // Every cross product below is cross(eta, zeta) and every triple the same dot t, so a
    // coefficient depends only on how many triples it averages: the sum of that many t's, in
    // bernstein_from_triples's operations.
    const double t = dot(e.xi[0][0], cross(e.eta[0][0], e.zeta[0][0]));
    double by_count[9] = {};
    for (int terms : {1, 2, 4, 8}) {
      double sum = 0;
      for (int i = 0; i < terms; ++i) sum += t;
      by_count[terms] = mean_of_sum(sum, terms);
    }
    BernsteinCoefficients beta{};
    for (int n = 0; n < 27; ++n) beta[n] = by_count[kTripleTerms.count[n]];
    return beta;
  }
  // triple(x, y, z) = dot(x, cross(y, z)): the 16 cross products of an eta and a zeta edge, each
  // used by four of the 64 triples, computed once. In components, two values per operation (the
  // compiler does not find this layout itself); every value is the same double as cross() and
  // dot() give, the same products summed in the same order on each lane.
  auto flat = [](const Vec3(&v)[2][2], int i) { return v[i >> 1][i & 1]; };
  auto both = [](double v) { return Double2{v, v}; };
  Double2 zx[2], zy[2], zz[2];  // zeta[a'][b'] at a' * 2 + b', two per value
  for (int h = 0; h < 2; ++h) {
    const Vec3 z0 = flat(e.zeta, 2 * h), z1 = flat(e.zeta, 2 * h + 1);
    zx[h] = Double2{z0.x, z1.x};
    zy[h] = Double2{z0.y, z1.y};
    zz[h] = Double2{z0.z, z1.z};
  }
  Double2 cx[8], cy[8], cz[8];  // cross(eta[a][c'], zeta[a'][b']) at 4 * (a * 2 + c') + a' * 2 + b'
  for (int i = 0; i < 4; ++i) {
    const Vec3 y = flat(e.eta, i);
    const Double2 yx = both(y.x), yy = both(y.y), yz = both(y.z);
    for (int h = 0; h < 2; ++h) {
      cx[2 * i + h] = yy * zz[h] - yz * zy[h];
      cy[2 * i + h] = yz * zx[h] - yx * zz[h];
      cz[2 * i + h] = yx * zy[h] - yy * zx[h];
    }
  }
  Double2 pairs[32];
  for (int i = 0; i < 4; ++i) {
    const Vec3 x = flat(e.xi, i);  // xi[b][c] at b * 2 + c
    const Double2 xx = both(x.x), xy = both(x.y), xz = both(x.z);
    for (int k = 0; k < 8; ++k) pairs[8 * i + k] = xx * cx[k] + xy * cy[k] + xz * cz[k];
  }
  std::array<double, 64> triples;
  std::memcpy(triples.data(), pairs, sizeof pairs);
  return bernstein_from_triples(triples, std::make_integer_sequence<int, 27>());
}

// Certificate. Each B_i^2(xi) B_j^2(eta) B_k^2(zeta) is >= 0 on [0,1]^3 and together they sum
// to 1, so det J(x) is a convex combination of the 27 coefficients at every x: det J >= min
// beta everywhere (the convex-hull property). We certify with min beta > 0, which gives
// det J >= min beta > 0 on the whole closed element. The paper's test (supplementary notes:
// min >= 0 && max > 0) proves only det J >= 0 with det J not identically 0: it accepts a zero
// corner coefficient, i.e. det J = 0 at a corner (a degenerate corner), and with coefficients
// computed in floating point a 0 may be a rounded negative. The paper applies it to symbolic
// polynomials over the open parameter box; for a concrete element in doubles we keep strict.
double min_of(const BernsteinCoefficients& beta) { return *std::min_element(beta.begin(), beta.end()); }

double mean_edge(const std::array<double, 12>& lengths) {
  double sum = 0;
  for (double l : lengths) sum += l;
  return sum / 12;
}

double mean_edge(const Edges& e) { return mean_edge(e.lengths()); }

// beta scales with the cube of the element size. An element collapsed to a point (h = 0) has
// every beta = 0; call that 0 rather than 0/0.
double scaled_by_size(double beta, double h) { return h > 0 ? beta / (h * h * h) : 0.0; }

double ratio_of_edges(const std::array<double, 12>& lengths) {
  double lo = std::numeric_limits<double>::infinity();
  double hi = 0;
  for (double l : lengths) {
    lo = std::min(lo, l);
    hi = std::max(hi, l);
  }
  return lo > 0 ? hi / lo : std::numeric_limits<double>::infinity();
}

double ratio_of_edges(const Edges& e) { return ratio_of_edges(e.lengths()); }

// The integral of a tensor Bernstein polynomial over [0,1]^3 is the mean of its coefficients
// (each quadratic Bernstein basis function integrates to 1/3), so the volume, the integral of
// det J, is exact for the trilinear element and costs nothing once beta is known.
double volume_of(const BernsteinCoefficients& beta) {
  double sum = 0;
  for (double b : beta) sum += b;
  return sum / 27;
}

double scaled_triple(Vec3 a, Vec3 b, Vec3 c) { return triple(normalized(a), normalized(b), normalized(c)); }

// normalized(v) from v's length already known (the same operations, so the same doubles).
Vec3 normalized_by(Vec3 v, double length) { return length > 0 ? v / length : Vec3{}; }

// The 12 edges at unit length (zero for an edge of zero length), each normalized once. Of a
// parallelepiped (Edges::parallel) only [0][0] of each direction is set: the others are equal.
struct UnitEdges {
  Vec3 xi[2][2]{}, eta[2][2]{}, zeta[2][2]{};
  double nxi[2][2]{}, neta[2][2]{}, nzeta[2][2]{};  // their squared lengths: 1 up to rounding, or 0
  UnitEdges(const Edges& e, const std::array<double, 12>& lengths) {
    for (int u = 0; u < 2; ++u)
      for (int v = 0; v < 2; ++v) {
        if (e.parallel && (u | v)) continue;
        const int n = 3 * (2 * u + v);  // Edges::for_each order
        xi[u][v] = normalized_by(e.xi[u][v], lengths[n]);
        eta[u][v] = normalized_by(e.eta[u][v], lengths[n + 1]);
        zeta[u][v] = normalized_by(e.zeta[u][v], lengths[n + 2]);
        nxi[u][v] = dot(xi[u][v], xi[u][v]);
        neta[u][v] = dot(eta[u][v], eta[u][v]);
        nzeta[u][v] = dot(zeta[u][v], zeta[u][v]);
      }
  }
};

// An angle atan2(s, c) taken in [0, 2 pi), kept as the pair: ordered by angle_less without a
// division or a trigonometric function, and turned into degrees only for the extremes (atan2 of
// the pair is accurate at every angle, where acos of a cosine is not near 0 and 180 degrees).
struct Angle {
  double c = 1, s = 0;
};

// (0, 0), the angle at an edge of zero length, is angle 0.
Angle make_angle(double c, double s) { return c == 0 && s == 0 ? Angle{1, 0} : Angle{c, s}; }

// Which half turn an angle is in: [0, pi) or [pi, 2 pi).
int half_turn(const Angle& a) { return a.s > 0 || (a.s == 0 && a.c > 0) ? 0 : 1; }

// a < b as angles in [0, 2 pi): by half turn, then within one (less than pi apart) by the sign of
// the cross product of the two pairs.
bool angle_less(const Angle& a, const Angle& b) {
  const int ha = half_turn(a), hb = half_turn(b);
  return ha != hb ? ha < hb : a.c * b.s - a.s * b.c > 0;
}

double degrees(const Angle& a) {
  constexpr double kPi = 3.14159265358979323846;
  double t = std::atan2(a.s, a.c);
  if (t < 0) t += 2 * kPi;
  return t / kPi * 180 + 0.0;  // exact at multiples of 90 (pi / 2 over pi is 0.5); + 0.0: no -0
}

// The measures of the corner at reference vertex (a, b, k), from the unit Jacobian columns there
// (U, V, W: +xi, +eta, +zeta edges) and their lengths over the mean edge length (lu, lv, lw).
//  - scaled Jacobian: det(U, V, W).
//  - dihedral angles (docs/quality.md): the edges leaving the corner are x = su U, y = sv V,
//    z = sw W with s = +1 at a reference coordinate 0 and -1 at 1. The face (x, y) has normal
//    x cross y at the corner, the face (x, z) normal x cross z; with unit vectors the interior
//    angle between them along x is
//      theta_x = atan2(det(U, V, W), (x cross y) . (x cross z)):
//    (x cross y) . (x cross z) is |x|^2 times the dot product of y and z projected off x, and
//    (x cross y) cross (x cross z) = det(x, y, z) x gives the sine. The sine takes the sign of
//    det J = det(U, V, W) (not of det(x, y, z) = su sv sw det J, whose sign flips from corner to
//    corner), so a corner where the hex folds over gives an angle above 180 degrees.
//    With A = U x V, B = V x W, C = W x U: (x cross y).(x cross z) = -sv sw A.C, and cyclically.
//  - 1 / kappa: J = (u, v, w) = (lu U, lv V, lw W) up to the common scale h, which kappa does
//    not see; |J^-1|_F = |(v x w, w x u, u x v)|_F / |det J|, so
//      1 / kappa = 3 det J / (|J|_F |J^-1|_F |det J|) = 3 det J / (|J|_F sqrt(|v x w|^2 + ...)).
//    Kept as its square with the sign of det J (condition_key; no square root per corner): the
//    order is the same. The lengths are over h so that the squares stay in range for any size.
struct Corner {
  double scaled_jacobian;  // also the sine part of the three angles
  double cosine[3];        // the cosine parts, along the xi, eta, zeta edge
  double condition_key;    // 1 / kappa times |1 / kappa|
  Angle dihedral(int d) const { return make_angle(cosine[d], scaled_jacobian); }
};

// With A, B, C as above, Binet-Cauchy gives every product of them from the dot products of U, V,
// W: (U x V).(W x U) = (U.W)(V.U) - (U.U)(V.W) and so on; 3 dot products instead of 3 cross
// products and 6 dot products per corner. nu = U.U etc. (1, or 0 for a zero-length edge).
inline Corner corner_measures(Vec3 U, Vec3 V, Vec3 W, double nu, double nv, double nw, double lu, double lv, double lw,
                              int a, int b, int k) {
  const double su = a ? -1 : 1, sv = b ? -1 : 1, sw = k ? -1 : 1;
  const double p = dot(U, V), q = dot(V, W), r = dot(W, U);
  Corner m;
  m.scaled_jacobian = triple(U, V, W);
  const double sj = m.scaled_jacobian;
  m.cosine[0] = -(sv * sw) * (r * p - nu * q);  // A.C
  m.cosine[1] = -(su * sw) * (p * q - nv * r);  // B.A
  m.cosine[2] = -(su * sv) * (q * r - nw * p);  // C.B
  const double uu = lu * lu, vv = lv * lv, ww = lw * lw;
  const double aa = nu * nv - p * p, bb = nv * nw - q * q, cc = nw * nu - r * r;  // |A|^2, |B|^2, |C|^2
  const double den = (uu + vv + ww) * (uu * vv * aa + vv * ww * bb + ww * uu * cc);
  m.condition_key = den > 0 ? 9 * (uu * vv * ww) * (sj * std::abs(sj)) / den : 0.0;
  return m;
}

double inverse_condition_of(double key) { return key < 0 ? -std::sqrt(-key) : std::sqrt(key); }

// Every corner of the hex, f(corner index, measures).
double inverse_mean_edge(const std::array<double, 12>& lengths) {
  const double h = mean_edge(lengths);
  return h > 0 ? 1 / h : 0.0;
}

template <class F>
void for_each_corner(const Edges& e, const std::array<double, 12>& lengths, const UnitEdges& n, F&& f) {
  const double inv_h = inverse_mean_edge(lengths);
  for (int k = 0; k < 2; ++k)
    for (int b = 0; b < 2; ++b)
      for (int a = 0; a < 2; ++a) {
        const int p = e.parallel ? 0 : 1;  // a parallelepiped keeps its unit edges in [0][0]
        const Corner m =
            corner_measures(n.xi[p * b][p * k], n.eta[p * a][p * k], n.zeta[p * a][p * b], n.nxi[p * b][p * k],
                            n.neta[p * a][p * k], n.nzeta[p * a][p * b], lengths[3 * (2 * b + k)] * inv_h,
                            lengths[3 * (2 * a + k) + 1] * inv_h, lengths[3 * (2 * a + b) + 2] * inv_h, a, b, k);
        f(corner_index(a, b, k), m);
      }
}

// The centre's scaled Jacobian: J's columns there are the means of each direction's 4 edges.
double centre_scaled_jacobian(const Edges& e) {
  return scaled_triple(bilinear(e.xi, 0.5, 0.5), bilinear(e.eta, 0.5, 0.5), bilinear(e.zeta, 0.5, 0.5));
}

// The sampled measures of quality_of, in one pass over the corners.
struct CornerSummary {
  std::array<double, 9> scaled{};  // scaled_jacobians
  Angle min_angle, max_angle;
  double min_condition_key = std::numeric_limits<double>::infinity();
};

CornerSummary corner_summary(const Edges& e, const std::array<double, 12>& lengths) {
  const UnitEdges n(e, lengths);
  CornerSummary r;
  bool first = true;
  // The three angles of a corner share their sine part s: in the half turn [0, pi) (s >= 0) the
  // angle falls as the cosine part rises, in [pi, 2 pi) it rises with it. So only the largest and
  // the smallest cosine part of a corner can be the hex's extremes.
  auto take = [&](double c_lo, double c_hi, double s) {
    const Angle smallest = make_angle(s >= 0 ? c_hi : c_lo, s), largest = make_angle(s >= 0 ? c_lo : c_hi, s);
    if (first || angle_less(smallest, r.min_angle)) r.min_angle = smallest;
    if (first || angle_less(r.max_angle, largest)) r.max_angle = largest;
    first = false;
  };
  auto take_corner = [&](const Corner& m) {
    const double lo = std::min({m.cosine[0], m.cosine[1], m.cosine[2]});
    const double hi = std::max({m.cosine[0], m.cosine[1], m.cosine[2]});
    take(lo, hi, m.scaled_jacobian);
  };
  if (e.parallel) {
    // Every corner is corner 0 with some edges reversed: the same scaled Jacobian and 1 / kappa,
    // and along each direction the angles theta and 180 - theta, cosine parts c and -c, bit for
    // bit (reversing a vector negates its products exactly).
    const double inv_h = inverse_mean_edge(lengths);
    const Corner m = corner_measures(n.xi[0][0], n.eta[0][0], n.zeta[0][0], n.nxi[0][0], n.neta[0][0], n.nzeta[0][0],
                                     lengths[0] * inv_h, lengths[1] * inv_h, lengths[2] * inv_h, 0, 0, 0);
    r.scaled.fill(m.scaled_jacobian);
    const double a = std::max({std::abs(m.cosine[0]), std::abs(m.cosine[1]), std::abs(m.cosine[2])});
    take(-a, a, m.scaled_jacobian);
    r.min_condition_key = m.condition_key;
  } else {
    for_each_corner(e, lengths, n, [&](int corner, const Corner& m) {
      r.scaled[corner] = m.scaled_jacobian;
      take_corner(m);
      r.min_condition_key = std::min(r.min_condition_key, m.condition_key);
    });
  }
  r.scaled[8] = centre_scaled_jacobian(e);
  return r;
}

}  // namespace

std::array<Vec3, 3> jacobian(const HexCorners& c, double xi, double eta, double zeta) {
  const Edges e(c);
  return {bilinear(e.xi, eta, zeta), bilinear(e.eta, xi, zeta), bilinear(e.zeta, xi, eta)};
}

double jacobian_determinant(const HexCorners& c, double xi, double eta, double zeta) {
  const auto j = jacobian(c, xi, eta, zeta);
  return triple(j[0], j[1], j[2]);
}

BernsteinCoefficients bernstein_jacobian(const HexCorners& c) { return bernstein_from_edges(Edges(c)); }

bool bernstein_certified(const HexCorners& c) { return min_bernstein(c) > 0; }

double min_bernstein(const HexCorners& c) { return min_of(bernstein_jacobian(c)); }

double min_bernstein_scaled(const HexCorners& c) {
  const Edges e(c);
  return scaled_by_size(min_of(bernstein_from_edges(e)), mean_edge(e));
}

double mean_edge_length(const HexCorners& c) { return mean_edge(Edges(c)); }

BernsteinCoefficients bernstein_jacobian(const HexCorners& c, double& mean_length) {
  const Edges e(c);
  mean_length = mean_edge(e);
  return bernstein_from_edges(e);
}

double edge_ratio(const HexCorners& c) { return ratio_of_edges(Edges(c)); }

double hex_volume(const HexCorners& c) { return volume_of(bernstein_jacobian(c)); }

std::array<double, 8> corner_jacobians(const HexCorners& c) {
  const Edges e(c);
  std::array<double, 8> d{};
  for (int z = 0; z < 2; ++z) {
    for (int y = 0; y < 2; ++y) {
      for (int x = 0; x < 2; ++x) {
        d[corner_index(x, y, z)] = triple(e.xi[y][z], e.eta[x][z], e.zeta[x][y]);
      }
    }
  }
  return d;
}

// The scaled Jacobian alone (the .vtu writer's field): the corner triples of corner_summary, the
// same operations, without the angles and the condition number.
std::array<double, 9> scaled_jacobians(const HexCorners& c) {
  const Edges e(c);
  const UnitEdges n(e, e.lengths());
  std::array<double, 9> s{};
  for (int k = 0; k < 2; ++k)
    for (int b = 0; b < 2; ++b)
      for (int a = 0; a < 2; ++a) {
        const int p = e.parallel ? 0 : 1;
        s[corner_index(a, b, k)] = triple(n.xi[p * b][p * k], n.eta[p * a][p * k], n.zeta[p * a][p * b]);
      }
  s[8] = centre_scaled_jacobian(e);
  return s;
}

double scaled_jacobian(const HexCorners& c) {
  const auto s = scaled_jacobians(c);
  return *std::min_element(s.begin(), s.end());
}

namespace {

// normalized() of two vectors, one per lane (norm's sum of squares in its order, then one division
// per component: the same doubles); their lengths in `length`.
void normalized_pair(Vec3 a, Vec3 b, Vec3& ua, Vec3& ub, Double2& length) {
  const Double2 x{a.x, b.x}, y{a.y, b.y}, z{a.z, b.z};
  length = sqrt2(x * x + y * y + z * z);
  // A lane of zero length divides by zero; its quotient is not used.
  const Double2 qx = x / length, qy = y / length, qz = z / length;
  ua = length[0] > 0 ? Vec3{qx[0], qy[0], qz[0]} : Vec3{};
  ub = length[1] > 0 ? Vec3{qx[1], qy[1], qz[1]} : Vec3{};
}

// triple(a[i], b[i], c[i]) for i = 0, 1, one per lane, in cross()'s and dot()'s operations.
Double2 triple_pair(const Vec3 (&a)[2], const Vec3 (&b)[2], const Vec3 (&c)[2]) {
  const Double2 bx{b[0].x, b[1].x}, by{b[0].y, b[1].y}, bz{b[0].z, b[1].z};
  const Double2 cx{c[0].x, c[1].x}, cy{c[0].y, c[1].y}, cz{c[0].z, c[1].z};
  const Double2 ax{a[0].x, a[1].x}, ay{a[0].y, a[1].y}, az{a[0].z, a[1].z};
  return ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx);
}

}  // namespace

MovingCorner::MovingCorner(const HexCorners& p, int corner) {
  c_ = corner >> 2;
  b_ = (corner & 3) >= 2;
  a_ = b_ ? 3 - (corner & 3) : corner & 3;
  const int a = a_, b = b_, k = c_;
  end_[0] = p[corner_index(1 - a, b, k)];
  end_[1] = p[corner_index(a, 1 - b, k)];
  end_[2] = p[corner_index(a, b, 1 - k)];
  const Edges e(p);
  // The 9 edges that do not touch the corner, at unit length as scaled_jacobians has them
  // (normalized_by of lengths() is normalized()), two at a time.
  Vec3 unit_xi[2][2], unit_eta[2][2], unit_zeta[2][2];
  const Vec3* edge[9];
  Vec3* unit[9];
  int n = 0;
  for (int u = 0; u < 2; ++u)
    for (int v = 0; v < 2; ++v) {
      if (!(u == b && v == k)) edge[n] = &e.xi[u][v], unit[n++] = &unit_xi[u][v];
      if (!(u == a && v == k)) edge[n] = &e.eta[u][v], unit[n++] = &unit_eta[u][v];
      if (!(u == a && v == b)) edge[n] = &e.zeta[u][v], unit[n++] = &unit_zeta[u][v];
    }
  short_ = std::numeric_limits<double>::infinity();
  long_ = 0;
  Vec3 spare;
  for (int i = 0; i < 9; i += 2) {
    Double2 length;
    normalized_pair(*edge[i], i + 1 < 9 ? *edge[i + 1] : *edge[i], *unit[i], i + 1 < 9 ? *unit[i + 1] : spare, length);
    // The extremes of the 12 lengths do not depend on their order (never NaN), so the fixed ones
    // are taken here, as ratio_of_edges takes them.
    for (int l = 0; l < (i + 1 < 9 ? 2 : 1); ++l) {
      short_ = std::min(short_, length[l]);
      long_ = std::max(long_, length[l]);
    }
  }
  neighbour_[0][0] = unit_eta[1 - a][k];
  neighbour_[0][1] = unit_zeta[1 - a][b];
  neighbour_[1][0] = unit_xi[1 - b][k];
  neighbour_[1][1] = unit_zeta[a][1 - b];
  neighbour_[2][0] = unit_xi[b][1 - k];
  neighbour_[2][1] = unit_eta[a][1 - k];
  // The 4 corners off the moving corner's edges: (1-a, 1-b, k), (1-a, b, 1-k), (a, 1-b, 1-k),
  // (1-a, 1-b, 1-k).
  const int far[4][3] = {{1 - a, 1 - b, k}, {1 - a, b, 1 - k}, {a, 1 - b, 1 - k}, {1 - a, 1 - b, 1 - k}};
  fixed_min_ = std::numeric_limits<double>::infinity();
  for (int f = 0; f < 4; f += 2) {
    Vec3 x[2], y[2], z[2];
    for (int l = 0; l < 2; ++l) {
      const int* r = far[f + l];
      x[l] = unit_xi[r[1]][r[2]];
      y[l] = unit_eta[r[0]][r[2]];
      z[l] = unit_zeta[r[0]][r[1]];
    }
    const Double2 value = triple_pair(x, y, z);
    for (int l = 0; l < 2; ++l) {
      const int* r = far[f + l];
      fixed_[corner_index(r[0], r[1], r[2])] = value[l];
      fixed_min_ = std::min(fixed_min_, value[l]);
    }
  }
  // The xi neighbour's triple is dot(moving unit xi, cross of its two fixed columns).
  xi_cross_ = cross(neighbour_[0][0], neighbour_[0][1]);
  // bilinear(e, 0.5, 0.5) = 0.5 * (0.5 * e[0][0] + 0.5 * e[0][1]) + 0.5 * (0.5 * e[1][0] + ...)
  // with the moving edge xi[b][k], eta[a][k], zeta[a][b]: IEEE addition is commutative, so where
  // the moving edge sits in its sum does not change a bit, and the products of fixed edges by 0.5
  // are the same computed here.
  half_partner_[0] = 0.5 * e.xi[b][1 - k];
  half_partner_[1] = 0.5 * e.eta[a][1 - k];
  half_partner_[2] = 0.5 * e.zeta[a][1 - b];
  half_other_[0] = 0.5 * (0.5 * e.xi[1 - b][0] + 0.5 * e.xi[1 - b][1]);
  half_other_[1] = 0.5 * (0.5 * e.eta[1 - a][0] + 0.5 * e.eta[1 - a][1]);
  half_other_[2] = 0.5 * (0.5 * e.zeta[1 - a][0] + 0.5 * e.zeta[1 - a][1]);
}

bool MovingCorner::scaled_jacobians(Vec3 y, double floor, std::array<double, 9>& s) const {
  if (fixed_min_ < floor) return false;
  const int a = a_, b = b_, k = c_;
  const Vec3 moving[3] = {a ? y - end_[0] : end_[0] - y, b ? y - end_[1] : end_[1] - y, k ? y - end_[2] : end_[2] - y};
  Vec3 column[3];  // the centre's Jacobian columns
  for (int d = 0; d < 3; ++d) column[d] = 0.5 * (0.5 * moving[d] + half_partner_[d]) + half_other_[d];
  Vec3 u[3], w[3];
  Double2 length;
  normalized_pair(moving[0], moving[1], u[0], u[1], length);
  normalized_pair(moving[2], column[0], u[2], w[0], length);
  normalized_pair(column[1], column[2], w[1], w[2], length);
  s = fixed_;
  const double own = triple(u[0], u[1], u[2]), along_xi = dot(u[0], xi_cross_);
  const double along_eta = triple(neighbour_[1][0], u[1], neighbour_[1][1]);
  const double along_zeta = triple(neighbour_[2][0], neighbour_[2][1], u[2]);
  s[corner_index(a, b, k)] = own;
  s[corner_index(1 - a, b, k)] = along_xi;
  s[corner_index(a, 1 - b, k)] = along_eta;
  s[corner_index(a, b, 1 - k)] = along_zeta;
  s[8] = triple(w[0], w[1], w[2]);
  return !(own < floor || along_xi < floor || along_eta < floor || along_zeta < floor || s[8] < floor);
}

double MovingCorner::scaled_jacobian(Vec3 y, double floor) const {
  std::array<double, 9> s;
  if (!scaled_jacobians(y, floor, s)) return -std::numeric_limits<double>::infinity();
  // std::min_element's value: the first of the least (a later value replaces it only if less).
  double lowest = s[0];
  for (int i = 1; i < 9; ++i) lowest = std::min(lowest, s[i]);
  return lowest;
}

double MovingCorner::edge_ratio(Vec3 y) const {
  // min and max of the 12 lengths (in any order: they are never NaN), as ratio_of_edges.
  double lo = short_, hi = long_;
  for (int d = 0; d < 3; ++d) {
    const double l = norm(y - end_[d]);
    lo = std::min(lo, l);
    hi = std::max(hi, l);
  }
  return lo > 0 ? hi / lo : std::numeric_limits<double>::infinity();
}

std::array<double, 24> dihedral_angles(const HexCorners& c) {
  const Edges e(c, /*shortcuts=*/false);
  const std::array<double, 12> lengths = e.lengths();
  std::array<double, 24> angles{};
  for_each_corner(e, lengths, UnitEdges(e, lengths), [&](int corner, const Corner& m) {
    for (int d = 0; d < 3; ++d) angles[3 * corner + d] = degrees(m.dihedral(d));
  });
  return angles;
}

std::array<double, 8> inverse_conditions(const HexCorners& c) {
  const Edges e(c, /*shortcuts=*/false);
  const std::array<double, 12> lengths = e.lengths();
  std::array<double, 8> v{};
  for_each_corner(e, lengths, UnitEdges(e, lengths),
                  [&](int corner, const Corner& m) { v[corner] = inverse_condition_of(m.condition_key); });
  return v;
}

double inverse_condition(const HexCorners& c) {
  const auto v = inverse_conditions(c);
  return *std::min_element(v.begin(), v.end());
}

namespace {

// A right box with positive orientation whose edges lie along the coordinate axes (a parallelepiped
// whose three edge vectors each have one non-zero component, on three different axes, of a size
// whose square and half are normal doubles), or nothing. Most hexes of a mesh are such boxes: the
// grid's uncut cells and the 8 hexes of each one's midpoint subdivision (97 % of the outside mesh of
// a torus at depth 4). For them the general measures below take values fixed bit for bit:
//  - every unit edge is exactly +-1 on its axis (sqrt(x * x) is |x| for any x whose square is a
//    normal double, and x / |x| is exact), so every corner's scaled Jacobian is the triple of three
//    signed unit vectors, exactly 1 for a positive box, and the centre's is the same triple (the
//    bilinear means of four equal edges are the edge itself: halves and sums of halves are exact);
//  - every cosine part of the dihedral angles is +-0, so both extreme angles are atan2(1, +-0), 90
//    degrees;
// which leaves the Bernstein coefficients, the condition number and the lengths to compute, by the
// same operations as the general path (tests: quality.AxisAlignedBoxesAreBitIdentical). About half
// the work of a parallelepiped: no centre normalisation and no atan2.
std::optional<HexQuality> axis_box_quality(const Edges& e) {
  if (!e.parallel) return std::nullopt;
  const Vec3 edge[3] = {e.xi[0][0], e.eta[0][0], e.zeta[0][0]};
  unsigned axes = 0;
  for (const Vec3& v : edge) {
    int nonzero = 0, axis = 0;
    for (int a = 0; a < 3; ++a) {
      if (v[a] == 0) continue;
      ++nonzero;
      axis = a;
      // Squares and halves stay normal doubles: the exactness argument above holds.
      if (!(std::abs(v[a]) > 0x1p-400 && std::abs(v[a]) < 0x1p400)) return std::nullopt;
    }
    if (nonzero != 1) return std::nullopt;
    axes |= 1u << axis;
  }
  if (axes != 7) return std::nullopt;
  const BernsteinCoefficients beta = bernstein_from_edges(e);
  HexQuality q;
  // Every corner coefficient (all indices in {0, 2}) averages one triple: the same value.
  q.min_corner_jacobian = beta[bernstein_index(0, 0, 0)];
  if (!(q.min_corner_jacobian > 0)) return std::nullopt;  // inverted or flat: the general path
  q.min_bernstein = min_of(beta);
  const std::array<double, 12> lengths = e.lengths();
  q.min_bernstein_scaled = scaled_by_size(q.min_bernstein, mean_edge(lengths));
  const UnitEdges n(e, lengths);
  const double inv_h = inverse_mean_edge(lengths);
  const Corner m = corner_measures(n.xi[0][0], n.eta[0][0], n.zeta[0][0], n.nxi[0][0], n.neta[0][0], n.nzeta[0][0],
                                   lengths[0] * inv_h, lengths[1] * inv_h, lengths[2] * inv_h, 0, 0, 0);
  q.scaled_jacobian = m.scaled_jacobian;
  static const double right_angle = degrees(Angle{0, 1});
  q.min_dihedral_angle = right_angle;
  q.max_dihedral_angle = right_angle;
  q.inverse_condition = inverse_condition_of(m.condition_key);
  q.edge_ratio = ratio_of_edges(lengths);
  q.volume = volume_of(beta);
  return q;
}

HexQuality quality_of(const Edges& e) {
  if (const std::optional<HexQuality> box = axis_box_quality(e)) return *box;
  const BernsteinCoefficients beta = bernstein_from_edges(e);
  HexQuality q;
  // The corner values of det J are the Bernstein coefficients with all indices in {0, 2}.
  q.min_corner_jacobian = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; k += 2) {
    for (int j = 0; j < 3; j += 2) {
      for (int i = 0; i < 3; i += 2) {
        q.min_corner_jacobian = std::min(q.min_corner_jacobian, beta[bernstein_index(i, j, k)]);
      }
    }
  }
  q.min_bernstein = min_of(beta);
  const std::array<double, 12> lengths = e.lengths();
  q.min_bernstein_scaled = scaled_by_size(q.min_bernstein, mean_edge(lengths));
  const CornerSummary corners = corner_summary(e, lengths);
  q.scaled_jacobian = *std::min_element(corners.scaled.begin(), corners.scaled.end());
  q.min_dihedral_angle = degrees(corners.min_angle);
  q.max_dihedral_angle = degrees(corners.max_angle);
  q.inverse_condition = inverse_condition_of(corners.min_condition_key);
  q.edge_ratio = ratio_of_edges(lengths);
  q.volume = volume_of(beta);
  return q;
}

}  // namespace

HexQuality hex_quality(const HexCorners& c) { return quality_of(Edges(c)); }

bool is_parallelepiped(const HexCorners& c) { return Edges(c).parallel; }

HexQuality QualityCache::operator()(const HexCorners& c) {
  const Edges e(c);
  if (!e.parallel) return quality_of(e);
  std::array<double, 9> key;
  std::memcpy(key.data(), &e.xi[0][0], sizeof(Vec3));
  std::memcpy(key.data() + 3, &e.eta[0][0], sizeof(Vec3));
  std::memcpy(key.data() + 6, &e.zeta[0][0], sizeof(Vec3));
  // A multiplicative hash over the nine doubles' bits, its top bits the slot: a grid's edges
  // differ from their neighbours' in low mantissa bits, which the products carry upwards.
  uint64_t h = 0;
  for (double d : key) {
    uint64_t bits;
    std::memcpy(&bits, &d, sizeof bits);
    h = (h ^ bits) * 0x9E3779B97F4A7C15ull;
    h ^= h >> 32;
  }
  Slot& s = slots_[h * 0x9E3779B97F4A7C15ull >> (64 - kSlotBits)];
  if (s.used && std::memcmp(s.key.data(), key.data(), sizeof key) == 0) {
    ++hits_;
    return s.quality;
  }
  s.key = key;
  s.quality = quality_of(e);
  s.used = true;
  return s.quality;
}

namespace detail {
HexQuality hex_quality_without_shortcuts(const HexCorners& c) { return quality_of(Edges(c, false)); }
bool takes_axis_box_path(const HexCorners& c) { return axis_box_quality(Edges(c)).has_value(); }
}  // namespace detail

}  // namespace mchex
