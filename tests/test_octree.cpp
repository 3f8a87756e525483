// Adaptive 3-refinement (core/octree.h): refinement by the paper's error with one SDF batch per
// level, balancing to a fixed point, and the conforming complex of templates. Conformity is
// checked by the project's independent checker (core/mesh_check.h): the complex is split into two
// meshes that must tile the box face for face with no gap (a hanging node leaves a face in one
// hex inside the box), every face in at most two hexes, volumes adding up to the box.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <mutex>
#include <random>
#include <set>

#include <tbb/global_control.h>

#include "core/cell_types.h"
#include "core/grid.h"
#include "core/hex_complex.h"
#include "core/mc33.h"
#include "core/mesh_check.h"
#include "core/octree.h"
#include "core/refinement_error.h"
#include "core/ro.h"
#include "core/shapes.h"

namespace mchex {
namespace {

const Box kUnitCube{{0, 0, 0}, {1, 1, 1}};

// A SignedDistance that records every batch it is asked for.
class RecordingSdf final : public SignedDistance {
 public:
  explicit RecordingSdf(const SignedDistance& inner) : inner_(inner) {}
  void evaluate(std::span<const Vec3> points, std::span<double> values) const override {
    std::lock_guard lock(mutex_);
    batches.push_back(points.size());
    all.insert(all.end(), points.begin(), points.end());
    inner_.evaluate(points, values);
  }
  Box bounds() const override { return inner_.bounds(); }
  mutable std::vector<std::size_t> batches;
  mutable std::vector<Vec3> all;

 private:
  const SignedDistance& inner_;
  mutable std::mutex mutex_;
};

// f = a linear function: the trilinear interpolant is exact, so the error is 0 everywhere.
class PlaneSdf final : public SignedDistance {
 public:
  void evaluate(std::span<const Vec3> p, std::span<double> v) const override {
    for (std::size_t i = 0; i < p.size(); ++i) v[i] = 0.3 - 0.2 * p[i].x + 0.5 * p[i].y - 0.1 * p[i].z;
  }
  Box bounds() const override { return kUnitCube; }
};

HexMesh as_mesh(const HexComplex& c, std::span<const std::uint32_t> which, int32_t region) {
  HexMesh m;
  m.points = c.points;
  for (std::uint32_t i : which) {
    m.hexes.push_back(c.cells[i]);
    m.region.push_back(region);
  }
  return m;
}

// The complex tiles its box conformingly, every cell Bernstein-certified, every point distinct.
void expect_conforming(const AdaptiveGrid& g, const std::string& where) {
  const HexComplex& c = g.complex;
  ASSERT_EQ(c.cells.size(), g.cell_type.size());
  ASSERT_EQ(c.cells.size(), c.cell_size.size());
  // Split by cell centre (any split works: the checker sees two meshes that must meet face for
  // face and fill the box).
  const double mid = 0.5 * (c.box.lo.x + c.box.hi.x) + 0.123 * (c.box.hi.x - c.box.lo.x);
  std::vector<std::uint32_t> a, b;
  for (std::uint32_t i = 0; i < c.cells.size(); ++i) {
    double x = 0;
    for (std::uint32_t p : c.cells[i]) x += c.points[p].x / 8;
    (x < mid ? a : b).push_back(i);
  }
  const HexMesh ma = as_mesh(c, a, kInside), mb = as_mesh(c, b, kOutside);
  const MeshCheck check = check_mesh(ma, &mb, &c.box);
  EXPECT_TRUE(check.ok) << where << ": " << (check.errors.empty() ? "" : check.errors.front());
  EXPECT_EQ(check.inside.quality.certified, check.inside.quality.count) << where;
  ASSERT_TRUE(check.outside.has_value());
  EXPECT_EQ(check.outside->quality.certified, check.outside->quality.count) << where;
  EXPECT_EQ(check.combined->gap_faces, 0u) << where;
  // Points are unique by coordinates.
  std::vector<Vec3> pts = c.points;
  std::sort(pts.begin(), pts.end(), [](Vec3 p, Vec3 q) { return std::tie(p.x, p.y, p.z) < std::tie(q.x, q.y, q.z); });
  EXPECT_EQ(std::adjacent_find(pts.begin(), pts.end()), pts.end()) << where << ": two point ids at one position";
  // Every point is used.
  std::vector<bool> used(c.points.size());
  for (const auto& cell : c.cells)
    for (std::uint32_t p : cell) used[p] = true;
  EXPECT_EQ(std::count(used.begin(), used.end(), false), 0) << where;
}

TEST(octree, SingleRefinedCellGivesNodeEdgeAndFaceTemplates) {
  Octree t(kUnitCube, 2);
  t.refine(0, octree_key(0, 0, 0));
  t.refine(1, octree_key(1, 1, 1));  // the centre child: its 26 neighbours need templates
  EXPECT_EQ(balance_octree(t), 0u);   // already balanced
  EXPECT_TRUE(octree_balanced(t));
  const AdaptiveGrid g = build_adaptive_complex(t);
  // 6 face, 12 edge and 8 node neighbours around the refined centre (a face of the centre, an
  // edge, a corner), and 27 cubes inside it.
  EXPECT_EQ(g.leaves_per_template[static_cast<int>(TemplateKind::kFace)], 6u);
  EXPECT_EQ(g.leaves_per_template[static_cast<int>(TemplateKind::kEdge)], 12u);
  EXPECT_EQ(g.leaves_per_template[static_cast<int>(TemplateKind::kNode)], 8u);
  EXPECT_EQ(g.leaves_per_template[static_cast<int>(TemplateKind::kCube)], 27u);
  EXPECT_EQ(g.complex.cells.size(), 6u * 22 + 12u * 11 + 8u * 4 + 27u);
  expect_conforming(g, "centre");
}

TEST(octree, OppositeRefinedNeighboursForceRefinement) {
  // A leaf between two refined cells (marks on two opposite faces) has no template.
  Octree t(kUnitCube, 2);
  t.refine(0, 0);
  t.refine(1, octree_key(0, 1, 1));
  t.refine(1, octree_key(2, 1, 1));
  EXPECT_FALSE(octree_balanced(t));
  EXPECT_GE(balance_octree(t), 1u);
  EXPECT_TRUE(t.is_refined(1, octree_key(1, 1, 1)));
  EXPECT_TRUE(octree_balanced(t));
  expect_conforming(build_adaptive_complex(t), "opposite");
}

TEST(octree, TwoLevelJumpsAreBalancedAway) {
  // A refined cell of level 2 in a corner: the level-1 leaves touching it must refine (rule a).
  Octree t(kUnitCube, 3);
  t.refine(0, 0);
  t.refine(1, octree_key(1, 1, 1));
  t.refine(2, octree_key(3, 3, 3));  // corner child of the centre cell, touching 7 level-1 leaves
  std::string why;
  EXPECT_FALSE(octree_balanced(t, &why));
  EXPECT_NE(why.find("holds a mark"), std::string::npos) << why;
  balance_octree(t);
  EXPECT_TRUE(octree_balanced(t, &why)) << why;
  EXPECT_TRUE(t.is_refined(1, octree_key(0, 0, 0)));
  expect_conforming(build_adaptive_complex(t), "corner jump");
}

TEST(octree, RandomTreesBalanceToAFixedPointAndConform) {
  std::mt19937_64 rng(7);
  for (int trial = 0; trial < 12; ++trial) {
    const int depth = 2 + trial % 3;
    Octree t(kUnitCube, depth);
    t.refine(0, 0);
    // Random refinements, level by level (a cell is refined only if it exists).
    for (int level = 1; level < depth; ++level) {
      std::vector<std::uint64_t> cells;
      for (std::uint64_t p : t.refined_cells(level - 1)) {
        const auto [i, j, k] = octree_unkey(p);
        for (int c = 0; c < 27; ++c) cells.push_back(octree_key(3 * i + c % 3, 3 * j + c / 3 % 3, 3 * k + c / 9));
      }
      std::shuffle(cells.begin(), cells.end(), rng);
      const std::size_t n = std::min<std::size_t>(cells.size(), 1 + rng() % 4);
      for (std::size_t c = 0; c < n; ++c) t.refine(level, cells[c]);
    }
    balance_octree(t);
    std::string why;
    ASSERT_TRUE(octree_balanced(t, &why)) << why;
    EXPECT_EQ(balance_octree(t), 0u) << "a balanced tree is a fixed point";
    expect_conforming(build_adaptive_complex(t), "trial " + std::to_string(trial));
  }
}

TEST(octree, PlanarFieldIsNotRefined) {
  PlaneSdf plane;
  const Octree t = refine_octree(plane, kUnitCube, {0.05, 4});
  EXPECT_EQ(t.leaf_count(), 1u);
}

TEST(octree, OneSdfBatchPerLevelAndEveryPointOnce) {
  const ShapeSdf sphere(ShapeKind::kSphere);
  RecordingSdf rec(sphere);
  OctreeStats stats;
  const Box cube = padded_cube(sphere.bounds(), 0.1);
  const Octree t = refine_octree(rec, cube, {0.05, 4}, &stats);
  std::size_t levels_with_candidates = 0;
  for (int l = 0; l < 4; ++l) levels_with_candidates += stats.levels[l].candidates > 0;
  EXPECT_EQ(rec.batches.size(), levels_with_candidates);
  std::vector<Vec3> pts = rec.all;
  std::sort(pts.begin(), pts.end(), [](Vec3 p, Vec3 q) { return std::tie(p.x, p.y, p.z) < std::tie(q.x, q.y, q.z); });
  EXPECT_EQ(std::adjacent_find(pts.begin(), pts.end()), pts.end()) << "a point evaluated twice";
  // The refined cells are exactly those whose error exceeds threshold * h (recomputed here from
  // the shape directly).
  const double edge = cube.hi.x - cube.lo.x;
  for (int level = 0; level < 4; ++level) {
    const double h = edge / std::pow(3.0, level);
    std::vector<std::uint64_t> cells = level == 0 ? std::vector<std::uint64_t>{0} : std::vector<std::uint64_t>{};
    for (std::uint64_t p : level ? t.refined_cells(level - 1) : std::vector<std::uint64_t>{}) {
      const auto [i, j, k] = octree_unkey(p);
      for (int c = 0; c < 27; ++c) cells.push_back(octree_key(3 * i + c % 3, 3 * j + c / 3 % 3, 3 * k + c / 9));
    }
    for (std::uint64_t cell : cells) {
      const auto [i, j, k] = octree_unkey(cell);
      std::array<Vec3, 64> p;
      for (int q = 0; q < 64; ++q)
        p[q] = cube.lo + Vec3{(i + (q % 4) / 3.0) * h, (j + (q / 4 % 4) / 3.0) * h, (k + (q / 16) / 3.0) * h};
      std::array<double, 64> v;
      sphere.evaluate(p, v);
      const double e = refinement_error(v, h);
      // Skip the rare cell within rounding of the threshold (positions here are computed
      // differently from the octree's integer-keyed ones).
      if (std::abs(e - 0.05 * h) < 1e-9 * h) continue;
      EXPECT_EQ(t.is_refined(level, cell), e > 0.05 * h) << "level " << level;
    }
  }
}

TEST(octree, TinyThresholdGivesTheUniformGrid) {
  // The sphere's SDF is curved everywhere, so a tiny threshold refines every cell to max_depth:
  // the complex is then the uniform grid, point for point (same integer-derived coordinates).
  const ShapeSdf sphere(ShapeKind::kSphere);
  const Box cube = padded_cube(sphere.bounds(), 0.1);
  Octree t = refine_octree(sphere, cube, {1e-12, 2});
  EXPECT_EQ(balance_octree(t), 0u);
  const AdaptiveGrid g = build_adaptive_complex(t);
  const UniformGrid u(cube, 2);
  ASSERT_EQ(g.complex.cells.size(), u.cell_count());
  std::vector<Vec3> a = g.complex.points, b = u.vertices();
  auto less = [](Vec3 p, Vec3 q) { return std::tie(p.x, p.y, p.z) < std::tie(q.x, q.y, q.z); };
  std::sort(a.begin(), a.end(), less);
  std::sort(b.begin(), b.end(), less);
  EXPECT_EQ(a, b);
}

AdaptiveGrid sphere_complex(int max_depth, double threshold, OctreeStats* stats = nullptr) {
  const ShapeSdf sphere(ShapeKind::kSphere);
  Octree t = refine_octree(sphere, padded_cube(sphere.bounds(), 0.1), {threshold, max_depth}, stats);
  balance_octree(t, stats);
  return build_adaptive_complex(t);
}

TEST(octree, SameComplexOnOneAndTwoThreads) {
  AdaptiveGrid one, two;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = sphere_complex(4, 0.05);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    two = sphere_complex(4, 0.05);
  }
  ASSERT_EQ(one.complex.points.size(), two.complex.points.size());
  ASSERT_EQ(one.complex.cells.size(), two.complex.cells.size());
  EXPECT_EQ(std::memcmp(one.complex.points.data(), two.complex.points.data(), one.complex.points.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(one.complex.cells, two.complex.cells);
  EXPECT_EQ(one.cell_type, two.cell_type);
}

// The complex meshed by the RO rule (a cell is inside when its corner values sum above 0): a
// local stand-in for the HexComplex meshers, enough to show the adaptive grid meshes and checks.
MeshPair remove_outside(const HexComplex& c, std::span<const double> values) {
  std::vector<Hex> in, out;
  for (const auto& cell : c.cells) {
    double s = 0;
    for (std::uint32_t p : cell) s += values[p];
    (s > 0 ? in : out).push_back(cell);
  }
  return {compact_mesh(c.points, in, kInside), compact_mesh(c.points, out, kOutside)};
}

TEST(octree, SphereAtMaxDepth5Threshold005) {
  OctreeStats stats;
  const AdaptiveGrid g = sphere_complex(5, 0.05, &stats);
  EXPECT_EQ(g.levels, 6) << "the sphere's centre (the SDF's kink) refines to max depth";
  expect_conforming(g, "sphere");
  std::size_t uniform = 1;
  for (int i = 0; i < 5; ++i) uniform *= 27;
  std::printf("sphere depth 5 threshold 0.05: %zu cells (uniform depth 5: %zu), leaves cube/node/edge/face %zu/%zu/%zu/%zu, balance rounds %d\n",
              g.complex.cells.size(), uniform, g.leaves_per_template[0], g.leaves_per_template[1],
              g.leaves_per_template[2], g.leaves_per_template[3], stats.balance_rounds);
  EXPECT_LT(g.complex.cells.size(), uniform / 5);
  const ShapeSdf sphere(ShapeKind::kSphere);
  std::vector<double> values(g.complex.points.size());
  sphere.evaluate(g.complex.points, values);
  const MeshPair m = remove_outside(g.complex, values);
  const MeshCheck check = check_mesh(m.inside, &m.outside, &g.complex.box);
  EXPECT_TRUE(check.ok) << (check.errors.empty() ? "" : check.errors.front());
  EXPECT_GT(m.inside.hexes.size(), 0u);
  EXPECT_EQ(check.inside.quality.certified, check.inside.quality.count);
}

}  // namespace
}  // namespace mchex
