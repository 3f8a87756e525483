// `mchex-gpu certify` (core/certify.h): the paper's positivity proof re-derived over the cell-type
// table x 24 rotations x MC33 subcases. Asserted: on the cube type (the uniform grid) every subcase
// certifies, direct or through local refinement, which is the paper's claim for cubes (Section 5);
// the run stays under a minute; failures are found and reported, never passed. Known failures on
// the transition cells are pinned below as what they are.
#include <gtest/gtest.h>

#include <cstdio>

#include "core/cell_types.h"
#include "core/certify.h"

namespace mchex {
namespace {

int type_index(const std::string& name) {
  const auto types = cell_types();
  for (std::size_t t = 0; t < types.size(); ++t)
    if (types[t].name == name) return static_cast<int>(t);
  return -1;
}

TEST(certify, CubesCertifyEverySubcaseAndFailuresAreReported) {
  const CertifyResult r = certify();
  std::printf("%s", certify_report(r).c_str());
  EXPECT_LT(r.seconds, 60.0);
  const int cube = type_index("cube");
  ASSERT_GE(cube, 0);
  std::size_t checked = 0;
  for (int s = 0; s < kNumSubcases; ++s) {
    const CertifyEntry& e = r.table[cube][s];
    if (!e.checked) continue;
    ++checked;
    EXPECT_GT(e.hexes, 0u);
    EXPECT_EQ(e.failed_hexes, 0u) << "cube, subcase " << subcase_name(static_cast<Subcase>(s));
    EXPECT_GT(e.min_coefficient, 0) << subcase_name(static_cast<Subcase>(s));
  }
  // The seeded pattern search reaches every subcase but 13.5.2, whose interior test needs values
  // random draws rarely give: reported as not checked, so the run cannot pass.
  EXPECT_EQ(checked, std::size_t(kNumSubcases - 1));
  EXPECT_FALSE(r.table[cube][static_cast<int>(Subcase::k13_5_2)].checked);
  EXPECT_EQ(r.not_landed_subcases, 1u);
  // KNOWN FAILURE (reported by certify, not hidden): plain midpoint subdivision of MC33 case 5 on
  // the node template's transition hex gives hexes with a negative Bernstein coefficient when
  // crossings sit at the clamp ends; the paper claims positivity there (Section 5, cases 1-11).
  const int node = type_index("node");
  ASSERT_GE(node, 0);
  EXPECT_GT(r.table[node][static_cast<int>(Subcase::k5)].failed_hexes, 0u);
  ASSERT_TRUE(r.first_failure.has_value());
  EXPECT_FALSE(r.passed());
  EXPECT_NE(certify_report(r).find("NOT PASSED"), std::string::npos);
}

TEST(certify, RejectsBadEps) {
  CertifyOptions o;
  o.eps = 0.7;
  EXPECT_ANY_THROW(certify(o));
}

}  // namespace
}  // namespace mchex
