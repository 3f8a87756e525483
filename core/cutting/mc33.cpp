// MC33 classification of one cell (see mc33.h for the conventions and the overview).
//
// Sources of the facts used here (tables are this project's own, built below from the canonical
// representatives in kSubcaseInfo and the symmetry group; nothing is copied):
//   [C]  E. V. Chernyaev, Marching Cubes 33: construction of topologically correct isosurfaces,
//        CERN CN/95-17 (1995): cases 1-14, face test, interior test on slices.
//   [L]  T. Lewiner et al., Efficient implementation of Marching Cubes' cases with topological
//        guarantees, JGT 8(2) 2003, and its LookUpTable.h (neurolabusc/LewinerMarchingCubes):
//        same corner order as ours; its cases[] fixes which chirality is 11 and which is 14;
//        its case-13 tilings cover 46 of the 64 face outcomes (13.1 to 13.5: 2, 12, 24, 4, 4).
//   [CU] L. Custodio et al., Practical considerations on Marching Cubes 33 topological
//        correctness, Computers & Graphics 37 (2013), code liscustodio/modified_mc33: the
//        corrected interior test (slices parallel to the ambiguous faces for 6, 10, 12, all three
//        directions for 4 and 7, the slice parabola must have its maximum for the tested pair;
//        body critical points for 13.5).
//   [N]  G. M. Nielson, B. Hamann, The asymptotic decider, IEEE Visualization 1991.
//   [JLM] C.-P. Jeannerod, N. Louvet, J.-M. Muller, Further analysis of Kahan's algorithm for the
//        accurate computation of 2x2 determinants, Math. Comp. 82 (2013): relative error <= 2u.
#include "core/cutting/mc33.h"

#include <bit>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/base/error.h"

namespace mchex {

std::array<double, 8> transform_cell(const std::array<double, 8>& f, int symmetry, bool invert) {
  const CubeSymmetry& g = kCubeSymmetries.at(static_cast<std::size_t>(symmetry));
  std::array<double, 8> out{};
  for (int c = 0; c < 8; ++c) out[g.corner[c]] = invert ? -f[c] : f[c];
  return out;
}

namespace {

constexpr std::uint8_t bit8(int i) { return static_cast<std::uint8_t>(1u << i); }

// Face f is ambiguous when both of its diagonals are same-sign pairs of opposite signs: only
// then does the surface's chord structure on it depend on the values [C].
constexpr std::uint8_t compute_ambiguous_faces(std::uint8_t mask) {
  std::uint8_t out = 0;
  for (int f = 0; f < 6; ++f) {
    const auto& q = kHexFaces[f];
    const int s0 = mask >> q[0] & 1, s1 = mask >> q[1] & 1, s2 = mask >> q[2] & 1, s3 = mask >> q[3] & 1;
    if (s0 == s2 && s1 == s3 && s0 != s1) out |= bit8(f);
  }
  return out;
}

constexpr std::uint8_t move_mask(const CubeSymmetry& g, std::uint8_t mask, bool invert) {
  std::uint8_t out = 0;
  for (int c = 0; c < 8; ++c)
    if (mask >> c & 1) out |= bit8(g.corner[c]);
  return invert ? static_cast<std::uint8_t>(~out) : out;
}

// Face outcomes move with the faces; negating the values swaps which diagonal is the positive one,
// so every ambiguous face's bit flips.
constexpr std::uint8_t move_faces(const CubeSymmetry& g, std::uint8_t mask, std::uint8_t faces, bool invert) {
  const std::uint8_t amb = compute_ambiguous_faces(mask);
  std::uint8_t out = 0;
  for (int f = 0; f < 6; ++f)
    if ((amb >> f & 1) && ((faces >> f & 1) != static_cast<int>(invert))) out |= bit8(g.face[f]);
  return out;
}

struct PatternEntry {
  std::uint8_t mc_case = 0;
  std::uint8_t ambiguous_faces = 0;
};

// Case of each sign pattern: the orbit of the case's representative under the 24 rotations and
// complement (the classic 15 classes; with reflections 11 and 14 would merge [L]).
constexpr std::array<PatternEntry, 256> make_pattern_table() {
  std::array<PatternEntry, 256> t{};
  for (int m = 0; m < 256; ++m) t[m].ambiguous_faces = compute_ambiguous_faces(static_cast<std::uint8_t>(m));
  for (const SubcaseInfo& s : kSubcaseInfo)
    for (int g = 0; g < kNumCubeRotations; ++g)
      for (int inv = 0; inv < 2; ++inv) t[move_mask(kCubeSymmetries[g], s.positive_mask, inv != 0)].mc_case = s.mc_case;
  return t;
}

constexpr std::array<PatternEntry, 256> kPatternTable = make_pattern_table();

// One Mc33Config per (sign pattern, face outcomes), index mask * 64 + face_joins.
constexpr int config_index(std::uint8_t mask, std::uint8_t faces) { return mask * 64 + faces; }

// Filled from the representatives: the cell g(rep) (negated when inv) maps back onto rep by
// g's inverse. Symmetry indices order rotations before reflections, so the smallest index is the
// preferred one; between the two maps a rotation wins, then no inversion.
constexpr std::array<Mc33Config, 256 * 64> make_config_table() {
  std::array<Mc33Config, 256 * 64> t{};
  for (int s = 0; s < kNumSubcases; ++s) {
    const SubcaseInfo& info = kSubcaseInfo[s];
    if (info.tunnel != 0) continue;  // same face configuration as its partner
    // A reflection of an 11 is a 14 and vice versa: those two use rotations only.
    const bool chiral = mirror_subcase(static_cast<Subcase>(s)) != static_cast<Subcase>(s);
    for (int gi = 0; gi < (chiral ? kNumCubeRotations : kNumCubeSymmetries); ++gi)
      for (int inv = 0; inv < 2; ++inv) {
        const CubeSymmetry& g = kCubeSymmetries[gi];
        const std::uint8_t m = move_mask(g, info.positive_mask, inv != 0);
        const std::uint8_t fc = move_faces(g, info.positive_mask, info.face_joins, inv != 0);
        Mc33Config& e = t[config_index(m, fc)];
        if (e.realisable() && e.subcase != static_cast<Subcase>(s)) throw "two subcases claim one configuration";
        e.subcase = static_cast<Subcase>(s);
        if (g.inverse < e.map[inv]) e.map[inv] = g.inverse;
      }
  }
  for (Mc33Config& e : t) {
    auto rank = [](std::uint8_t sym, int inv) {
      return sym == kNoCubeSymmetry ? 1 << 20 : (sym >= kNumCubeRotations) * 1000 + inv * 100 + sym;
    };
    e.preferred = rank(e.map[1], 1) < rank(e.map[0], 0) ? 1 : 0;
  }
  return t;
}

constexpr std::array<Mc33Config, 256 * 64> kConfigTable = make_config_table();

// Edge neighbours of each corner.
constexpr std::array<std::uint8_t, 8> make_edge_neighbours() {
  std::array<std::uint8_t, 8> n{};
  for (const auto& e : kCubeEdges) {
    n[e[0]] |= bit8(e[1]);
    n[e[1]] |= bit8(e[0]);
  }
  return n;
}
constexpr std::array<std::uint8_t, 8> kEdgeNeighbours = make_edge_neighbours();

// Sign of a*b - c*d, exactly: Kahan's algorithm has relative error <= 2u [JLM], so its result has
// the exact sign and is zero only when the exact value is (barring underflow of the products,
// i.e. |values| below ~1e-150, far beneath any SDF value the pipeline perturbs zeros to).
double kahan_det(double a, double b, double c, double d) {
  const double w = c * d;
  const double e = std::fma(-c, d, w);  // w - c*d, exactly
  const double f = std::fma(a, b, -w);
  return f + e;
}

// Same-sign components of the corners under the links in adj (edges, faces, interior).
void label_regions(const std::array<std::uint8_t, 8>& adj, std::uint8_t sign_mask, CellClass& out) {
  std::uint8_t left = 0xFF;
  int n = 0;
  while (left) {
    const int c = std::countr_zero(left);
    std::uint8_t comp = bit8(c), frontier = comp;
    while (frontier) {
      std::uint8_t next = 0;
      for (std::uint8_t m = frontier; m; m &= static_cast<std::uint8_t>(m - 1)) next |= adj[std::countr_zero(m)];
      next &= static_cast<std::uint8_t>(~comp);
      comp |= next;
      frontier = next;
    }
    CellRegion& r = out.regions[n];
    r.sign = (sign_mask >> c & 1) ? 1 : -1;
    r.corners = comp;
    r.count = static_cast<std::uint8_t>(std::popcount(comp));
    for (std::uint8_t m = comp; m; m &= static_cast<std::uint8_t>(m - 1))
      out.corner_region[std::countr_zero(m)] = static_cast<std::uint8_t>(n);
    left &= static_cast<std::uint8_t>(~comp);
    ++n;
  }
  out.num_regions = static_cast<std::uint8_t>(n);
  for (int i = n; i < 8; ++i) out.regions[i] = CellRegion{};
}

// The interior test: Chernyaev's slice test [C] along z, in the cell's own frame.
//
// Cut the cell by the plane z = t. The slice is a bilinear square with corners A(t), B(t), C(t),
// D(t) on the vertical edges 0-4, 1-5, 2-6, 3-7 (cyclic; A-C and B-D are its diagonals), each
// linear in t. When the slice is ambiguous (A, C one sign, B, D the other), the asymptotic decider
// joins A-C iff Q(t) = A C - B D > 0 and B-D iff Q(t) < 0; Q is a quadratic in t.
//
// Slicing lemma (why one direction is exact): every component of the positive set of a slice
// touches a positive slice corner (a bilinear function has no interior maximum), and a slice
// corner lies on a vertical edge, hence is joined along it to a cube corner. So each point of the
// cell's positive set inherits the label of such a corner; the label is well defined once
// corners are joined whenever two positive slice corners share a slice component (adjacent ones:
// a side face already joins them; diagonal ones: the slice test above), and it is locally
// constant because a slice path moves continuously to nearby heights. Hence corners joined
// through the inside of the cell are exactly those joined by edges, faces and slices at some t;
// likewise for the negative set. Of the slice joins, those at the ends of an ambiguous interval of
// t are either the z-faces' own tests or occur next to a height where three slice corners share a
// sign, which the side faces already join; a join not implied by edges and faces therefore needs
// the extremum t* = -b / 2a of Q inside (0, 1), the slice at t* ambiguous, and Q(t*) of the joining
// sign: a maximum (a < 0) with Q(t*) > 0 joins A-C, a minimum (a > 0) with Q(t*) < 0 joins B-D.
// For cases 4 and 10 this is the test of [C] and [L] (z-planes at the parabola's vertex). For 6,
// 7, 12 and 13 [L] instead evaluates the plane through a reference edge's crossing; [CU]'s
// corrected code tests planes parallel to the ambiguous faces (6, 10, 12) or in all three
// directions (4, 7), keeps only a maximum for the tested pair, and for 13.5 uses the two body
// critical points. By the lemma every direction gives the same answer, so z serves every case.
// The tests check the result against a flood fill of the sampled interpolant, and against [CU]'s
// 13.5 rule: they agree whenever both saddles lie in the cell; the slice test also finds the
// tunnels whose second saddle lies just outside the cell, which the flood fill confirms.
//
// Returns the two cube corners the interior joins (c1 != c2 may already be in one region: the
// caller decides whether the join is a tunnel), or false when the extremum joins nothing.
bool interior_join(const std::array<double, 8>& f, int& c1, int& c2) {
  const double b0 = f[0], b1 = f[1], b2 = f[2], b3 = f[3];
  const double d0 = f[4] - f[0], d1 = f[5] - f[1], d2 = f[6] - f[2], d3 = f[7] - f[3];
  const double qa = d0 * d2 - d1 * d3;
  const double qb = b0 * d2 + b2 * d0 - b1 * d3 - b3 * d1;
  if (qa == 0) return false;  // Q is linear: its extremes are the z-faces' own tests
  const double ts = -qb / (2 * qa);
  if (!(ts > 0 && ts < 1)) return false;
  const double v[4] = {b0 + ts * d0, b1 + ts * d1, b2 + ts * d2, b3 + ts * d3};
  const bool p0 = v[0] > 0, p1 = v[1] > 0, p2 = v[2] > 0, p3 = v[3] > 0;
  if (p0 != p2 || p1 != p3 || p0 == p1) return false;  // slice at t* not ambiguous
  const double q = v[0] * v[2] - v[1] * v[3];
  int k1, k2;
  bool positive;
  if (qa < 0) {
    // Maximum: joins A-C when Q(t*) > 0; a tie joins them only if they are the positive pair
    // (the infinitesimal raise of face_joins_positive).
    if (!(q > 0 || (q == 0 && p0))) return false;
    k1 = 0, k2 = 2, positive = p0;
  } else {
    if (!(q < 0 || (q == 0 && p1))) return false;
    k1 = 1, k2 = 3, positive = p1;
  }
  // The slice corner on edge k -> k+4 belongs to the end of the edge with its sign.
  c1 = ((f[k1] > 0) == positive) ? k1 : k1 + 4;
  c2 = ((f[k2] > 0) == positive) ? k2 : k2 + 4;
  return true;
}

}  // namespace

bool face_joins_positive(double p0, double p1, double n0, double n1) {
  // Saddle value of the bilinear face interpolant = (p0 p1 - n0 n1) / (p0 + p1 - n0 - n1) [N];
  // the denominator is positive, so only the numerator's sign matters.
  return kahan_det(p0, p1, n0, n1) >= 0;
}

int mc_case_of(std::uint8_t sign_mask) { return kPatternTable[sign_mask].mc_case; }

const Mc33Config& mc33_config(std::uint8_t sign_mask, std::uint8_t face_joins) {
  return kConfigTable.at(static_cast<std::size_t>(config_index(sign_mask, face_joins & 0x3F)));
}

std::uint8_t ambiguous_faces_of(std::uint8_t sign_mask) { return kPatternTable[sign_mask].ambiguous_faces; }

CellClass classify(const std::array<double, 8>& f) {
  CellClass out;
  std::uint8_t mask = 0;
  for (int c = 0; c < 8; ++c) {
    if (!std::isfinite(f[c])) throw InputError("MC33 classify: a corner value is not finite");
    if (f[c] > 0) mask |= bit8(c);
  }
  out.sign_mask = mask;

  // Crossing parameters on Table 1's edges, measured from the first-listed corner.
  for (int e = 0; e < 12; ++e) {
    const int a = kCubeEdges[e][0], b = kCubeEdges[e][1];
    if ((mask >> a & 1) != (mask >> b & 1)) {
      out.cut_edges |= static_cast<std::uint16_t>(1u << e);
      out.crossing[e] = f[a] / (f[a] - f[b]);
    } else {
      out.crossing[e] = std::numeric_limits<double>::quiet_NaN();
    }
  }

  const PatternEntry& pattern = kPatternTable[mask];
  out.mc_case = pattern.mc_case;
  out.ambiguous_faces = pattern.ambiguous_faces;

  // Links between same-sign corners: edges, then the diagonal each ambiguous face joins.
  std::array<std::uint8_t, 8> adj{};
  for (int c = 0; c < 8; ++c) {
    const std::uint8_t same = (mask >> c & 1) ? mask : static_cast<std::uint8_t>(~mask);
    adj[c] = kEdgeNeighbours[c] & same;
  }
  for (int fi = 0; fi < 6; ++fi) {
    if (!(pattern.ambiguous_faces >> fi & 1)) continue;
    const auto& q = kHexFaces[fi];
    // Positive diagonal (pa, pb), negative diagonal (na, nb).
    const bool first_positive = mask >> q[0] & 1;
    const int pa = first_positive ? q[0] : q[1], pb = first_positive ? q[2] : q[3];
    const int na = first_positive ? q[1] : q[0], nb = first_positive ? q[3] : q[2];
    const bool joins_positive = face_joins_positive(f[pa], f[pb], f[na], f[nb]);
    if (joins_positive) out.face_joins |= bit8(fi);
    const int u = joins_positive ? pa : na, v = joins_positive ? pb : nb;
    adj[u] |= bit8(v);
    adj[v] |= bit8(u);
  }
  label_regions(adj, mask, out);

  const Mc33Config& entry = kConfigTable[config_index(mask, out.face_joins)];
  if (!entry.realisable())
    // Unreachable: the exact face test never produces one of case 13's impossible face
    // configurations (see the test); finite values were checked above.
    throw std::logic_error("MC33 classify: face outcomes match no subcase");
  out.subcase = entry.subcase;

  // The interior decides only between a subcase and its tunnel partner; elsewhere the trilinear
  // topology is fixed by edges and faces [C], so the test is not run.
  const Subcase partner = subcase_info(entry.subcase).tunnel_partner;
  int c1 = 0, c2 = 0;
  if (partner != Subcase::kEmpty && interior_join(f, c1, c2) && out.corner_region[c1] != out.corner_region[c2]) {
    out.tunnel = static_cast<std::int8_t>((mask >> c1 & 1) ? 1 : -1);
    out.subcase = partner;
    adj[c1] |= bit8(c2);
    adj[c2] |= bit8(c1);
    label_regions(adj, mask, out);
  }

  // A tunnel fixes the inversion (the representative's tunnel has a given sign); otherwise the
  // preferred map is used.
  const int inv = out.tunnel != 0 ? (out.tunnel != subcase_info(out.subcase).tunnel) : entry.preferred;
  out.symmetry = entry.map[inv];
  out.inverted = inv != 0;
  if (out.symmetry == kNoCubeSymmetry)
    throw std::logic_error("MC33 classify: no symmetry maps the cell onto its representative");
  return out;
}

}  // namespace mchex
