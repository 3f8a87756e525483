// Cutting cells into 3-regular polyhedra (core/cutting/polyhedra.h) and midpoint subdivision
// (core/cutting/subdivide.h), checked on every sign pattern against the facts of docs/mc33.md
// (regions, corner counts, polyhedron V/F, hexes = 8 + 2 * cut edges) and against geometry that
// does not share their code (volumes by the divergence theorem and by the exact trilinear hex
// volume). Then the Bernstein certificate of every hex, per subcase: every subcase that
// core/cutting/local_refinement.h cuts directly is asserted 100% certified; the refined ones (their
// direct cut is what makes them refined) are measured and printed. tests/test_local_refinement.cpp
// certifies the refined cells.
//
// Figure 6 numbers its templates in its own order, not Chernyaev's. The volume centres the paper
// gives identify them: "Case 12", ((5+s1+s6)/10, (3+s10+s11)/10, (4+s3+s7)/10), is the 10-vertex
// polyhedron of corners {0,1,5,6} cut on Table-1 edges 1, 3, 6, 7, 10, 11: MC33 case 11 here
// (its canonical pattern); "Case 14", ((5+s1+s6+s9+s12)/12, (6+s10+s11)/12, (6+s7+s8)/12), is a
// 12-vertex polyhedron of corners {1,2,5,7} with 8 cut edges: the 4-corner region of MC33 12.1.1
// (or of 12.2, which has two such regions; the paper's Table 3 offsets are for the transition
// cells 2, 5 and 6 only, and 12.1.1 certifies fully on cubes here, so 12.1.1 is the likelier).
// Case 11 (and its mirror 14) fails plain subdivision for crossings near 0 and 1; cut_cell moves
// their volume centres by the offset of core/cutting/volume_centre_offset.h (the paper's Eq. 14), which
// certifies them on affine cells, and local refinement takes them on the other cells.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "core/cutting/local_refinement.h"
#include "core/cutting/mc33.h"
#include "core/cutting/polyhedra.h"
#include "core/cutting/repair.h"
#include "core/cutting/subdivide.h"
#include "core/mesh/quality.h"
#include "tests/cell_samples.h"

namespace mchex {
namespace {

// ---- docs/mc33.md: per subcase, each region's (corners, V, F), sorted -------------------------

struct RegionFact {
  int corners, v, f;
  friend auto operator<=>(const RegionFact&, const RegionFact&) = default;
};

std::map<Subcase, std::vector<RegionFact>> notes_facts() {
  using S = Subcase;
  std::map<Subcase, std::vector<RegionFact>> m = {
      {S::kEmpty, {{8, 8, 6}}},
      {S::k1, {{1, 4, 4}, {7, 10, 7}}},
      {S::k2, {{2, 6, 5}, {6, 10, 7}}},
      {S::k3_1, {{1, 4, 4}, {1, 4, 4}, {6, 12, 8}}},
      {S::k3_2, {{2, 8, 6}, {6, 12, 8}}},
      {S::k4_1_1, {{1, 4, 4}, {1, 4, 4}, {6, 12, 8}}},
      {S::k5, {{3, 8, 6}, {5, 10, 7}}},
      {S::k6_1_1, {{1, 4, 4}, {2, 6, 5}, {5, 12, 8}}},
      {S::k6_2, {{3, 10, 7}, {5, 12, 8}}},
      {S::k7_1, {{1, 4, 4}, {1, 4, 4}, {1, 4, 4}, {5, 14, 9}}},
      {S::k7_2, {{1, 4, 4}, {2, 8, 6}, {5, 14, 9}}},
      {S::k7_3, {{3, 12, 8}, {5, 14, 9}}},
      {S::k7_4_1, {{1, 4, 4}, {3, 12, 8}, {4, 10, 7}}},
      {S::k8, {{4, 8, 6}, {4, 8, 6}}},
      {S::k9, {{4, 10, 7}, {4, 10, 7}}},
      {S::k10_1_1, {{2, 6, 5}, {2, 6, 5}, {4, 12, 8}}},
      {S::k10_2, {{4, 12, 8}, {4, 12, 8}}},
      {S::k11, {{4, 10, 7}, {4, 10, 7}}},
      {S::k12_1_1, {{1, 4, 4}, {3, 8, 6}, {4, 12, 8}}},
      {S::k12_2, {{4, 12, 8}, {4, 12, 8}}},
      {S::k13_1, {{1, 4, 4}, {1, 4, 4}, {1, 4, 4}, {1, 4, 4}, {4, 16, 10}}},
      {S::k13_2, {{1, 4, 4}, {1, 4, 4}, {2, 8, 6}, {4, 16, 10}}},
      {S::k13_3, {{1, 4, 4}, {3, 12, 8}, {4, 16, 10}}},
      {S::k13_4, {{4, 16, 10}, {4, 16, 10}}},
      {S::k13_5_1, {{1, 4, 4}, {1, 4, 4}, {3, 12, 8}, {3, 12, 8}}},
      {S::k14, {{4, 10, 7}, {4, 10, 7}}},
  };
  for (auto& [s, v] : m) std::sort(v.begin(), v.end());
  return m;
}

// Subcases certified under midpoint subdivision (plain, or with the volume-centre offset of 11
// and 14) in every sample, asserted: exactly those that local refinement leaves to the direct cut
// on affine cells, which every geometry of this file is.
bool asserted_direct(Subcase s) { return !needs_local_refinement(s, CellShape::kAffine); }

// ---- Samples ---------------------------------------------------------------------------------

using Cell = std::array<double, 8>;
using Corners = std::array<Vec3, 8>;

Corners unit_cube() {
  Corners c;
  for (int i = 0; i < 8; ++i)
    c[i] = {double(kCubeCorners[i][0]), double(kCubeCorners[i][1]), double(kCubeCorners[i][2])};
  return c;
}

// The unit cube and 3 random affine images of it (tests/cell_samples.h).
std::vector<Corners> geometries(std::mt19937_64& rng) {
  std::vector<Corners> out = {unit_cube()};
  while (out.size() < 4) out.push_back(test::random_affine_cube(rng));
  return out;
}

using test::draw_cell;

// ---- Checks of one polyhedron ----------------------------------------------------------------

struct Shape {
  int v = 0, e = 0, f = 0;
};

// 3-regular, closed and consistently oriented (each directed edge once, its reverse once),
// Euler characteristic 2.
Shape check_polyhedron(const Polyhedron& p, const std::string& where) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  for (const auto& face : p.faces) {
    EXPECT_GE(face.size(), 3u) << where;
    for (std::size_t i = 0; i < face.size(); ++i) ++directed[{face[i], face[(i + 1) % face.size()]}];
  }
  std::vector<std::set<std::uint32_t>> nbrs(p.points.size());
  for (const auto& [uv, n] : directed) {
    EXPECT_EQ(n, 1) << where << ": directed edge used twice";
    EXPECT_EQ(directed.count({uv.second, uv.first}), 1u) << where << ": open or misoriented edge";
    nbrs[uv.first].insert(uv.second);
  }
  for (std::size_t i = 0; i < nbrs.size(); ++i)
    EXPECT_EQ(nbrs[i].size(), 3u) << where << ": vertex " << i << " not of degree 3";
  Shape s{int(p.points.size()), int(directed.size() / 2), int(p.faces.size())};
  EXPECT_EQ(s.v - s.e + s.f, 2) << where;
  return s;
}

// The isosurface loops as cyclic key sequences starting at their smallest key.
std::vector<int> canonical_loop(const Polyhedron& p, const std::vector<std::uint32_t>& f, bool reversed) {
  std::vector<int> k;
  for (std::uint32_t i : f) k.push_back(p.keys[i]);
  if (reversed) std::reverse(k.begin(), k.end());
  std::rotate(k.begin(), std::min_element(k.begin(), k.end()), k.end());
  return k;
}

struct Stats {
  long cells = 0, hexes = 0, certified = 0, cells_all_certified = 0;
  double min_scaled = 1e300;
};

bool is_unit(const Corners& c) { return c == unit_cube(); }

TEST(polyhedra, EmptyCellIsTheCubeAndGivesTheEightOctants) {
  CellClass c = classify({1, 1, 1, 1, 1, 1, 1, 1});
  const auto polys = cut_cell(unit_cube(), c);
  ASSERT_EQ(polys.size(), 1u);
  EXPECT_EQ(polys[0].points.size(), 8u);
  EXPECT_EQ(polys[0].faces.size(), 6u);
  EXPECT_EQ(polys[0].region_sign, 1);
  const auto hexes = midpoint_subdivide(polys[0]);
  ASSERT_EQ(hexes.size(), 8u);
  for (const auto& h : hexes) {
    // Each octant is a right-handed cube of side 1/2 at one corner of the cell.
    EXPECT_NEAR(hex_volume(h.corners), 0.125, 1e-14);
    EXPECT_NEAR(scaled_jacobian(h.corners), 1.0, 1e-12);
  }
}

TEST(polyhedra, TunnelSubcasesAreRefused) {
  // 4.1.2: corners 0 and 6 joined inside: a large value at both makes the interior positive.
  CellClass c = classify({10, -1, -1, -1, -1, -1, 10, -1});
  ASSERT_EQ(c.subcase, Subcase::k4_1_2);
  EXPECT_THROW(cut_cell(unit_cube(), c), TunnelSubcaseError);
}

// The failure that makes case 11 (the paper's Figure 6 "Case 12") need the volume-centre offset,
// as a regression: positive corners {0,1,5,6} (the canonical pattern) with crossings s3 = s7 =
// 0.048, s9 = 0.952, s2 = s4 = s12 = 0.5 (paper Table 1 numbering). Plain midpoint subdivision
// (the vertex mean as volume centre) gives a hex with det J < 0 at a corner (min Bernstein
// coefficient about -1.6e-3 on the unit cube; a scan of corner magnitudes in {1, t} finds failures
// from t = 0.05 on and none at t >= 0.1). cut_cell's offset centre certifies it on the cube
// (tests/test_volume_centre_offset.cpp), and local refinement (core/cutting/local_refinement.h, the
// route on non-affine cells) certifies every hex of the same cell too.
TEST(polyhedra, Case11CounterexampleIsRefinedAndCertifies) {
  const Cell f = {0.05, 0.05, -0.05, -0.05, -1, 0.05, 1, -1};
  const CellClass c = classify(f);
  ASSERT_EQ(c.subcase, Subcase::k11);
  double worst = 1e300, offset = 1e300;
  for (Polyhedron p : cut_cell(unit_cube(), c)) {
    for (const auto& h : midpoint_subdivide(p)) offset = std::min(offset, min_bernstein(h.corners));
    p.volume_centre.reset();
    for (const auto& h : midpoint_subdivide(p)) worst = std::min(worst, min_bernstein(h.corners));
  }
  EXPECT_LT(worst, 0);
  EXPECT_GT(offset, 0);
  EXPECT_FALSE(needs_local_refinement(c, unit_cube()));
  ASSERT_TRUE(needs_local_refinement(c));
  const LocalRefinement r = refine_locally(unit_cube(), f, c, 1e-10);
  long hexes = 0;
  for (const auto& leaf : r.cells) {
    Corners g;
    Cell lf;
    for (int j = 0; j < 8; ++j) {
      g[j] = r.points[leaf[j]];
      lf[j] = r.values[leaf[j]];
    }
    CellClass lc = classify(lf);
    for (int e = 0; e < 12; ++e)
      if (lc.cut_edges >> e & 1) lc.crossing[e] = std::clamp(lc.crossing[e], 1e-3, 1 - 1e-3);
    for (const Polyhedron& p : cut_cell(g, lc))
      for (const auto& h : midpoint_subdivide(p)) {
        EXPECT_TRUE(bernstein_certified(h.corners));
        ++hexes;
      }
  }
  EXPECT_EQ(hexes, local_refinement_hexes(Subcase::k11));
}

TEST(polyhedra, AllSignPatternsCutSubdivideAndCertify) {
  const auto facts = notes_facts();
  std::mt19937_64 rng(20250917);
  const auto geoms = geometries(rng);
  constexpr int kDraws = 24;                      // per pattern, geometry and kind (random / extreme)
  std::map<Subcase, std::array<Stats, 2>> stats;  // [0] random magnitudes, [1] extreme
  std::set<Subcase> tunnels_seen;
  for (int mask = 0; mask < 256; ++mask) {
    for (int extreme = 0; extreme < 2; ++extreme) {
      for (int d = 0; d < kDraws; ++d) {
        const Cell f = draw_cell(static_cast<std::uint8_t>(mask), extreme, rng);
        const CellClass c = classify(f);
        if (subcase_has_tunnel(c.subcase)) {
          tunnels_seen.insert(c.subcase);
          EXPECT_THROW(cut_cell(geoms[0], c), TunnelSubcaseError);
          continue;
        }
        for (const Corners& g : geoms) {
          const std::string where = "mask " + std::to_string(mask) + " subcase " +
                                    std::string(subcase_name(c.subcase)) + (is_unit(g) ? " unit" : " affine");
          const auto polys = cut_cell(g, c);
          ASSERT_EQ(polys.size(), c.num_regions) << where;
          // Topology against docs/mc33.md's table.
          std::vector<RegionFact> got;
          for (std::size_t r = 0; r < polys.size(); ++r) {
            const Polyhedron& p = polys[r];
            EXPECT_EQ(p.corners, c.regions[r].corners) << where;
            EXPECT_EQ(p.region_sign, c.regions[r].sign) << where;
            const Shape s = check_polyhedron(p, where);
            got.push_back({std::popcount(p.corners), s.v, s.f});
          }
          std::sort(got.begin(), got.end());
          ASSERT_TRUE(facts.count(c.subcase)) << where;
          EXPECT_EQ(got, facts.at(c.subcase)) << where;
          // Each isosurface loop bounds one inside and one outside polyhedron, oppositely.
          std::multiset<std::vector<int>> pos, neg;
          for (const Polyhedron& p : polys)
            for (std::size_t i = p.num_cell_face_pieces; i < p.faces.size(); ++i)
              (p.region_sign > 0 ? pos : neg).insert(canonical_loop(p, p.faces[i], p.region_sign < 0));
          EXPECT_EQ(pos, neg) << where;
          // Volumes: polyhedra and hexes each fill the cell.
          const double cell_volume = hex_volume(g);
          double poly_volume = 0, hex_sum = 0;
          std::size_t num_hexes = 0;
          Stats& st = stats[c.subcase][extreme];
          bool all = true;
          for (const Polyhedron& p : polys) {
            const double v = polyhedron_volume(p);
            EXPECT_GT(v, 0) << where;
            poly_volume += v;
            const auto hexes = midpoint_subdivide(p);
            EXPECT_EQ(hexes.size(), p.points.size()) << where;
            num_hexes += hexes.size();
            for (const auto& h : hexes) {
              hex_sum += hex_volume(h.corners);
              const bool ok = bernstein_certified(h.corners);
              all = all && ok;
              ++st.hexes;
              st.certified += ok;
              st.min_scaled = std::min(st.min_scaled, min_bernstein_scaled(h.corners));
            }
          }
          ++st.cells;
          st.cells_all_certified += all;
          EXPECT_NEAR(poly_volume, cell_volume, 1e-12 * cell_volume) << where;
          EXPECT_NEAR(hex_sum, cell_volume, 1e-12 * cell_volume) << where;
          const int cut = std::popcount(c.cut_edges);
          EXPECT_EQ(num_hexes, std::size_t(8 + 2 * cut)) << where;
        }
      }
    }
  }
  // Every non-tunnel subcase must have been reached, else the checks above say nothing about it.
  for (const auto& [s, v] : facts) EXPECT_TRUE(stats.count(s)) << subcase_name(s) << " never drawn";

  std::printf("\nBernstein certificate of midpoint subdivision (11, 14: offset centres; all 27 coefficients > 0),\n"
              "per subcase: certified hexes / hexes, cells with every hex certified / cells, min\n"
              "scaled coefficient; random magnitudes | crossings near 0 and 1\n");
  for (const auto& [s, pair] : stats) {
    std::printf("%-7s %s", std::string(subcase_name(s)).c_str(), asserted_direct(s) ? "asserted" : "measured");
    for (const Stats& st : pair)
      std::printf(" | %6ld/%6ld (%5.1f%%) cells %5ld/%5ld min %.2e", st.certified, st.hexes,
                  st.hexes ? 100.0 * st.certified / st.hexes : 0.0, st.cells_all_certified, st.cells, st.min_scaled);
    std::printf("\n");
  }
  std::printf("tunnel subcases refused:");
  for (Subcase s : tunnels_seen) std::printf(" %s", std::string(subcase_name(s)).c_str());
  std::printf("\n");
  for (const auto& [s, pair] : stats) {
    if (!asserted_direct(s)) continue;
    for (int extreme = 0; extreme < 2; ++extreme) {
      const Stats& st = pair[extreme];
      EXPECT_EQ(st.certified, st.hexes) << "subcase " << subcase_name(s) << ": cut directly, so it must certify";
    }
  }
}

}  // namespace
}  // namespace mchex

namespace mchex {
namespace {

// The mesher's shortcut (core/cutting/repair.h): an uncut right-handed parallelepiped needs no check.
// Random parallelepipeds, checked with the full certificate; mirror images and warped cells are
// refused.
TEST(polyhedra, UncutAffineCellsAreCertifiedWithoutTheCheck) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const CellClass empty = classify({1, 1, 1, 1, 1, 1, 1, 1});
  const auto polys = cut_cell(kUnitCubeCorners, empty);
  ASSERT_EQ(polys.size(), 1u);
  int accepted = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const Vec3 a{u(rng), u(rng), u(rng)}, b{u(rng), u(rng), u(rng)}, c{u(rng), u(rng), u(rng)};
    const Vec3 o{10 * u(rng), 10 * u(rng), 10 * u(rng)};
    HexCorners x;
    for (int i = 0; i < 8; ++i)
      x[i] = o + kUnitCubeCorners[i].x * a + kUnitCubeCorners[i].y * b + kUnitCubeCorners[i].z * c;
    const bool shortcut = uncut_affine_cell_certified(x);
    bool all = true;
    for (SubdivisionHex h : midpoint_subdivide(polys[0])) {
      for (Vec3& p : h.corners) p = trilinear_map(x, p);
      all = all && bernstein_certified(h.corners);
    }
    if (shortcut) {
      EXPECT_TRUE(all) << "trial " << trial;
      ++accepted;
    }
    if (dot(a, cross(b, c)) < 0) {
      EXPECT_FALSE(shortcut) << "a mirror image, trial " << trial;
    }
  }
  EXPECT_GT(accepted, 500);
  HexCorners warped = kUnitCubeCorners;
  warped[6] += Vec3{0.2, 0.1, 0.3};
  EXPECT_FALSE(uncut_affine_cell_certified(warped));
}

}  // namespace
}  // namespace mchex
