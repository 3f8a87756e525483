// The check and volume-centre search of core/cutting/repair.h. The least coefficients it reports are
// the definition's, bit for bit: every Bernstein coefficient of every mapped hex times 1 / (mean
// edge)^3 (min_element per hex and over all), written here from quality.h's public functions; the
// implementation folds them faster and the search picks its centre from them, so any drift would
// change meshes. The overload that reuses storage gives the same bits as the one that returns, and
// the mapped corners are trilinear_map's.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>

#include "core/cutting/local_refinement.h"
#include "core/cutting/mc33.h"
#include "core/cutting/polyhedra.h"
#include "core/cutting/repair.h"
#include "core/cutting/subdivide.h"
#include "core/grid/cell_types.h"

namespace mchex {
namespace {

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

struct Least {
  std::vector<double> per_hex;
  double all = 0;
};

Least least_by_definition(const std::vector<SubdivisionHex>& hexes) {
  Least r;
  std::vector<double> scaled;
  for (const SubdivisionHex& h : hexes) {
    const double l = mean_edge_length(h.corners);
    const double scale = 1.0 / (l * l * l);
    const std::size_t first = scaled.size();
    for (double b : bernstein_jacobian(h.corners)) scaled.push_back(b * scale);
    r.per_hex.push_back(*std::min_element(scaled.begin() + static_cast<std::ptrdiff_t>(first), scaled.end()));
  }
  r.all = *std::min_element(scaled.begin(), scaled.end());
  return r;
}

// Both overloads on one polyhedron (`reused` keeps the storage of earlier calls), checked against
// each other and against the definition. Counts the searches in `moved`.
void expect_exact(const Polyhedron& p, const HexCorners& cell, MappedSubdivision& reused, int& moved,
                  const std::string& what) {
  const MappedSubdivision ms = subdivide_in_cell(p, cell);
  subdivide_in_cell(p, cell, reused);
  ASSERT_EQ(ms.hexes.size(), reused.hexes.size()) << what;
  for (std::size_t i = 0; i < ms.hexes.size(); ++i) {
    ASSERT_EQ(std::memcmp(ms.hexes[i].corners.data(), reused.hexes[i].corners.data(), sizeof(HexCorners)), 0) << what;
    ASSERT_TRUE(ms.hexes[i].keys == reused.hexes[i].keys) << what;
    ASSERT_TRUE(same_bits(ms.hex_min_scaled[i], reused.hex_min_scaled[i])) << what;
  }
  ASSERT_TRUE(same_bits(ms.min_scaled, reused.min_scaled)) << what;
  ASSERT_EQ(ms.certified, reused.certified) << what;
  ASSERT_EQ(ms.centre_moved, reused.centre_moved) << what;
  moved += ms.centre_moved;
  // Every corner is the cell's trilinear map of the parametric one (the centre, where the search
  // moved it, aside).
  const std::vector<SubdivisionHex> parametric = midpoint_subdivide(p);
  for (std::size_t i = 0; i < ms.hexes.size(); ++i)
    for (int c = 0; c < 8; ++c)
      if (c != 6 || !ms.centre_moved) {
        const Vec3 want = trilinear_map(cell, parametric[i].corners[c]);
        ASSERT_EQ(std::memcmp(&want, &ms.hexes[i].corners[c], sizeof want), 0) << what << " hex " << i;
      }
  // After a search too: the reported values are those of the hexes with the centre it kept.
  const Least want = least_by_definition(ms.hexes);
  for (std::size_t i = 0; i < ms.hexes.size(); ++i)
    ASSERT_TRUE(same_bits(ms.hex_min_scaled[i], want.per_hex[i])) << what << " hex " << i;
  ASSERT_TRUE(same_bits(ms.min_scaled, want.all) || (std::isnan(ms.min_scaled) && std::isnan(want.all))) << what;
  bool all_positive = true;
  for (double v : want.per_hex) all_positive = all_positive && v > 0;
  ASSERT_EQ(ms.certified, all_positive) << what;
}

// Cut cells of every type in some rotations, crossings from random and end values (where the
// search runs), as certify cuts them.
TEST(repair, LeastCoefficientsAreTheDefinitionsBitForBit) {
  const auto types = cell_types();
  std::mt19937_64 rng(29);
  std::uniform_real_distribution<double> u(0.05, 1.0);
  MappedSubdivision reused;
  int polyhedra = 0, moved = 0;
  for (std::size_t t = 0; t < types.size(); ++t)
    for (int q = 0; q < kNumCubeRotations; q += 5) {
      const HexCorners cell = transform_hex(types[t].corners, q);
      for (int s = 0; s < 40; ++s) {
        std::array<double, 8> f;
        for (double& x : f) x = (rng() & 1 ? 1.0 : -1.0) * (s % 2 ? u(rng) : (rng() & 1 ? 1.0 : 1e-6));
        CellClass c = classify(f);
        if (needs_local_refinement(c, cell)) continue;
        clamp_crossings(c, 1e-3);
        for (const Polyhedron& p : cut_cell(kUnitCubeCorners, c)) {
          ++polyhedra;
          expect_exact(p, cell, reused, moved, std::string(types[t].name) + " rotation " + std::to_string(q));
        }
      }
    }
  EXPECT_GT(polyhedra, 10000);
  EXPECT_GT(moved, 0);  // the search ran on some
}

// Degenerate cells: flat (every coefficient 0), inverted (all negative), and with a corner at
// infinity (inf - inf: NaN coefficients), where the fast fold steps aside.
TEST(repair, DegenerateCellsFollowTheDefinitionToo) {
  CellClass c = classify({1, -1, -1, -1, -1, -1, -1, -1});
  clamp_crossings(c, 1e-3);
  HexCorners flat = kUnitCubeCorners, inverted = kUnitCubeCorners, infinite = kUnitCubeCorners;
  for (int i = 4; i < 8; ++i) flat[i].z = 0;
  for (Vec3& x : inverted) x.z = -x.z;
  infinite[6] = {std::numeric_limits<double>::infinity(), 1, 1};
  MappedSubdivision reused;
  int moved = 0;
  for (const HexCorners& cell : {flat, inverted, infinite})
    for (const Polyhedron& p : cut_cell(kUnitCubeCorners, c)) expect_exact(p, cell, reused, moved, "degenerate");
}

}  // namespace
}  // namespace mchex
