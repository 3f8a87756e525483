// Marching Cubes 33 classification of one cell: the first stage of MCHex cutting (paper Section 5:
// "the MC method (9) is then applied ... thirty-one topological cases"). Later stages build one
// 3-regular polyhedron template per subcase on its canonical representative and map it back to
// the cell with the symmetry and inversion that classify() returns.
//
// Conventions (shared with the rest of the project):
//   corners   VTK hexahedron / paper Eq. 8 order: 0(0,0,0) 1(1,0,0) 2(1,1,0) 3(0,1,0)
//             4(0,0,1) 5(1,0,1) 6(1,1,1) 7(0,1,1);
//   values    f at the corners, f > 0 is INSIDE (the solid). A value of exactly 0 counts as
//             outside; the caller perturbs zeros first (docs/mc33.md), so this never decides a case;
//   edges     paper Table 1, points 1..12 stored 0-based (kCubeEdges); the crossing parameter s
//             is measured from the first-listed corner: s = f_a / (f_a - f_b);
//   faces     x=0, x=1, y=0, y=1, z=0, z=1, corners cyclic as in kHexFaces.
//
// What classify() decides and how (details and sources at each step in mc33.cpp):
//   case      Chernyaev's case 1..14 of the sign pattern up to the 24 rotations and complement
//             (cases 11 and 14 are mirror images; every other case is closed under reflection);
//   faces     the asymptotic decider on every ambiguous face, evaluated with a sign-exact 2x2
//             determinant, so two cells sharing a face always make the same decision;
//   interior  for the six face configurations that admit a tunnel (4.1, 6.1, 7.4, 10.1, 12.1,
//             13.5) Chernyaev's slice test: cut the cell by the planes z = t; the slice's saddle
//             test A(t)C(t) - B(t)D(t) is a quadratic in t, and two same-sign regions are joined
//             through the interior iff at its extremum t* in (0, 1) the slice is ambiguous and
//             the extremum joins that diagonal. In exact arithmetic this is exact for the
//             trilinear interpolant whichever axis the planes are normal to (the slicing lemma in
//             mc33.cpp), so one axis serves every case; Custodio et al.'s corrections choose the
//             planes per case instead.
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

#include "core/mesh/cube.h"
#include "core/mesh/hex_faces.h"

namespace mchex {

// The cell moved by symmetry g, optionally with every value negated (complement):
// out[g.corner[c]] = (invert ? -f[c] : f[c]).
std::array<double, 8> transform_cell(const std::array<double, 8>& f, int symmetry, bool invert);

// ---- Subcases --------------------------------------------------------------------------------

// The 31 non-empty MC33 subcases (Chernyaev 1995, as listed in docs/mc33.md; 12.2/12.3
// are one subcase, 11 and 14 are kept apart as mirror images) plus kEmpty (no sign change).
// clang-format off
enum class Subcase : std::uint8_t {
  kEmpty,
  k1, k2, k3_1, k3_2, k4_1_1, k4_1_2, k5, k6_1_1, k6_1_2, k6_2,
  k7_1, k7_2, k7_3, k7_4_1, k7_4_2, k8, k9, k10_1_1, k10_1_2, k10_2, k11,
  k12_1_1, k12_1_2, k12_2, k13_1, k13_2, k13_3, k13_4, k13_5_1, k13_5_2, k14,
};
// clang-format on
inline constexpr int kNumSubcases = 32;  // kEmpty and the 31

// A subcase's name, MC33 case, and canonical representative. The representative is the
// configuration every cell of the subcase is mapped onto: its positive corners, the ambiguous
// faces whose test joins the positive diagonal, and the sign of the regions its interior joins.
// The positive corners of cases 1-7 are the case's (minority) corners; the patterns are
// (corners listed): 1 {0}, 2 {0,1}, 3 {0,2}, 4 {0,6}, 5 {0,1,3}, 6 {0,1,6}, 7 {1,3,4},
// 8 {0,1,2,3}, 9 {0,1,3,4}, 10 {0,2,4,6}, 11 {0,1,5,6}, 12 {0,1,3,6}, 13 {0,2,5,7},
// 14 {0,1,2,6} (Lewiner's LookUpTable.h cases[]: 71 = {0,1,2,6} is case 14, 99 = {0,1,5,6} is
// case 11). Where a subcase fixes some face outcomes, its representative takes the smallest
// face bit mask that gives it.
struct SubcaseInfo {
  std::string_view name;       // "7.4.2"; "empty" for kEmpty
  std::uint8_t mc_case;        // 1..14, 0 for kEmpty
  std::uint8_t positive_mask;  // canonical representative: bit c <=> f[c] > 0
  std::uint8_t face_joins;     // canonical: bit f <=> ambiguous face f joins its positive corners
  std::int8_t tunnel;          // canonical: +1 / -1 the interior joins two positive / negative
                               // regions (tunnel subcases only), 0 otherwise
  Subcase tunnel_partner;      // the subcase with the same face chords and the other interior
                               // outcome (4.1.1 <-> 4.1.2, ...); kEmpty where there is none
};

inline constexpr std::array<SubcaseInfo, kNumSubcases> kSubcaseInfo = {{
    {"empty", 0, 0x00, 0x00, 0, Subcase::kEmpty},
    {"1", 1, 0x01, 0x00, 0, Subcase::kEmpty},
    {"2", 2, 0x03, 0x00, 0, Subcase::kEmpty},
    {"3.1", 3, 0x05, 0x00, 0, Subcase::kEmpty},
    {"3.2", 3, 0x05, 0x10, 0, Subcase::kEmpty},  // z=0 joins 0-2
    {"4.1.1", 4, 0x41, 0x00, 0, Subcase::k4_1_2},
    {"4.1.2", 4, 0x41, 0x00, +1, Subcase::k4_1_1},  // 0 and 6 joined inside
    {"5", 5, 0x0B, 0x00, 0, Subcase::kEmpty},
    {"6.1.1", 6, 0x43, 0x00, 0, Subcase::k6_1_2},
    {"6.1.2", 6, 0x43, 0x00, +1, Subcase::k6_1_1},  // {0,1} and 6 joined inside
    {"6.2", 6, 0x43, 0x02, 0, Subcase::kEmpty},     // x=1 joins 1-6
    {"7.1", 7, 0x1A, 0x00, 0, Subcase::kEmpty},
    {"7.2", 7, 0x1A, 0x01, 0, Subcase::kEmpty},     // x=0 joins 3-4
    {"7.3", 7, 0x1A, 0x05, 0, Subcase::kEmpty},     // and y=0 joins 1-4
    {"7.4.1", 7, 0x1A, 0x15, 0, Subcase::k7_4_2},   // and z=0 joins 1-3
    {"7.4.2", 7, 0x1A, 0x15, -1, Subcase::k7_4_1},  // corner 0 joins {2,5,6,7} inside
    {"8", 8, 0x0F, 0x00, 0, Subcase::kEmpty},
    {"9", 9, 0x1B, 0x00, 0, Subcase::kEmpty},
    {"10.1.1", 10, 0x55, 0x00, 0, Subcase::k10_1_2},
    {"10.1.2", 10, 0x55, 0x00, +1, Subcase::k10_1_1},  // {0,4} and {2,6} joined inside
    {"10.2", 10, 0x55, 0x10, 0, Subcase::kEmpty},      // z=0 joins 0-2
    {"11", 11, 0x63, 0x00, 0, Subcase::kEmpty},
    {"12.1.1", 12, 0x4B, 0x00, 0, Subcase::k12_1_2},
    {"12.1.2", 12, 0x4B, 0x00, +1, Subcase::k12_1_1},  // {0,1,3} and 6 joined inside
    {"12.2", 12, 0x4B, 0x02, 0, Subcase::kEmpty},      // x=1 joins 1-6
    {"13.1", 13, 0xA5, 0x00, 0, Subcase::kEmpty},
    {"13.2", 13, 0xA5, 0x01, 0, Subcase::kEmpty},      // x=0 joins 0-7
    {"13.3", 13, 0xA5, 0x05, 0, Subcase::kEmpty},      // and y=0 joins 0-5
    {"13.4", 13, 0xA5, 0x15, 0, Subcase::kEmpty},      // and z=0 joins 0-2 (star at 0)
    {"13.5.1", 13, 0xA5, 0x16, 0, Subcase::k13_5_2},   // x=1, y=0, z=0: triangle {0,2,5}
    {"13.5.2", 13, 0xA5, 0x16, +1, Subcase::k13_5_1},  // 7 joins {0,2,5} inside
    {"14", 14, 0x47, 0x00, 0, Subcase::kEmpty},
}};

constexpr const SubcaseInfo& subcase_info(Subcase s) { return kSubcaseInfo[static_cast<int>(s)]; }
constexpr std::string_view subcase_name(Subcase s) { return subcase_info(s).name; }
constexpr int subcase_case(Subcase s) { return subcase_info(s).mc_case; }
constexpr bool subcase_has_tunnel(Subcase s) { return subcase_info(s).tunnel != 0; }
// The subcase of the mirror image of a cell: 11 <-> 14, every other subcase maps to itself.
constexpr Subcase mirror_subcase(Subcase s) {
  return s == Subcase::k11 ? Subcase::k14 : s == Subcase::k14 ? Subcase::k11 : s;
}

// ---- Classification --------------------------------------------------------------------------

// A connected component of same-sign corners: joined along cell edges, across faces whose test
// joins them, and through the interior where the interior test joins them (tunnel subcases).
struct CellRegion {
  std::int8_t sign = 0;      // +1 inside (f > 0), -1 outside
  std::uint8_t corners = 0;  // bit c <=> corner c belongs to the region
  std::uint8_t count = 0;    // number of corners
};

struct CellClass {
  std::uint8_t sign_mask = 0;  // bit c <=> f[c] > 0
  std::uint8_t mc_case = 0;    // 0 (no sign change) or Chernyaev's case 1..14
  Subcase subcase = Subcase::kEmpty;
  std::uint8_t ambiguous_faces = 0;  // bit f <=> face f has its two diagonals of opposite signs
  std::uint8_t face_joins = 0;       // bit f <=> the test of ambiguous face f joins its positive
                                     // corners (otherwise its negative ones); 0 off ambiguous faces
  std::int8_t tunnel = 0;            // +1 / -1: the interior joins two positive / negative regions
  // The canonical representative of `subcase` is this cell moved by kCubeSymmetries[symmetry],
  // with every value negated when `inverted`: transform_cell(f, symmetry, inverted) has the
  // representative's sign pattern, face outcomes and tunnel (kSubcaseInfo). A template built on
  // the representative maps back through kCubeSymmetries[symmetry].inverse. Preference: a
  // rotation, then no inversion, then the lowest index. Only 12.2 ever needs a reflection (half of
  // its cells): it is Chernyaev's 12.2 and its mirror image 12.3 in one subcase (paper, Section
  // 5); the other mirror pair, 11 and 14, are separate subcases and always map by a rotation. When
  // `inverted` is set the representative's positive corners are the cell's NEGATIVE (outside)
  // ones, so a template's inside/outside labels swap.
  std::uint8_t symmetry = 0;
  bool inverted = false;
  std::uint16_t cut_edges = 0;        // bit e <=> edge e (Table 1, 0-based) has a sign change
  std::array<double, 12> crossing{};  // s on cut edges (f_a / (f_a - f_b)), NaN elsewhere
  std::uint8_t num_regions = 0;
  std::array<CellRegion, 8> regions{};          // the first num_regions entries, ordered by lowest corner
  std::array<std::uint8_t, 8> corner_region{};  // index into regions of each corner
};

// Classifies one cell. No allocation; throws InputError if a value is not finite.
CellClass classify(const std::array<double, 8>& f);

// The paper's clamp of the crossing parameters (Section 5: s_i = max(min(s_i, 1 - eps), eps)), on
// the cut edges of c, so that no polyhedron has a (near-)zero-length edge. eps in (0, 0.5).
inline void clamp_crossings(CellClass& c, double eps) {
  for (int e = 0; e < 12; ++e)
    if (c.cut_edges >> e & 1)
      c.crossing[e] = c.crossing[e] < eps ? eps : c.crossing[e] > 1 - eps ? 1 - eps : c.crossing[e];
}

// The asymptotic decider of one face (Nielson & Hamann 1991; Chernyaev's face test): with the
// face's diagonal corner values p0, p1 > 0 and n0, n1 <= 0, the positive corners are joined across
// the face iff the bilinear interpolant's saddle value is >= 0, i.e. iff p0 * p1 >= n0 * n1. The
// sign of the difference is computed exactly, so the decision depends only on the four values,
// never on the order in which a cell lists them. A tie (saddle on the surface) joins the positive
// corners, as if every value were raised by an infinitesimal.
bool face_joins_positive(double p0, double p1, double n0, double n1);

// Chernyaev's MC33 case (0..14) of a sign pattern (bit c <=> f[c] > 0), and its ambiguous faces.
int mc_case_of(std::uint8_t sign_mask);
std::uint8_t ambiguous_faces_of(std::uint8_t sign_mask);

// The lookup behind classify(), exposed for kernel generators and tests: for a sign pattern and
// the outcomes of its ambiguous faces (CellClass::face_joins), the subcase without a tunnel and
// the symmetry mapping the cell onto that subcase's representative without (map[0]) or with
// (map[1]) inversion, kNoCubeSymmetry where none does. Both are kNoCubeSymmetry for the face
// outcomes no trilinear function produces (18 of the 64 of each case-13 pattern); classify() uses
// map[preferred] unless a tunnel fixes the inversion (the representative's tunnel sign).
inline constexpr std::uint8_t kNoCubeSymmetry = 0xFF;
struct Mc33Config {
  Subcase subcase = Subcase::kEmpty;
  std::array<std::uint8_t, 2> map = {kNoCubeSymmetry, kNoCubeSymmetry};
  std::uint8_t preferred = 0;
  constexpr bool realisable() const { return map[0] != kNoCubeSymmetry || map[1] != kNoCubeSymmetry; }
};
const Mc33Config& mc33_config(std::uint8_t sign_mask, std::uint8_t face_joins);

}  // namespace mchex
