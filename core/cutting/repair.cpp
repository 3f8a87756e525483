// Mapped midpoint subdivision with a volume-centre search; see repair.h.
#include "core/cutting/repair.h"

#include "core/cutting/volume_centre_offset.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>

namespace mchex {
namespace {

// The least coefficient is a max-min of polynomials in the centre (the hex's corner-6 coefficient
// is even linear in it: the signed volume of the centre over the plane of its three neighbours),
// so a plain local search stalls at the kink where two hexes' coefficients cross (measured: a
// 26-direction compass search leaves case 5 on the node type at -1.5e-4 where a grid finds
// +6e-7). Sequential linear programming handles the kinks: linearize the coefficients that can
// bind within a trust region, maximize their least value over the box (a 4-variable LP, solved
// exactly by its vertices), accept the step if the true least coefficient grows, else shrink.
constexpr double kFirstRadius = 0.1;  // trust-region half-width, in mean hex edges L
constexpr double kMaxRadius = 0.5;
constexpr double kLeastRadius = 1e-7;      // stop below this
constexpr double kCertifiedRadius = 1e-3;  // once certified, stop below this
constexpr double kDerivativeStep = 1e-6;   // central differences, in L (the coefficients are cubic)
constexpr int kMaxIterations = 60;
constexpr std::size_t kMaxActive = 8;  // linearized coefficients per LP (with the 6 box sides)

// 1 / (mean edge)^3: a hex's coefficients times this are its scaled coefficients.
double coefficient_scale(double mean_length) { return 1.0 / (mean_length * mean_length * mean_length); }

// Every scaled coefficient (beta / mean edge^3) of every hex, hex-major.
void scaled_coefficients(const std::vector<SubdivisionHex>& hexes, std::vector<double>& out) {
  out.resize(27 * hexes.size());
  double* o = out.data();
  for (const SubdivisionHex& h : hexes) {
    double l = 0;
    const BernsteinCoefficients beta = bernstein_jacobian(h.corners, l);
    const double scale = coefficient_scale(l);
    for (double b : beta) *o++ = b * scale;
  }
}

// The value std::min_element finds (the first least; a NaN in front stays), kept in a register.
double least_of(const double* v, std::size_t n) {
  double m = v[0];
  for (std::size_t i = 1; i < n; ++i)
    if (v[i] < m) m = v[i];
  return m;
}

// min_element's value over beta[k] * scale, one product at a time.
double least_of_products(const BernsteinCoefficients& beta, double scale) {
  double m = beta[0] * scale;
  for (int k = 1; k < 27; ++k) {
    const double v = beta[k] * scale;
    if (v < m) m = v;
  }
  return m;
}

// The same value from the least coefficient: for a positive finite scale, rounding is monotonic,
// so the least product is the least coefficient's product, a double of that value; and equal
// values are the same double unless they are zeros. So where no coefficient is NaN (their sum is
// not), the scale is positive and finite, and the product is a normal number, `least` is exactly
// least_of_products (found two coefficients per operation); else false, and the caller folds
// the products (and the hexes' list) in order.
bool least_scaled(const BernsteinCoefficients& beta, double scale, double& least) {
  auto pair = [&](int k) {
    Double2 v;
    std::memcpy(&v, &beta[k], sizeof v);
    return v;
  };
  Double2 lo = pair(0), sum = lo;
  for (int k = 2; k < 26; k += 2) {
    const Double2 v = pair(k);
    lo = v < lo ? v : lo;
    sum += v;
  }
  const double mu = std::min({lo[0], lo[1], beta[26]});
  const double probe = sum[0] + sum[1] + beta[26];
  least = mu * scale;
  return !std::isnan(probe) && scale > 0 && std::isfinite(scale) && std::isnormal(least);
}

// max t subject to t <= c_k + g_k . d (the rows) and |d_i| <= r: the optimum is a vertex, where 4
// of the constraints hold with equality; every 4-subset is solved (Gauss-Jordan elimination with
// partial pivoting) and the best feasible one kept. Rows are few (kMaxActive + 6), so this is
// cheap and exact.
struct LpRow {
  std::array<double, 4> a;  // a . (d, t) <= b
  double b;
};

// One vertex: the 4 rows' equalities a . (d, t) = b, by Gauss-Jordan elimination with partial
// pivoting. Column by column the pivot row reduces every other row: the rows below it (forward)
// and the earlier pivots above it (backward). The last row is never above a pivot, so t = x[3]
// follows from the forward reductions alone, and solve_lp needs the rest only for a vertex whose t
// beats the best so far. So the halves run apart: forward2 leaves each row as it was when it
// became the pivot, which is all backward2 reads, and backward2 reduces each earlier row by the
// later pivots in column order. Every value is the one the whole elimination gives; an entry in a
// column already done, never read again, is not computed. Both run on two systems at once, one
// per lane of a Double2 (each system is a chain of divisions, and the lanes run two chains for the
// price of one): on each lane the operations of the scalar elimination, its pivot (the first row
// of largest magnitude) chosen and its rows swapped by a select per lane.
using VertexSystems = std::array<std::array<Double2, 5>, 4>;
using Mask2 = decltype(Double2{} < Double2{});  // per lane: all ones (true) or zero

Double2 abs2(Double2 v) {  // std::abs: the sign bit cleared
  const Mask2 magnitude{0x7fffffffffffffff, 0x7fffffffffffffff};
  return Double2(Mask2(v) & magnitude);
}

// Returns the lanes whose pivot is below 1e-14 (singular; their later values, which the scalar
// elimination would not compute, are not read) and t per lane.
Mask2 forward2(VertexSystems& m, Double2& t) {
  Mask2 singular{0, 0};
  for (int c = 0; c < 4; ++c) {
    Double2 largest = abs2(m[c][c]);
    Mask2 piv{c, c};
    for (int r = c + 1; r < 4; ++r) {
      const Double2 a = abs2(m[r][c]);
      const Mask2 larger = a > largest;
      largest = larger ? a : largest;
      piv = larger ? Mask2{r, r} : piv;
    }
    singular |= largest < Double2{1e-14, 1e-14};
    for (int r = c + 1; r < 4; ++r) {
      const Mask2 swap = piv == Mask2{r, r};
      for (int k = c; k < 5; ++k) {
        const Double2 above = m[c][k];
        m[c][k] = swap ? m[r][k] : above;
        m[r][k] = swap ? above : m[r][k];
      }
    }
    for (int r = c + 1; r < 4; ++r) {
      const Double2 f = m[r][c] / m[c][c];
      for (int k = c + 1; k < 5; ++k) m[r][k] -= f * m[c][k];
    }
  }
  t = m[3][4] / m[3][3];
  return singular;
}

// The backward half, on the same lanes: x per lane.
void backward2(VertexSystems& m, std::array<Double2, 4>& x) {
  for (int r = 0; r < 3; ++r) {
    for (int c = r + 1; c < 4; ++c) {
      const Double2 f = m[r][c] / m[c][c];
      for (int k = c + 1; k < 5; ++k) m[r][k] -= f * m[c][k];
    }
    x[r] = m[r][4] / m[r][r];
  }
  x[3] = m[3][4] / m[3][3];
}

// rows: the linearized coefficients, then the 6 box sides (+x, -x, +y, -y, +z, -z), as the
// search builds them. A 4-subset with no coefficient row (t's column is zero) or with both sides
// of one axis (two opposite rows) is singular, and the elimination would find a pivot below 1e-14:
// those subsets are skipped before it, which leaves the result as it was.
bool solve_lp(const std::vector<LpRow>& rows, std::array<double, 4>& best) {
  const std::size_t n = rows.size();
  const std::size_t first_side = n - 6;
  // Bit a set: the row is a side of axis a; 8: a coefficient row.
  auto kind = [&](std::size_t r) { return r < first_side ? 8u : 1u << ((r - first_side) / 2); };
  // The subsets to solve, in the order of the loops (which decides among vertices of equal t).
  std::array<std::array<std::uint8_t, 4>, 1001> subsets;
  std::size_t count = 0;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      if (kind(i) == kind(j) && kind(i) != 8u) continue;
      for (std::size_t k = j + 1; k < n; ++k) {
        const unsigned ijk = kind(i) | kind(j);
        if ((ijk & kind(k) & 7u) != 0) continue;
        for (std::size_t l = k + 1; l < n; ++l) {
          const unsigned all = ijk | kind(k);
          if ((all & kind(l) & 7u) != 0 || ((all | kind(l)) & 8u) == 0) continue;
          subsets[count++] = {static_cast<std::uint8_t>(i), static_cast<std::uint8_t>(j), static_cast<std::uint8_t>(k),
                              static_cast<std::uint8_t>(l)};
        }
      }
    }
  bool found = false;
  const double tol = 1e-12;
  // One subset's vertex, in the subsets' order: kept if its t beats the best so far and it is
  // feasible.
  auto consider = [&](const std::array<Double2, 4>& xs, int lane) {
    const std::array<double, 4> x = {xs[0][lane], xs[1][lane], xs[2][lane], xs[3][lane]};
    if (found && x[3] <= best[3]) return;
    for (const LpRow& row : rows) {
      const double lhs = row.a[0] * x[0] + row.a[1] * x[1] + row.a[2] * x[2] + row.a[3] * x[3];
      if (lhs > row.b + tol * (1 + std::abs(row.b))) return;
    }
    best = x;
    found = true;
  };
  auto load = [&](std::size_t s, VertexSystems& m) {
    const auto& first = subsets[std::min(s, count - 1)];
    const auto& second = subsets[std::min(s + 1, count - 1)];  // past the end: the last again, not read
    for (int r = 0; r < 4; ++r) {
      const LpRow& p = rows[first[r]];
      const LpRow& q = rows[second[r]];
      for (int c = 0; c < 4; ++c) m[r][c] = Double2{p.a[c], q.a[c]};
      m[r][4] = Double2{p.b, q.b};
    }
  };
  // Four subsets per step, two systems of two lanes: independent chains the processor overlaps.
  // Most vertices that are not singular beat the best so far (many of them infeasible), so the
  // backward half runs on both lanes of a system unless neither can (the best only grows).
  for (std::size_t s = 0; s < count; s += 4) {
    VertexSystems m0, m1;
    load(s, m0);
    load(s + 2, m1);
    Double2 t0, t1;
    const Mask2 singular0 = forward2(m0, t0), singular1 = forward2(m1, t1);
    const std::array<bool, 4> open = {!singular0[0], s + 1 < count && !singular0[1], s + 2 < count && !singular1[0],
                                      s + 3 < count && !singular1[1]};
    const std::array<double, 4> t = {t0[0], t0[1], t1[0], t1[1]};
    std::array<bool, 4> can{};
    for (int i = 0; i < 4; ++i) can[i] = open[i] && !(found && t[i] <= best[3]);
    std::array<Double2, 4> x0, x1;
    if (can[0] || can[1]) backward2(m0, x0);
    if (can[2] || can[3]) backward2(m1, x1);
    for (int i = 0; i < 4; ++i)
      if (can[i]) consider(i < 2 ? x0 : x1, i % 2);
  }
  return found;
}

// trilinear_map (quality.h) of every hex corner, two corners per operation: on each lane, per
// coordinate, trilinear_map's exact_lerp (geometry.h), whose first four differences b - a are the
// cell's own and computed once. Every mapped coordinate is trilinear_map's double.
void map_corners(const HexCorners& cell, std::vector<SubdivisionHex>& hexes) {
  auto both = [](double v) { return Double2{v, v}; };
  // exact_lerp on each lane, given b - a.
  auto lerp = [](Double2 a, Double2 b, Double2 d, Double2 s) {
    const Double2 from_a = a + s * d, from_b = b - (1.0 - s) * d;
    return s < 0.5 ? from_a : from_b;
  };
  // Per coordinate: the four lerps along x, (c0, c1), (c3, c2), (c4, c5), (c7, c6), as a, b and
  // b - a.
  std::array<std::array<Double2, 12>, 3> lerps;
  for (int j = 0; j < 3; ++j) {
    const int pairs[4][2] = {{0, 1}, {3, 2}, {4, 5}, {7, 6}};
    for (int q = 0; q < 4; ++q) {
      const double a = cell[pairs[q][0]][j], b = cell[pairs[q][1]][j];
      lerps[j][3 * q] = both(a);
      lerps[j][3 * q + 1] = both(b);
      lerps[j][3 * q + 2] = both(b - a);
    }
  }
  for (SubdivisionHex& h : hexes)
    for (int i = 0; i < 8; i += 2) {
      Vec3& p = h.corners[i];
      Vec3& q = h.corners[i + 1];
      const Double2 tx{p.x, q.x}, ty{p.y, q.y}, tz{p.z, q.z};
      Double2 mapped[3];
      for (int j = 0; j < 3; ++j) {
        const std::array<Double2, 12>& l = lerps[j];
        const Double2 a01 = lerp(l[0], l[1], l[2], tx), a32 = lerp(l[3], l[4], l[5], tx);
        const Double2 a45 = lerp(l[6], l[7], l[8], tx), a76 = lerp(l[9], l[10], l[11], tx);
        const Double2 y0 = lerp(a01, a32, a32 - a01, ty), y1 = lerp(a45, a76, a76 - a45, ty);
        mapped[j] = lerp(y0, y1, y1 - y0, tz);
      }
      p = {mapped[0][0], mapped[1][0], mapped[2][0]};
      q = {mapped[0][1], mapped[1][1], mapped[2][1]};
    }
}

// subdivide_in_cell on out.hexes, which hold the parametric hexes: mapped, checked, repaired.
void map_check_and_repair(const HexCorners& cell, MappedSubdivision& out) {
  map_corners(cell, out.hexes);
  out.centre_moved = false;
  // Scaled coefficients have the sign of the coefficients (the scale is a positive length cubed;
  // a hex with all corners equal gives NaN, which counts as not certified).
  auto finish = [&](double least_value) {
    out.min_scaled = least_value;
    out.certified = true;
    for (double v : out.hex_min_scaled) out.certified = out.certified && v > 0;
  };
  // Plain subdivision, which certifies almost every polyhedron: each hex's least scaled
  // coefficient and the least over all hexes, the values min_element finds in the hex-major list
  // of every scaled coefficient, without that list. Where no coefficient is NaN, the least over
  // all hexes is the least of the hexes' least (the first least value either way).
  const std::size_t n = out.hexes.size();
  out.hex_min_scaled.resize(n);
  double plain_least = 0;
  bool any_nan = false;
  for (std::size_t i = 0; i < n; ++i) {
    double l = 0;
    const BernsteinCoefficients beta = bernstein_jacobian(out.hexes[i].corners, l);
    const double scale = coefficient_scale(l);
    double hex_least = 0;
    if (!least_scaled(beta, scale, hex_least)) {
      hex_least = least_of_products(beta, scale);
      for (double b : beta) any_nan = any_nan || std::isnan(b * scale);
    }
    out.hex_min_scaled[i] = hex_least;
    plain_least = i == 0 || hex_least < plain_least ? hex_least : plain_least;
  }
  if (any_nan) {  // the list's own order decides where a NaN is (never seen on real hexes)
    std::vector<double> all;
    scaled_coefficients(out.hexes, all);
    plain_least = least_of(all.data(), all.size());
  }
  if (plain_least > 0) {
    finish(plain_least);
    return;
  }
  out.centre_moved = true;
  std::vector<double> beta;
  auto least = [&] {
    scaled_coefficients(out.hexes, beta);
    for (std::size_t i = 0; i < n; ++i) out.hex_min_scaled[i] = least_of(beta.data() + 27 * i, 27);
    return least_of(beta.data(), beta.size());
  };
  least();
  // Corner 6 of every hex is the volume centre (subdivide.h).
  auto place = [&](const Vec3& c) {
    for (SubdivisionHex& h : out.hexes) h.corners[6] = c;
  };
  double length = 0;
  for (const SubdivisionHex& h : out.hexes) length += mean_edge_length(h.corners);
  length /= static_cast<double>(out.hexes.size());

  Vec3 centre = out.hexes.front().corners[6];
  double best = plain_least;
  std::vector<double> value = beta, plus, minus;
  std::array<std::vector<double>, 3> grad;
  double radius = kFirstRadius * length;
  const double h = kDerivativeStep * length;
  for (int it = 0; it < kMaxIterations && radius > kLeastRadius * length; ++it) {
    // Certified and the steps already small: more would only add margin to a tiny coefficient.
    if (best > 0 && radius < kCertifiedRadius * length) break;
    for (int axis = 0; axis < 3; ++axis) {
      Vec3 e{};
      e[axis] = h;
      place(centre + e);
      scaled_coefficients(out.hexes, plus);
      place(centre - e);
      scaled_coefficients(out.hexes, minus);
      grad[axis].resize(plus.size());
      for (std::size_t k = 0; k < plus.size(); ++k) grad[axis][k] = (plus[k] - minus[k]) / (2 * h);
    }
    // Coefficients that can bind within the box: lower bound over the box below the least upper
    // bound of any coefficient; the lowest kMaxActive of them.
    double upper = std::numeric_limits<double>::infinity();
    std::vector<std::pair<double, std::size_t>> lower(value.size());
    for (std::size_t k = 0; k < value.size(); ++k) {
      const double reach = radius * (std::abs(grad[0][k]) + std::abs(grad[1][k]) + std::abs(grad[2][k]));
      upper = std::min(upper, value[k] + reach);
      lower[k] = {value[k] - reach, k};
    }
    // Only the lowest kMaxActive can be taken: ordered as a full sort would (pairs order totally).
    const std::size_t take = std::min(lower.size(), kMaxActive);
    std::partial_sort(lower.begin(), lower.begin() + static_cast<std::ptrdiff_t>(take), lower.end());
    std::vector<LpRow> rows;
    for (std::size_t i = 0; i < lower.size() && rows.size() < kMaxActive && lower[i].first <= upper; ++i) {
      const std::size_t k = lower[i].second;
      rows.push_back({{-grad[0][k], -grad[1][k], -grad[2][k], 1.0}, value[k]});
    }
    for (int axis = 0; axis < 3; ++axis)
      for (double sign : {1.0, -1.0}) {
        LpRow row{{0, 0, 0, 0}, radius};
        row.a[axis] = sign;
        rows.push_back(row);
      }
    std::array<double, 4> x{};
    if (!solve_lp(rows, x) || x[3] <= best) {
      radius *= 0.5;
      continue;
    }
    const Vec3 trial = centre + Vec3{x[0], x[1], x[2]};
    place(trial);
    scaled_coefficients(out.hexes, plus);
    const double v = least_of(plus.data(), plus.size());
    if (v > best) {
      best = v;
      centre = trial;
      value = plus;
      radius = std::min(radius * 1.5, kMaxRadius * length);
    } else {
      radius *= 0.5;
    }
  }
  place(centre);
  least();
  finish(best);
}

}  // namespace

MappedSubdivision subdivide_in_cell(const Polyhedron& parametric, const HexCorners& cell) {
  MappedSubdivision out;
  out.hexes = midpoint_subdivide(parametric);
  map_check_and_repair(cell, out);
  return out;
}

void subdivide_in_cell(const Polyhedron& parametric, const HexCorners& cell, MappedSubdivision& out) {
  midpoint_subdivide(parametric, out.hexes);
  map_check_and_repair(cell, out);
}

bool uncut_affine_cell_certified(const HexCorners& x) {
  if (cell_shape(x) != CellShape::kAffine) return false;
  const Vec3 a = x[1] - x[0], b = x[3] - x[0], c = x[4] - x[0];
  const double size = std::max({norm(a), norm(b), norm(c)});
  return dot(a, cross(b, c)) > 1e-6 * size * size * size;
}

}  // namespace mchex
