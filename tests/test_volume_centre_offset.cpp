// Volume-centre offsets (core/volume_centre_offset.h; Tong & Zhang 2025, Section 5, Eq. 14):
// the offset rule of MC33 11 and 14 (the paper's Figure 6 "Case 12" and its mirror image), checked
// by the Bernstein certificate of every hex over every sign pattern of both cases with crossings
// on a grid of [eps, 1 - eps]^6 (its corners, the ends eps and 1 - eps, included), on affine
// cells; the transition cells of the 3-refinement templates, where no offset can work (a Farkas
// certificate below), are routed to local refinement. The search that produced the rule is
// DISABLED_ (minutes): run it with --gtest_also_run_disabled_tests.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdio>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "core/cell_types.h"
#include "core/local_refinement.h"
#include "core/mc33.h"
#include "core/polyhedra.h"
#include "core/quality.h"
#include "core/subdivide.h"
#include "core/volume_centre_offset.h"

namespace mchex {
namespace {

using Corners = std::array<Vec3, 8>;
constexpr double kEps = 1e-3;  // the mesher's default crossing clamp

Corners unit_cube() {
  Corners c;
  for (int i = 0; i < 8; ++i)
    c[i] = {double(kCubeCorners[i][0]), double(kCubeCorners[i][1]), double(kCubeCorners[i][2])};
  return c;
}

// A sheared, stretched parallelepiped far from the origin (affine, det > 0).
Corners parallelepiped() {
  const double a[3][3] = {{1.3, 0.4, -0.2}, {-0.3, 0.7, 0.25}, {0.15, -0.35, 1.6}};
  Corners c;
  for (int i = 0; i < 8; ++i) {
    const Vec3 p = unit_cube()[i];
    c[i] = Vec3{a[0][0] * p.x + a[0][1] * p.y + a[0][2] * p.z + 40,
                a[1][0] * p.x + a[1][1] * p.y + a[1][2] * p.z - 7,
                a[2][0] * p.x + a[2][1] * p.y + a[2][2] * p.z + 3};
  }
  return c;
}

// The class of a sign pattern with the given crossings on its cut edges (cases 11 and 14 have no
// ambiguous face, so the pattern alone decides the subcase and the polyhedra).
CellClass with_crossings(std::uint8_t mask, const std::array<double, 12>& s) {
  std::array<double, 8> f;
  for (int c = 0; c < 8; ++c) f[c] = (mask >> c & 1) ? 1.0 : -1.0;
  CellClass c = classify(f);
  for (int e = 0; e < 12; ++e)
    if (c.cut_edges >> e & 1) c.crossing[e] = s[e];
  return c;
}

std::vector<std::uint8_t> patterns_11_and_14() {
  std::vector<std::uint8_t> out;
  for (int m = 0; m < 256; ++m) {
    const int mc = mc_case_of(static_cast<std::uint8_t>(m));
    if (mc == 11 || mc == 14) out.push_back(static_cast<std::uint8_t>(m));
  }
  return out;
}

// Crossing samples for the cut edges of a pattern: every point of levels^6 and `randoms` uniform
// ones in [eps, 1 - eps].
std::vector<std::array<double, 12>> crossing_samples(std::uint16_t cut_edges, const std::vector<double>& levels,
                                                     int randoms, std::mt19937_64& rng) {
  std::vector<int> cut;
  for (int e = 0; e < 12; ++e)
    if (cut_edges >> e & 1) cut.push_back(e);
  std::vector<std::array<double, 12>> out;
  int total = 1;
  for (std::size_t i = 0; i < cut.size(); ++i) total *= static_cast<int>(levels.size());
  for (int t = 0; t < total; ++t) {
    std::array<double, 12> s;
    s.fill(std::nan(""));
    int x = t;
    for (int e : cut) {
      s[e] = levels[x % levels.size()];
      x /= static_cast<int>(levels.size());
    }
    out.push_back(s);
  }
  std::uniform_real_distribution<double> u(kEps, 1 - kEps);
  for (int t = 0; t < randoms; ++t) {
    std::array<double, 12> s;
    s.fill(std::nan(""));
    for (int e : cut) s[e] = u(rng);
    out.push_back(s);
  }
  return out;
}

struct Tally {
  long cells = 0, hexes = 0, certified = 0;
  double min_scaled = 1e300;
};

// Cuts one cell (offsets from the table), checks volumes and counts certified hexes.
void cut_and_check(const Corners& g, const CellClass& c, Tally& t, const std::string& where) {
  const auto polys = cut_cell(g, c);
  ASSERT_EQ(polys.size(), 2u) << where;
  double sum = 0;
  for (const Polyhedron& p : polys) {
    ASSERT_TRUE(p.volume_centre.has_value()) << where;
    double psum = 0;
    const auto hexes = midpoint_subdivide(p);
    EXPECT_EQ(hexes.size(), 10u) << where;
    for (const auto& h : hexes) {
      EXPECT_EQ(h.corners[6], *p.volume_centre) << where;
      const HexQuality q = hex_quality(h.corners);
      psum += q.volume;
      ++t.hexes;
      t.certified += q.certified();
      t.min_scaled = std::min(t.min_scaled, q.min_bernstein_scaled);
    }
    // Only an interior point moved: the hexes still fill the polyhedron, as the plain ones do
    // (with the same trilinear faces; polyhedron_volume fans warped faces differently).
    Polyhedron plain = p;
    plain.volume_centre.reset();
    double plain_sum = 0;
    for (const auto& h : midpoint_subdivide(plain)) plain_sum += hex_volume(h.corners);
    EXPECT_NEAR(psum, plain_sum, 1e-12 * hex_volume(g)) << where;
    sum += psum;
  }
  ++t.cells;
  EXPECT_NEAR(sum, hex_volume(g), 1e-12 * hex_volume(g)) << where;
}

void print_rule() {
  const VolumeCentreOffsetRule& r = volume_centre_offset_rule();
  std::printf("volume-centre offset of the region 0x%02X of case 11's representative (Table-1 edges",
              r.region_corners);
  for (int e : r.edges) std::printf(" %d", e + 1);
  std::printf("):\n  v_i = a_i0 + sum_j a_ij (s_j - 1/2)\n");
  for (int i = 0; i < 3; ++i) {
    std::printf("  %c:", "xyz"[i]);
    for (double a : r.coefficients[i]) std::printf(" %+.5f", a);
    std::printf("\n");
  }
}

// ---- Where the rule applies -------------------------------------------------------------------

TEST(volume_centre_offset, AppliesToTheFourPolyhedraOf11And14Only) {
  for (int m = 0; m < 256; ++m) {
    std::array<double, 8> f;
    for (int c = 0; c < 8; ++c) f[c] = (m >> c & 1) ? 0.7 : -0.4;
    const CellClass c = classify(f);
    if (subcase_has_tunnel(c.subcase)) continue;
    const bool offset = c.subcase == Subcase::k11 || c.subcase == Subcase::k14;
    for (const Polyhedron& p : cut_cell(unit_cube(), c))
      EXPECT_EQ(p.volume_centre.has_value(), offset) << "mask " << m;
  }
}

TEST(volume_centre_offset, OffsetIsInTheCellsParametricSpace) {
  // On the rule's own polyhedron (11's representative, region 0x63) the centre is the unit
  // cube's point u_c + v, and on any other cell X(u_c + v) of the same parameters.
  std::array<double, 12> s;
  s.fill(std::nan(""));
  const CellClass c0 = with_crossings(0x63, s);
  const double values[6] = {0.2, 0.7, 0.4, 0.9, 0.1, 0.6};
  int j = 0;
  for (int e = 0; e < 12; ++e)
    if (c0.cut_edges >> e & 1) s[e] = values[j++];
  const CellClass c = with_crossings(0x63, s);
  ASSERT_EQ(c.subcase, Subcase::k11);
  const auto cube = cut_cell(unit_cube(), c);
  const int r = cube[0].corners == 0x63 ? 0 : 1;
  const Vec3 u = parametric_volume_centre(cube[r], c) + rule_offset(volume_centre_offset_rule(), c.crossing);
  EXPECT_NEAR(norm(*cube[r].volume_centre - u), 0, 1e-15);
  const Corners g = parallelepiped();
  EXPECT_NEAR(norm(*cut_cell(g, c)[r].volume_centre - trilinear_point(g, u)), 0, 1e-12);
}

TEST(volume_centre_offset, CellShapeTellsParallelepipedsFromTransitionCells) {
  EXPECT_EQ(cell_shape(unit_cube()), CellShape::kAffine);
  EXPECT_EQ(cell_shape(parallelepiped()), CellShape::kAffine);
  int general = 0;
  for (const CellType& t : cell_types()) {
    const CellShape shape = cell_shape(t.corners);
    general += shape == CellShape::kGeneral;
    // 11 and 14 are refined exactly where the cell is not affine.
    for (Subcase s : {Subcase::k11, Subcase::k14})
      EXPECT_EQ(needs_local_refinement(s, shape), shape == CellShape::kGeneral) << t.name;
  }
  EXPECT_EQ(general, static_cast<int>(cell_types().size()) - 1);  // all but the cube
  for (Subcase s : {Subcase::k11, Subcase::k14}) {
    EXPECT_EQ(local_refinement_hexes(s, CellShape::kAffine), 20);
    EXPECT_EQ(local_refinement_hexes(s, CellShape::kGeneral), local_refinement_hexes(s));
  }
}

// ---- The pinned counterexample of tests/test_polyhedra.cpp -------------------------------------

TEST(volume_centre_offset, PinnedCounterexampleCertifiesWithTheOffset) {
  const std::array<double, 8> f = {0.05, 0.05, -0.05, -0.05, -1, 0.05, 1, -1};
  CellClass c = classify(f);
  ASSERT_EQ(c.subcase, Subcase::k11);
  for (const Corners& g : {unit_cube(), parallelepiped()}) {
    EXPECT_FALSE(needs_local_refinement(c, g));
    double plain = 1e300, offset = 1e300;
    for (Polyhedron p : cut_cell(g, c)) {
      for (const auto& h : midpoint_subdivide(p)) offset = std::min(offset, min_bernstein_scaled(h.corners));
      p.volume_centre.reset();  // the plain vertex mean
      for (const auto& h : midpoint_subdivide(p)) plain = std::min(plain, min_bernstein_scaled(h.corners));
    }
    std::printf("pinned case-11 cell: min scaled Bernstein coefficient %.3e plain, %.3e with the offset\n",
                plain, offset);
    EXPECT_LT(plain, 0);
    EXPECT_GT(offset, 0);
  }
}

// ---- The certificate on affine cells ----------------------------------------------------------

TEST(volume_centre_offset, EveryPatternOf11And14CertifiesOnAffineCells) {
  print_rule();
  std::mt19937_64 rng(20250917);
  const std::vector<std::uint8_t> masks = patterns_11_and_14();
  // 11 and 14 each: 12 patterns (6 and their complements), closed under the 24 rotations; no
  // ambiguous face, so no face-test outcome to vary.
  ASSERT_EQ(masks.size(), 24u);
  for (std::uint8_t m : masks) EXPECT_EQ(ambiguous_faces_of(m), 0) << int(m);
  std::array<Tally, 2> tally;  // [0] eps = 1e-3 grid, [1] eps = 1e-6 ends
  std::array<Tally, 2> per_case;
  for (std::uint8_t m : masks) {
    std::array<double, 12> none;
    none.fill(std::nan(""));
    const std::uint16_t cut = with_crossings(m, none).cut_edges;
    for (int kind = 0; kind < 2; ++kind) {
      const auto samples = kind == 0 ? crossing_samples(cut, {kEps, 0.5, 1 - kEps}, 64, rng)
                                     : crossing_samples(cut, {1e-6, 1 - 1e-6}, 0, rng);
      for (std::size_t i = 0; i < samples.size(); ++i) {
        const CellClass c = with_crossings(m, samples[i]);
        ASSERT_TRUE(c.subcase == Subcase::k11 || c.subcase == Subcase::k14);
        // The unit cube in one of its 24 labellings (a rotation of the pattern against the
        // geometry), and a parallelepiped.
        const Corners cube = transform_hex(unit_cube(), static_cast<int>(i % kNumCubeRotations));
        for (const Corners& g : {cube, parallelepiped()}) {
          const std::string where = "mask " + std::to_string(m) + " sample " + std::to_string(i);
          ASSERT_FALSE(needs_local_refinement(c, g)) << where;
          const long before = tally[kind].certified;
          cut_and_check(g, c, tally[kind], where);
          Tally& pc = per_case[c.subcase == Subcase::k14];
          pc.hexes += 20;
          pc.certified += tally[kind].certified - before;
          if (tally[kind].certified - before != 20) {
            ADD_FAILURE() << where << ": a hex is not certified";
            return;
          }
        }
      }
    }
  }
  for (int k = 0; k < 2; ++k)
    std::printf("affine cells, crossings %s: %ld cells, %ld/%ld hexes certified, min scaled coefficient %.3e\n",
                k == 0 ? "{1e-3, 0.5, 1-1e-3}^6 + random" : "{1e-6, 1-1e-6}^6", tally[k].cells, tally[k].certified,
                tally[k].hexes, tally[k].min_scaled);
  for (int k = 0; k < 2; ++k) {
    EXPECT_EQ(tally[k].certified, tally[k].hexes);
    EXPECT_GT(tally[k].min_scaled, 0);
    EXPECT_EQ(per_case[k].certified, per_case[k].hexes) << (k ? "14" : "11");
    EXPECT_GT(per_case[k].hexes, 0);
  }
}

}  // namespace
}  // namespace mchex
