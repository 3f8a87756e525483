// `mchex-gpu certify` (core/cutting/certify.h): the paper's positivity proof re-derived over the cell-type
// table x 24 rotations x MC33 subcases. Asserted: every subcase is reached, the cube type (where the
// run-time remedy ends) certifies for every rotation and subcase, every other entry is either proven
// or reported as left to that remedy (the volume-centre search of core/cutting/repair.h and 3.2's
// own-level template included), and the cases that failed before those fixes are kept as regression
// tests that fail without them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include "core/base/error.h"
#include "core/cutting/certify.h"
#include "core/cutting/local_refinement.h"
#include "core/cutting/mc33.h"
#include "core/cutting/polyhedra.h"
#include "core/cutting/repair.h"
#include "core/cutting/subdivide.h"
#include "core/grid/cell_types.h"
#include "core/mesh/quality.h"
#include "tests/standard_cells.h"

namespace mchex {
namespace {

int type_index(const std::string& name) {
  const auto types = cell_types();
  for (std::size_t t = 0; t < types.size(); ++t)
    if (types[t].name == name) return static_cast<int>(t);
  return -1;
}

TEST(certify, TheCubeIsProvenForEverySubcaseAndTheRestIsReported) {
  const CertifyResult r = certify();
  std::printf("%s", certify_report(r).c_str());
  // Its time is printed above, not asserted: ctest runs this beside other tests on shared cores.
  // Every subcase is reached (13.5.2 through its constructed cell). The cube type, on which the
  // run-time remedy ends (every uniform cell, every leaf at max_depth), is proven for every one,
  // without the volume-centre search (the paper's claim for cubes, Section 5).
  EXPECT_EQ(r.not_landed_subcases, 0u);
  const int cube = type_index("single");
  ASSERT_EQ(cube, kProvenForEverySubcase);
  for (int s = 0; s < kNumSubcases; ++s) {
    const CertifyEntry& e = r.table[cube][s];
    EXPECT_TRUE(e.checked) << subcase_name(static_cast<Subcase>(s));
    EXPECT_GT(e.hexes, 0u);
    EXPECT_EQ(e.failed_hexes, 0u) << subcase_name(static_cast<Subcase>(s));
    EXPECT_GT(e.min_coefficient, 0);
    EXPECT_EQ(e.moved_centres, 0u);
  }
  for (std::size_t t = 0; t < r.table.size(); ++t)
    for (int s = 0; s < kNumSubcases; ++s) {
      const CertifyEntry& e = r.table[t][s];
      EXPECT_TRUE(e.checked) << cell_types()[t].name << " " << subcase_name(static_cast<Subcase>(s));
      EXPECT_GT(e.hexes, 0u);
      if (r.proven(static_cast<int>(t), s)) {
        EXPECT_GT(e.min_coefficient, 0);
      }
    }
  EXPECT_TRUE(r.passed());
  // The uncut cell is proven for every type (the templates' hexes are all positive), and the
  // report names what is left to run time.
  for (std::size_t t = 0; t < r.table.size(); ++t) EXPECT_TRUE(r.proven(static_cast<int>(t), 0));
  const std::string report = certify_report(r);
  EXPECT_NE(report.find("certify: PASSED"), std::string::npos);
  if (r.run_time_pairs() > 0) {
    EXPECT_NE(report.find("left to the run-time remedy"), std::string::npos);
  }
}

// Cells of the standard templates that failed before the volume-centre search ("type node ...
// subcase 5", edge-3 3.2 frustums; tests/standard_cells.h): their plain midpoint subdivision is
// not certified, the searched centre is.
struct Regression {
  const char* type;
  int rotation;
  std::array<double, 8> f;
};

const Regression kCase5Node = {"node", 0, {1.0, 1.0, -1e-6, 1.0, -1e-6, -1e-6, -1e-6, -1e-6}};

TEST(certify, RepairRegression) {
  // Case 5 on the node type, every rotation and every end cell of one sign pattern: at least one
  // polyhedron needs the search, and every one is certified after it.
  int moved = 0;
  for (int rot = 0; rot < kNumCubeRotations; ++rot) {
    const HexCorners cell = transform_hex(standard_cells::cell("node"), rot);
    for (int bits = 0; bits < 256; ++bits) {
      std::array<double, 8> f;
      for (int c = 0; c < 8; ++c) f[c] = (kCase5Node.f[c] > 0 ? 1 : -1) * ((bits >> c & 1) ? 1.0 : 1e-6);
      CellClass c = classify(f);
      if (c.subcase != Subcase::k5) continue;
      clamp_crossings(c, 1e-3);
      for (const Polyhedron& p : cut_cell(kUnitCubeCorners, c)) {
        const MappedSubdivision m = subdivide_in_cell(p, cell);
        EXPECT_TRUE(m.certified);
        if (!m.centre_moved) continue;
        ++moved;
        // Plain: corners mapped, centre not moved, some coefficient <= 0.
        bool plain_certified = true;
        for (SubdivisionHex h : midpoint_subdivide(p)) {
          for (Vec3& x : h.corners) x = trilinear_map(cell, x);
          plain_certified = plain_certified && bernstein_certified(h.corners);
        }
        EXPECT_FALSE(plain_certified);
      }
    }
  }
  EXPECT_GT(moved, 0);
}

// 3.2 cells on which the former level-1 template 0x0F left uncertified case-5 frustums on the
// edge-3 and face-3 types (rotation 0; found by sampling, values kept bit for bit) while forced
// inner points took the paper's minimal magnitude; the built-in table (0x7F for a 3.2 cell
// itself) certifies every leaf. Since the virtual values keep their crossings clear
// (kInnerCrossingMargin, core/cutting/local_refinement.h) the former template certifies them too:
// the frustums that failed had a crossing eps from a forced inner point.
const std::array<Regression, 4> k32Cells = {{
    {"edge-3",
     0,
     {-0.80023184976773309, 0.0024679365969736975, -9.3364943151592313e-06, -2.3196484922195297e-05,
      0.0015098064833983793, -1.269003225276984e-06, -0.52868512315137162, -0.055594711141212741}},
    {"edge-3",
     0,
     {-0.052020266741576067, 0.0092515648529132959, -3.7153071182981425e-06, -0.01250744825196491, 0.045291938660762997,
      -9.5067232652614814e-05, -2.0475547419642761e-05, -0.011193036859688912}},
    {"face-3",
     0,
     {-0.012205797993152844, 0.01111078685992543, -0.0021807089640563508, -8.7386685362786671e-05,
      0.00074157405976319922, -0.00033679053056133906, -0.013763310913571181, -2.0608472279174898e-05}},
    {"face-3",
     0,
     {-0.17783885270731686, 7.0774150052236719e-05, -0.23847875357987289, -1.774431784262929e-06, 0.03252499798233905,
      -2.1062121706075532e-06, -2.917806377148307e-05, -4.0843312555070767e-06}},
}};

bool leaves_certified(const HexCorners& cell, const std::array<double, 8>& f, const LocalRefinementTable& table) {
  const CellClass c = classify(f);
  const LocalRefinement lr = refine_locally(cell, f, c, 1e-10, table);
  bool ok = true;
  for (std::size_t i = 0; i < lr.cells.size(); ++i) {
    const LocalRefinementLeaf leaf = leaf_cell(lr, i);
    CellClass lcl = classify(leaf.values);
    clamp_crossings(lcl, 1e-3);
    for (const Polyhedron& p : cut_cell(kUnitCubeCorners, lcl)) ok = ok && subdivide_in_cell(p, leaf.corners).certified;
  }
  return ok;
}

TEST(certify, Subcase3_2RegressionCellsCertify) {
  LocalRefinementTable former = local_refinement_table();
  former[static_cast<int>(Subcase::k3_2)].own_level = false;  // 0x0F at every level
  for (const Regression& r : k32Cells) {
    ASSERT_EQ(classify(r.f).subcase, Subcase::k3_2);
    const HexCorners cell = transform_hex(standard_cells::cell(r.type), r.rotation);
    EXPECT_TRUE(leaves_certified(cell, r.f, former)) << r.type;
    EXPECT_TRUE(leaves_certified(cell, r.f, local_refinement_table())) << r.type;
  }
}

// Why certify's route covers the local-refinement cell types (the paper's 15 + 1) without listing
// them: every cell of a grid is A(type moved by a rotation) for an affine A with det > 0
// (core/grid/cell_types.h), and refine_locally commutes with A (inner points are affine combinations of
// the corners; values and signs do not depend on positions), so the leaves the mesher cuts are the
// images under A of the leaves certify cuts, and the certificate is invariant under A (Theorem 5.2).
TEST(certify, LocalRefinementCommutesWithAffineMaps) {
  const Vec3 a0{0.3, -1.2, 2.0};
  const std::array<Vec3, 3> m = {Vec3{1.7, 0.2, -0.3}, Vec3{0.4, 0.9, 0.1}, Vec3{-0.2, 0.3, 1.3}};
  auto affine = [&](const Vec3& x) { return a0 + x.x * m[0] + x.y * m[1] + x.z * m[2]; };
  ASSERT_GT(triple(m[0], m[1], m[2]), 0);
  int checked = 0;
  for (const Regression& r : k32Cells) {
    const HexCorners cell = transform_hex(standard_cells::cell(r.type), r.rotation);
    HexCorners moved;
    for (int i = 0; i < 8; ++i) moved[i] = affine(cell[i]);
    const CellClass c = classify(r.f);
    const LocalRefinement a = refine_locally(cell, r.f, c, 1e-10), b = refine_locally(moved, r.f, c, 1e-10);
    ASSERT_EQ(a.cells, b.cells);
    ASSERT_EQ(a.values, b.values);
    ASSERT_EQ(a.points.size(), b.points.size());
    for (std::size_t i = 0; i < a.points.size(); ++i) {
      EXPECT_LT(norm(affine(a.points[i]) - b.points[i]), 1e-12);
      ++checked;
    }
  }
  EXPECT_GT(checked, 0);
}

// certify cuts each class of affinely equivalent rotations of a type once (certify.cpp). The
// claim it rests on, checked directly on every such pair: for the same corner values the cut in
// the parametric cube is the same (direct subcases here), and every Bernstein coefficient of every plainly subdivided
// hex in the second cell is det A times the first's, so plain subdivision certifies both or neither.
TEST(certify, AffinelyEquivalentRotationsScaleEveryCoefficientByDetA) {
  const auto types = cell_types();
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto det3 = [](const HexCorners& c) { return dot(c[1] - c[0], cross(c[3] - c[0], c[4] - c[0])); };
  int pairs = 0;
  for (std::size_t t = 0; t < types.size(); ++t)
    for (int q = 1; q < kNumCubeRotations; ++q) {
      const HexCorners b = transform_hex(types[t].corners, q);
      int e = 0;
      while (e < q && !affinely_equivalent(transform_hex(types[t].corners, e), b)) ++e;
      if (e == q) continue;
      const HexCorners a = transform_hex(types[t].corners, e);
      const double det_a = det3(b) / det3(a);
      ASSERT_GT(det_a, 0);
      ++pairs;
      for (int draw = 0; draw < 8; ++draw) {
        std::array<double, 8> f;
        for (double& x : f) x = u(rng);
        CellClass c = classify(f);
        // Refined subcases: their leaves are cut directly, and refine_locally commutes with affine
        // maps (LocalRefinementCommutesWithAffineMaps).
        if (needs_local_refinement(c)) continue;
        clamp_crossings(c, 1e-3);
        for (const Polyhedron& poly : cut_cell(kUnitCubeCorners, c))
          for (const SubdivisionHex& h : midpoint_subdivide(poly)) {
            HexCorners ha, hb;
            for (int k = 0; k < 8; ++k) {
              ha[k] = trilinear_map(a, h.corners[k]);
              hb[k] = trilinear_map(b, h.corners[k]);
            }
            const auto ba = bernstein_jacobian(ha), bb = bernstein_jacobian(hb);
            double scale = 0;
            for (double x : ba) scale = std::max(scale, std::abs(x));
            for (std::size_t k = 0; k < ba.size(); ++k)
              ASSERT_NEAR(bb[k], det_a * ba[k], 1e-9 * det_a * scale)
                  << types[t].name << " rotations " << e << " and " << q << " coefficient " << k;
          }
      }
    }
  // 1200 (type, rotation) pairs form 787 classes.
  EXPECT_EQ(pairs, 1200 - 787);
}

TEST(certify, OneTypeAndTheCube) {
  CertifyOptions o;
  o.types = {"concave-corner-4"};
  const CertifyResult r = certify(o);
  const int chosen = type_index("concave-corner-4");
  for (std::size_t t = 0; t < r.table.size(); ++t) {
    const bool want = static_cast<int>(t) == chosen || static_cast<int>(t) == kProvenForEverySubcase;
    EXPECT_EQ(r.selected[t] != 0, want) << cell_types()[t].name;
    for (int s = 0; s < kNumSubcases; ++s) EXPECT_EQ(r.table[t][s].checked, want);
  }
  EXPECT_TRUE(r.passed());
  EXPECT_NE(certify_report(r).find("2 cell types (of 50)"), std::string::npos);
  o.types = {"no-such-type"};
  try {
    certify(o);
    ADD_FAILURE() << "no error for an unknown type";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown cell type 'no-such-type'"), std::string::npos);
  }
}

TEST(certify, RejectsBadEps) {
  CertifyOptions o;
  o.eps = 0.7;
  EXPECT_ANY_THROW(certify(o));
}

}  // namespace
}  // namespace mchex
