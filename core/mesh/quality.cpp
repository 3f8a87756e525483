#include "core/mesh/quality.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <limits>

namespace mchex {
namespace {

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
    int n = 0;
    for_each([&](Vec3 v) { l[n++] = norm(v); });
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
// then c, ascending), as indices ((((a * 2 + a') * 2 + b) * 2 + b') * 2 + c) * 2 + c' into the
// triples below: a fixed table, so the per-hex work is 64 dot products and 64 additions.
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
                  static_cast<std::uint8_t>(((((a * 2 + (i - a)) * 2 + b) * 2 + (j - b)) * 2 + c) * 2 + (k - c));
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

BernsteinCoefficients bernstein_from_triples(const std::array<double, 64>& triples) {
  BernsteinCoefficients beta{};
  for (int n = 0; n < 27; ++n) {
    double sum = 0;
    for (int t = 0; t < kTripleTerms.count[n]; ++t) sum += triples[kTripleTerms.index[n][t]];
    beta[n] = mean_of_sum(sum, kTripleTerms.count[n]);
  }
  return beta;
}

BernsteinCoefficients bernstein_from_edges(const Edges& e) {
  std::array<double, 64> triples;
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
  // used by four of the 64 triples, computed once (the same operations, so the same doubles).
  Vec3 eta_zeta[2][2][2][2];  // [a][c'][a'][b']
  for (int a = 0; a < 2; ++a)
    for (int c = 0; c < 2; ++c)
      for (int a2 = 0; a2 < 2; ++a2)
        for (int b = 0; b < 2; ++b) eta_zeta[a][c][a2][b] = cross(e.eta[a][c], e.zeta[a2][b]);
  for (int a = 0; a < 2; ++a)
    for (int a2 = 0; a2 < 2; ++a2)
      for (int b = 0; b < 2; ++b)
        for (int b2 = 0; b2 < 2; ++b2)
          for (int c = 0; c < 2; ++c)
            for (int c2 = 0; c2 < 2; ++c2)
              triples[((((a * 2 + a2) * 2 + b) * 2 + b2) * 2 + c) * 2 + c2] = dot(e.xi[b][c], eta_zeta[a][c2][a2][b2]);
  return bernstein_from_triples(triples);
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

std::array<double, 9> scaled_from_edges(const Edges& e, const std::array<double, 12>& lengths) {
  // Each edge meets two corners: normalized once.
  std::array<double, 9> s{};
  if (e.parallel) {
    // Every corner's triple is the same one.
    s.fill(triple(normalized_by(e.xi[0][0], lengths[0]), normalized_by(e.eta[0][0], lengths[1]),
                  normalized_by(e.zeta[0][0], lengths[2])));
    s[8] = scaled_triple(bilinear(e.xi, 0.5, 0.5), bilinear(e.eta, 0.5, 0.5), bilinear(e.zeta, 0.5, 0.5));
    return s;
  }
  Vec3 xi[2][2], eta[2][2], zeta[2][2];
  for (int u = 0; u < 2; ++u)
    for (int v = 0; v < 2; ++v) {
      const int n = 3 * (2 * u + v);  // Edges::for_each order
      xi[u][v] = normalized_by(e.xi[u][v], lengths[n]);
      eta[u][v] = normalized_by(e.eta[u][v], lengths[n + 1]);
      zeta[u][v] = normalized_by(e.zeta[u][v], lengths[n + 2]);
    }
  for (int c = 0; c < 2; ++c) {
    for (int b = 0; b < 2; ++b) {
      for (int a = 0; a < 2; ++a) {
        s[corner_index(a, b, c)] = triple(xi[b][c], eta[a][c], zeta[a][b]);
      }
    }
  }
  s[8] = scaled_triple(bilinear(e.xi, 0.5, 0.5), bilinear(e.eta, 0.5, 0.5), bilinear(e.zeta, 0.5, 0.5));
  return s;
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

std::array<double, 9> scaled_jacobians(const HexCorners& c) {
  const Edges e(c);
  return scaled_from_edges(e, e.lengths());
}

double scaled_jacobian(const HexCorners& c) {
  const auto s = scaled_jacobians(c);
  return *std::min_element(s.begin(), s.end());
}

namespace {

HexQuality quality_of(const Edges& e) {
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
  const auto s = scaled_from_edges(e, lengths);
  q.scaled_jacobian = *std::min_element(s.begin(), s.end());
  q.edge_ratio = ratio_of_edges(lengths);
  q.volume = volume_of(beta);
  return q;
}

}  // namespace

HexQuality hex_quality(const HexCorners& c) { return quality_of(Edges(c)); }

bool is_parallelepiped(const HexCorners& c) { return Edges(c).parallel; }

namespace detail {
HexQuality hex_quality_without_shortcuts(const HexCorners& c) { return quality_of(Edges(c, false)); }
}  // namespace detail

}  // namespace mchex
