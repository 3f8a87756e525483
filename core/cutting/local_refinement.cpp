// Local refinement of one cell (paper Section 5, Figure 7); see local_refinement.h.
#include "core/cutting/local_refinement.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace mchex {
namespace {

// The paper's two levels (Figure 7); the table needs no more.
constexpr int kMaxLevels = 2;

constexpr int corner_index(int x, int y, int z) { return detail::cube_corner_index(x, y, z); }

// Trilinear weights of the 8 corners at parametric point u (paper Eq. 8).
std::array<double, 8> trilinear_weights(const std::array<double, 3>& u) {
  std::array<double, 8> w{};
  for (int c = 0; c < 8; ++c) {
    double p = 1;
    for (int i = 0; i < 3; ++i) p *= kCubeCorners[c][i] ? u[i] : 1 - u[i];
    w[c] = p;
  }
  return w;
}

std::array<double, 3> inner_parameter(int corner) {
  std::array<double, 3> u{};
  for (int i = 0; i < 3; ++i) u[i] = kCubeCorners[corner][i] ? 1 - kInnerPointPosition : kInnerPointPosition;
  return u;
}

// The 16 points of one level: corners, then inner points. Inner point i is the midpoint of corner
// i and the centroid (the mean of the 8 corners): the paper's "connecting its eight grid points to
// its centroid" (Section 5), taken in space. The inner cell is then the cell shrunk by 1/2 about
// its centroid, an affine image of the cell, so it has the cell's own type (Theorem 5.2), and
// each frustum's side faces are planar trapezoids (a cell edge and its image, scaled about the
// centroid). On a parallelepiped cell this is the trilinear map at parametric (1/4, 3/4) (the
// placement used before); on a transition cell the parametric placement makes warped frustums
// and a warped inner cell. Measured by certify on the 7 transition types (before any
// volume-centre search, core/cutting/repair.h): parametric placement, min scaled Bernstein coefficient
// down to -8e-2 and every refined subcase failing; this placement, every refined subcase
// certified except 3.2, 4.1.2 and 6.2, whose failing leaves are case-5 frustums (-1e-1..-3e-3).
// The scale (kInnerPointScale) barely matters: 0.35, 0.4, 0.5, 0.6 leave the same few 3.2
// frustum leaves failing on edge-3 (646..663 of 115118 sampled cells).
std::array<Vec3, 16> level_points(const std::array<Vec3, 8>& corners) {
  std::array<Vec3, 16> p{};
  Vec3 centroid{};
  for (int c = 0; c < 8; ++c) {
    p[c] = corners[c];
    centroid += corners[c];
  }
  centroid = centroid / 8.0;
  for (int i = 0; i < 8; ++i) p[8 + i] = centroid + kInnerPointScale * (corners[i] - centroid);
  return p;
}

// The built-in table: the output of the template search in tests/test_local_refinement.cpp
// (TemplateSearchFindsTheBuiltInTable re-runs it and compares), whose other tests re-prove every
// entry's guarantees over all sign patterns. The search tries all 256 inner sign patterns per
// subcase on the unit cube, first with every child cut directly (level 1), then letting children
// of the level-1 subcases be refined once more (level 2), and keeps the first pattern (fewest
// levels, then fewest hexes) whose every leaf certifies with the cell's topology.
//
// Refined: the subcases whose direct cut fails the Bernstein certificate on the unit cube for
// some crossings (3.2, 6.2, 7.2, 7.3, 10.2, 11, 12.2, 13.2, 13.3, 13.4, 14; see
// test_polyhedra.cpp) and the six tunnel subcases. Unlike the paper's 17 (Figure 7), 7.4.1 and
// 13.5.1 certify directly here and are not refined. 11 and 14 (the paper's "Case 12", which it
// fixes with a volume-centre offset, Eq. 14) are cut directly with the offset on affine cells
// (core/cutting/volume_centre_offset.h: 20 hexes a cell) and refined on the others (104 hexes), where no
// offset certifies them: for some crossings no centre at all does on the templates' transition
// cells. Cut directly on a frustum child, 11 and 14 fail for about a quarter of sampled cells
// (DISABLED_DirectSubcasesPerGeometry), so no template may leave them as leaves either.
// Except in 3.2 the inner points all take one sign: the inner cell then is empty and every
// frustum is a case of its outer face alone (the frustum's 4 inner points share a sign, so none
// of its side faces is ambiguous and it admits no tunnel): 1, 2, 3.1, 5, 8, 9 directly, or a
// 3.2 or 6.2 refined once more. In a tunnel subcase the inner cell takes the tunnel's sign, which
// joins the two regions through the middle of the cell.
constexpr LocalRefinementTable make_table() {
  LocalRefinementTable t{};
  auto set = [&t](Subcase s, std::uint8_t inner) { t[static_cast<int>(s)] = {true, inner}; };
  using S = Subcase;
  // One level: every child is cut directly.
  set(S::k3_2, 0x0F);  // inner points next to the face z = 0 (the joined one) positive
  // ... but a cell that is 3.2 itself takes 0x7F (every inner point positive but the one next to
  // corner 7): measured, before the virtual values kept their crossings clear of the inner points
  // (kInnerCrossingMargin; with it 0x0F certifies the regression cells of test_certify too), over
  // the 8 basic cell types x 24 rotations x 709 sampled 3.2 cells (with
  // core/cutting/repair.h's volume-centre search), 0x0F leaves 117 uncertified polyhedra on edge-3 and
  // face-3 (min scaled coefficient -6.9e-3, case-5 side frustums), 0x1F 65, 0x4F 54, 0x7F none
  // (the first one-level pattern with none); as the template of a 3.2 frustum at the second level
  // (7.2, 7.4.2) 0x7F fails on the cube, where 0x0F certifies.
  t[static_cast<int>(S::k3_2)].own_level = true;
  t[static_cast<int>(S::k3_2)].own_inner_positive = 0x7F;
  set(S::k6_2, 0xFF);
  set(S::k11, 0x00);
  set(S::k14, 0x00);
  // ... on general cells only: on affine ones the volume-centre offset certifies them directly.
  t[static_cast<int>(S::k11)].direct_on_affine = true;
  t[static_cast<int>(S::k14)].direct_on_affine = true;
  set(S::k4_1_2, 0xFF);  // the tunnel's sign fills the inner cell
  // Two levels: some frustums are 3.2 or 6.2 cells and are refined again.
  set(S::k7_2, 0x00);
  set(S::k7_3, 0xFF);
  set(S::k10_2, 0x00);
  set(S::k12_2, 0x00);
  set(S::k13_2, 0x00);
  set(S::k13_3, 0x00);
  set(S::k13_4, 0x00);
  set(S::k6_1_2, 0xFF);
  set(S::k7_4_2, 0x00);
  set(S::k10_1_2, 0xFF);
  set(S::k12_1_2, 0xFF);
  set(S::k13_5_2, 0xFF);
  return t;
}

constexpr LocalRefinementTable kTable = make_table();

// Sign-level plan of one cell's refinement, for the hex count: the cell's sign pattern and face
// outcomes, the template mapped onto the cell, and each child's pattern and face outcomes (a
// frustum inherits the cell's outcome on its outer face, its only face that can be ambiguous).
struct SignPlan {
  int hexes = 0;
  int levels = 0;
};

SignPlan plan(std::uint8_t mask, std::uint8_t face_joins, Subcase s, int symmetry, bool inverted,
              const LocalRefinementTable& table, int depth) {
  const LocalRefinementTemplate& tpl = table[static_cast<int>(s)];
  if (!tpl.refine) {
    int cut = 0;
    for (const auto& e : kCubeEdges) cut += (mask >> e[0] & 1) != (mask >> e[1] & 1);
    return {8 + 2 * cut, 0};
  }
  if (depth >= kMaxLevels)
    throw std::logic_error("local refinement: subcase " + std::string(subcase_name(s)) + " needs a third level");
  const CubeSymmetry& g = kCubeSymmetries[symmetry];
  std::uint16_t signs = mask;
  for (int i = 0; i < 8; ++i) {
    const bool pos = ((tpl.signs(depth) >> g.corner[i] & 1) != 0) != inverted;
    if (pos) signs |= static_cast<std::uint16_t>(1u << (8 + i));
  }
  SignPlan out{0, 1};
  const auto children = local_refinement_child_points();
  for (int k = 0; k < kNumLocalRefinementChildren; ++k) {
    std::uint8_t m = 0;
    for (int j = 0; j < 8; ++j)
      if (signs >> children[k][j] & 1) m |= static_cast<std::uint8_t>(1u << j);
    std::uint8_t joins = 0;
    const std::uint8_t amb = ambiguous_faces_of(m);
    if (k > 0 && (amb >> (k - 1) & 1)) joins = face_joins & static_cast<std::uint8_t>(1u << (k - 1));
    const Mc33Config& cfg = mc33_config(m, joins);
    const int inv = cfg.preferred;
    const SignPlan sub = plan(m, joins, cfg.subcase, cfg.map[inv], inv != 0, table, depth + 1);
    out.hexes += sub.hexes;
    out.levels = std::max(out.levels, 1 + sub.levels);
  }
  return out;
}

SignPlan subcase_plan(Subcase s) {
  const SubcaseInfo& info = subcase_info(s);
  return plan(info.positive_mask, info.face_joins, s, 0, false, kTable, 0);
}

// The inner points' virtual values of one level (local_refinement.h). Signs: the template's,
// on the representative (inner point i of this cell is the representative's g.corner[i]; an
// inverted map swaps inside and outside). Magnitudes: the cell's trilinear interpolant where its
// sign agrees, else the interpolant of the magnitudes (the field's local scale); then each is
// moved into the range that puts the crossing on every cut inner edge (to its corner, and along
// the inner cell's edges) at least kInnerCrossingMargin from both ends: |v| / |w| in
// [r, 1 / r], r = margin / (1 - margin), for a neighbour w of the other sign. The corners are
// fixed; the inner points are settled in order, a few sweeps over the 8. Where the ranges of a
// point do not meet, the geometric middle of the two bounds. Only magnitudes change, so every
// child's subcase (decided by signs alone) and the cell's faces stay as they were.
std::array<double, 8> virtual_values(const std::array<double, 8>& f, std::uint8_t signs, const CubeSymmetry& g,
                                     bool inverted, double zero_tolerance) {
  constexpr int kSweeps = 4;
  constexpr double r = kInnerCrossingMargin / (1 - kInnerCrossingMargin);
  std::array<bool, 8> positive_at{};
  std::array<double, 8> m{};
  for (int i = 0; i < 8; ++i) {
    positive_at[i] = ((signs >> g.corner[i] & 1) != 0) != inverted;
    const auto w = trilinear_weights(inner_parameter(i));
    double v = 0, scale = 0;
    for (int k = 0; k < 8; ++k) {
      v += w[k] * f[k];
      scale += w[k] * std::abs(f[k]);
    }
    m[i] = std::max((v > 0) == positive_at[i] ? std::abs(v) : scale, zero_tolerance);
  }
  for (int sweep = 0; sweep < kSweeps; ++sweep)
    for (int i = 0; i < 8; ++i) {
      double lo = zero_tolerance, hi = std::numeric_limits<double>::infinity();
      auto keep_clear_of = [&](double magnitude, bool other_positive) {
        if (other_positive == positive_at[i]) return;
        lo = std::max(lo, r * magnitude);
        hi = std::min(hi, magnitude / r);
      };
      keep_clear_of(std::abs(f[i]), f[i] > 0);
      for (const auto& e : kCubeEdges) {
        if (e[0] == i) keep_clear_of(m[e[1]], positive_at[e[1]]);
        if (e[1] == i) keep_clear_of(m[e[0]], positive_at[e[0]]);
      }
      m[i] = lo <= hi ? std::clamp(m[i], lo, hi) : std::max(std::sqrt(lo * hi), zero_tolerance);
    }
  std::array<double, 8> out{};
  for (int i = 0; i < 8; ++i) out[i] = positive_at[i] ? m[i] : -m[i];
  return out;
}

void refine_into(const std::array<std::uint32_t, 8>& cell, const CellClass& c, const LocalRefinementTable& table,
                 double zero_tolerance, int depth, LocalRefinement& out) {
  if (depth >= kMaxLevels)
    throw std::logic_error("local refinement: subcase " + std::string(subcase_name(c.subcase)) +
                           " would need a third level");
  const LocalRefinementTemplate& tpl = table[static_cast<int>(c.subcase)];
  std::array<Vec3, 8> corners{};
  std::array<double, 8> f{};
  for (int i = 0; i < 8; ++i) {
    corners[i] = out.points[cell[i]];
    f[i] = out.values[cell[i]];
  }
  const auto pts = level_points(corners);
  const CubeSymmetry& g = kCubeSymmetries[c.symmetry];
  std::array<std::uint32_t, 16> id{};
  for (int i = 0; i < 8; ++i) id[i] = cell[i];
  const auto v = virtual_values(f, tpl.signs(depth), g, c.inverted, zero_tolerance);
  for (int i = 0; i < 8; ++i) {
    id[8 + i] = static_cast<std::uint32_t>(out.points.size());
    out.points.push_back(pts[8 + i]);
    out.values.push_back(v[i]);
  }
  out.levels = std::max(out.levels, depth + 1);
  for (const LocalRefinementChild& child : local_refinement_child_points()) {
    std::array<std::uint32_t, 8> sub{};
    std::array<double, 8> sf{};
    for (int j = 0; j < 8; ++j) {
      sub[j] = id[child[j]];
      sf[j] = out.values[sub[j]];
    }
    const CellClass cc = classify(sf);
    // The guarantee that a child's subcase follows from signs alone: no tunnel-admitting
    // configuration (the interior test would read the virtual magnitudes), and no ambiguous face
    // except on the cell's own faces (whose points are the cell's corners, ids 0..7).
    if (subcase_info(cc.subcase).tunnel_partner != Subcase::kEmpty)
      throw std::logic_error("local refinement: a child of subcase " + std::string(subcase_name(c.subcase)) + " is " +
                             std::string(subcase_name(cc.subcase)) + ", decided by the interior test");
    for (int face = 0; face < 6; ++face)
      if (cc.ambiguous_faces >> face & 1)
        for (int q : kHexFaces[face])
          if (sub[q] >= 8)
            throw std::logic_error("local refinement: a child of subcase " + std::string(subcase_name(c.subcase)) +
                                   " has an ambiguous face inside the cell");
    if (table[static_cast<int>(cc.subcase)].refine) refine_into(sub, cc, table, zero_tolerance, depth + 1, out);
    else out.cells.push_back(sub);
  }
}

}  // namespace

std::array<LocalRefinementChild, kNumLocalRefinementChildren> local_refinement_child_points() {
  std::array<LocalRefinementChild, kNumLocalRefinementChildren> out{};
  for (int j = 0; j < 8; ++j) out[0][j] = static_cast<std::uint8_t>(8 + j);
  for (int f = 0; f < 6; ++f) {
    const int axis = f / 2, side = f % 2;
    for (int j = 0; j < 8; ++j) {
      // Local corner j at (a, b, c); the cell corner below it on face f, and the inner point
      // next to that corner; local coordinate `side` along `axis` is the face, the other side
      // the inner point. Keeping the cell's axes keeps the frustum right-handed.
      std::array<int, 3> p = kCubeCorners[j];
      const bool on_face = p[axis] == side;
      p[axis] = side;
      const int base = corner_index(p[0], p[1], p[2]);
      out[1 + f][j] = static_cast<std::uint8_t>(on_face ? base : 8 + base);
    }
  }
  return out;
}

const LocalRefinementTable& local_refinement_table() { return kTable; }

bool needs_local_refinement(Subcase s) { return kTable[static_cast<int>(s)].refine; }
bool needs_local_refinement(const CellClass& c) { return needs_local_refinement(c.subcase); }
bool needs_local_refinement(Subcase s, CellShape shape) {
  const LocalRefinementTemplate& t = kTable[static_cast<int>(s)];
  return t.refine && !(shape == CellShape::kAffine && t.direct_on_affine);
}
bool needs_local_refinement(const CellClass& c, const std::array<Vec3, 8>& corners) {
  // The shape test only where it can change the answer.
  const LocalRefinementTemplate& t = kTable[static_cast<int>(c.subcase)];
  if (!t.refine || !t.direct_on_affine) return t.refine;
  return needs_local_refinement(c.subcase, cell_shape(corners));
}

LocalRefinement refine_locally(const std::array<Vec3, 8>& corners, const std::array<double, 8>& f, const CellClass& c,
                               double zero_tolerance, const LocalRefinementTable& table) {
  if (!table[static_cast<int>(c.subcase)].refine)
    throw std::invalid_argument("refine_locally: subcase " + std::string(subcase_name(c.subcase)) +
                                " is cut without local refinement");
  if (!(zero_tolerance > 0)) throw std::invalid_argument("refine_locally: zero_tolerance must be positive");
  LocalRefinement out;
  out.points.assign(corners.begin(), corners.end());
  out.values.assign(f.begin(), f.end());
  refine_into({0, 1, 2, 3, 4, 5, 6, 7}, c, table, zero_tolerance, 0, out);
  return out;
}

std::vector<std::array<Vec3, 8>> local_refinement_children(const std::array<Vec3, 8>& corners) {
  const auto pts = level_points(corners);
  std::vector<std::array<Vec3, 8>> out;
  for (const LocalRefinementChild& child : local_refinement_child_points()) {
    std::array<Vec3, 8> h{};
    for (int j = 0; j < 8; ++j) h[j] = pts[child[j]];
    out.push_back(h);
  }
  return out;
}

int local_refinement_hexes(Subcase s) { return subcase_plan(s).hexes; }
int local_refinement_hexes(Subcase s, CellShape shape) {
  if (!needs_local_refinement(s, shape)) {
    // Cut directly: 8 + 2 * cut edges (Theorem 4.1), on the representative's sign pattern.
    const std::uint8_t m = subcase_info(s).positive_mask;
    int cut = 0;
    for (const auto& e : kCubeEdges) cut += (m >> e[0] & 1) != (m >> e[1] & 1);
    return 8 + 2 * cut;
  }
  return local_refinement_hexes(s);
}
int local_refinement_levels(Subcase s) { return subcase_plan(s).levels; }

}  // namespace mchex
