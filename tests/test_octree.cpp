// Adaptive 3-refinement (core/grid/octree.h): refinement by the paper's error with one SDF batch per
// level, balancing to a fixed point, and the conforming complex of templates. Conformity is
// checked by the project's independent checker (core/check/mesh_check.h): the complex is split into two
// meshes that must tile the box face for face with no gap (a hanging node leaves a face in one
// hex inside the box), every face in at most two hexes, volumes adding up to the box.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <mutex>
#include <random>
#include <set>

#include "core/base/parallel.h"
#include "core/check/mesh_check.h"
#include "core/cutting/mc33.h"
#include "core/cutting/ro.h"
#include "core/grid/cell_types.h"
#include "core/grid/grid.h"
#include "core/grid/hex_complex.h"
#include "core/grid/octree.h"
#include "core/grid/refinement_error.h"
#include "core/sdf/shapes.h"

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

int template_named(std::string_view name) {
  for (int t = 0; t < kNumTemplates; ++t)
    if (template_name(t) == name) return t;
  return -1;
}

TEST(octree, SingleRefinedCellGivesSingleEdgeAndFaceTemplates) {
  Octree t(kUnitCube, 2);
  t.refine(0, octree_key(0, 0, 0));
  t.refine(1, octree_key(1, 1, 1));  // the centre child: its 26 neighbours need templates
  EXPECT_EQ(balance_octree(t), 0u);  // already balanced
  EXPECT_TRUE(octree_balanced(t));
  const AdaptiveGrid g = build_adaptive_complex(t);
  // Around the refined centre: 6 face neighbours (4 marks, the face template), 12 edge neighbours
  // (2 marks, the edge template), 8 corner neighbours (1 mark splits no edge: the leaf stays
  // whole), and the centre's 27 children.
  EXPECT_EQ(g.leaves_per_template[template_named("face")], 6u);
  EXPECT_EQ(g.leaves_per_template[template_named("edge")], 12u);
  EXPECT_EQ(g.leaves_per_template[template_named("single")], 8u + 27u);
  EXPECT_EQ(g.complex.cells.size(), 6u * 13 + 12u * 5 + 8u + 27u);
  expect_conforming(g, "centre");
}

// The fitted grid's measured rounds refine the leaves that hold far samples (core/pipeline/fit.h).
TEST(octree, RefineLeavesAtPointsRefinesTheLeafThatHoldsEachPointOnce) {
  Octree t(kUnitCube, 3);
  t.refine(0, octree_key(0, 0, 0));
  // A point in level-1 leaf (2, 0, 0), twice and in two orders; one on the face x = 1/3 between
  // leaves (0,1,1) and (1,1,1) (floor: the one above it); one outside the cube.
  const std::vector<Vec3> points = {{0.9, 0.1, 0.1}, {1.0 / 3, 0.5, 0.5}, {0.9, 0.1, 0.1}, {2, 0.5, 0.5}};
  Octree u = t;
  EXPECT_EQ(refine_leaves_at_points(t, points), 2u);  // balanced already: no more
  EXPECT_TRUE(t.is_refined(1, octree_key(2, 0, 0)));
  EXPECT_TRUE(t.is_refined(1, octree_key(1, 1, 1)));
  EXPECT_FALSE(t.is_refined(1, octree_key(0, 1, 1)));
  EXPECT_EQ(t.leaf_count(), 1u + 26u + 2u * 26u);
  const std::vector<Vec3> reversed(points.rbegin(), points.rend());
  EXPECT_EQ(refine_leaves_at_points(u, reversed), 2u);
  EXPECT_EQ(u.refined_cells(1), t.refined_cells(1));
  // min_points: only a leaf with two of the points.
  Octree v(kUnitCube, 3);
  v.refine(0, octree_key(0, 0, 0));
  EXPECT_EQ(refine_leaves_at_points(v, points, 2), 1u);
  EXPECT_TRUE(v.is_refined(1, octree_key(2, 0, 0)));
  // Leaves at max_depth stay; the leaf of a point deeper in refines in turn and balancing follows.
  Octree w(kUnitCube, 1);
  w.refine(0, octree_key(0, 0, 0));
  EXPECT_EQ(refine_leaves_at_points(w, points), 0u);
  EXPECT_EQ(refine_leaves_at_points(t, std::vector<Vec3>{{0.9, 0.1, 0.1}}), 1u);
  EXPECT_TRUE(t.is_refined(2, octree_key(8, 0, 0)));
  EXPECT_TRUE(octree_balanced(t));
  expect_conforming(build_adaptive_complex(t), "points");
}

// The error tests stop above error_depth: the levels below it are left to the other tests.
TEST(octree, ErrorDepthStopsTheErrorTestAboveIt) {
  const ShapeSdf sphere(ShapeKind::kSphere);
  const Box cube = padded_cube(sphere.bounds(), 0.1);
  const Octree deep = refine_octree(sphere, cube, {0.05, 4});
  AdaptiveOptions o{0.05, 6};
  o.error_depth = 4;
  const Octree capped = refine_octree(sphere, cube, o);
  EXPECT_EQ(capped.max_depth(), 6);
  EXPECT_TRUE(capped.refined_cells(4).empty());
  EXPECT_TRUE(capped.refined_cells(5).empty());
  // Same tolerance in finest-of-error-depth units: the same refined cells above it.
  for (int level = 0; level < 4; ++level) EXPECT_EQ(capped.refined_cells(level), deep.refined_cells(level)) << level;
}

// The surface-sample test refines a cell whose interpolant misses an input point: a sharp tip.
TEST(octree, SurfaceSamplesRefineWhereTheInterpolantMissesTheSurface) {
  const ShapeSdf sphere(ShapeKind::kSphere);
  const Box cube = padded_cube(sphere.bounds(), 0.1);
  AdaptiveOptions base{1e9, 3};  // the distance test off: nothing refines but the root's need
  const Octree none = refine_octree(sphere, cube, base);
  AdaptiveOptions o = base;
  o.surface_tolerance = 1e-6;  // any interpolant misses a sphere point by more than this
  const std::vector<Vec3> samples = {{1, 0, 0}};
  o.surface_samples = samples;
  const Octree some = refine_octree(sphere, cube, o);
  EXPECT_GT(some.leaf_count(), none.leaf_count());
  // The sample's leaf reaches max depth: every level's cell that holds it was refined.
  for (int level = 0; level < 3; ++level) {
    const double n = std::pow(3.0, level), e = cube.hi.x - cube.lo.x;
    auto idx = [&](double x, double lo) { return std::uint64_t(std::floor((x - lo) / e * n)); };
    EXPECT_TRUE(some.is_refined(level, octree_key(idx(1, cube.lo.x), idx(0, cube.lo.y), idx(0, cube.lo.z)))) << level;
  }
  o.surface_tolerance = 1e9;  // nothing is that far
  EXPECT_EQ(refine_octree(sphere, cube, o).leaf_count(), none.leaf_count());
}

TEST(octree, ALeafBetweenOppositeRefinedNeighboursIsSplitUniformlyNotRefined) {
  // All 8 corners marked: the uniform template (its 27 children), with no refinement of the tree.
  Octree t(kUnitCube, 2);
  t.refine(0, 0);
  t.refine(1, octree_key(0, 1, 1));
  t.refine(1, octree_key(2, 1, 1));
  EXPECT_TRUE(octree_balanced(t));
  EXPECT_EQ(balance_octree(t), 0u);
  EXPECT_FALSE(t.is_refined(1, octree_key(1, 1, 1)));
  const AdaptiveGrid g = build_adaptive_complex(t);
  EXPECT_EQ(g.leaves_per_template[template_named("uniform")], 1u);
  expect_conforming(g, "opposite");
}

TEST(octree, ConcaveEdgesAndCornersNeedNoRefinement) {
  // Every level-1 cell refined but a column along the z axis: the column's leaves have a concave
  // edge (6 marks). Every one refined but one corner cell: a concave corner (7 marks). The standard
  // templates had neither and refined the leaf; these keep it.
  for (bool corner : {false, true}) {
    Octree t(kUnitCube, 2);
    t.refine(0, 0);
    for (std::uint32_t c = 0; c < 27; ++c) {
      const std::uint32_t i = c % 3, j = c / 3 % 3, k = c / 9;
      const bool keep = i == 0 && j == 0 && (!corner || k == 0);
      if (!keep) t.refine(1, octree_key(i, j, k));
    }
    EXPECT_TRUE(octree_balanced(t));
    EXPECT_EQ(balance_octree(t), 0u);
    const AdaptiveGrid g = build_adaptive_complex(t);
    if (corner) {
      EXPECT_EQ(g.leaves_per_template[template_named("concave-corner")], 1u);
    } else {
      // The middle of the column has 6 marks; its ends, on the cube's boundary, too (the
      // boundary corners touch no finer leaf).
      EXPECT_EQ(g.leaves_per_template[template_named("concave-edge")], 3u);
    }
    expect_conforming(g, corner ? "concave corner" : "concave edge");
  }
}

TEST(octree, EveryMarkingOfALeafBuildsAConformingComplex) {
  // The centre leaf (1, 1, 1) of level 1 gets any of the 256 markings: refining the level-1 cell
  // diagonally across its corner c (touching it at that vertex only, which moderate balance allows)
  // marks exactly corner c. Every template in the rotation the marking selects, in the real
  // complex builder, next to its neighbours' templates: conforming, certified, and as many cells
  // as the leaves' templates have hexes.
  for (int m = 0; m < 256; ++m) {
    Octree t(kUnitCube, 2);
    t.refine(0, 0);
    for (int c = 0; c < 8; ++c)
      if (m >> c & 1) t.refine(1, octree_key(2 * kCubeCorners[c][0], 2 * kCubeCorners[c][1], 2 * kCubeCorners[c][2]));
    ASSERT_TRUE(octree_balanced(t));
    ASSERT_EQ(t.marks(1, octree_key(1, 1, 1)), m);
    const AdaptiveGrid g = build_adaptive_complex(t);
    std::size_t hexes = 0;
    for (int k = 0; k < kNumTemplates; ++k) hexes += g.leaves_per_template[k] * template_hexes(k).size();
    EXPECT_EQ(g.complex.cells.size(), hexes) << "marking " << m;
    expect_conforming(g, "marking " + std::to_string(m));
    if (HasFailure()) return;
  }
}

TEST(octree, TwoLevelJumpsAcrossFacesAndEdgesAreBalancedAwayNotAcrossVertices) {
  // A refined cell of level 2 in the low corner of the centre cell: the level-1 leaves sharing a
  // face or an edge with it must refine (moderate balance); the one touching it at a vertex need not.
  Octree t(kUnitCube, 3);
  t.refine(0, 0);
  t.refine(1, octree_key(1, 1, 1));
  t.refine(2, octree_key(3, 3, 3));
  std::string why;
  EXPECT_FALSE(octree_balanced(t, &why));
  EXPECT_NE(why.find("shares a face or an edge"), std::string::npos) << why;
  balance_octree(t);
  EXPECT_TRUE(octree_balanced(t, &why)) << why;
  EXPECT_TRUE(t.is_refined(1, octree_key(0, 1, 1)));   // face
  EXPECT_TRUE(t.is_refined(1, octree_key(0, 0, 1)));   // edge
  EXPECT_FALSE(t.is_refined(1, octree_key(0, 0, 0)));  // vertex only
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

// The 64 child-lattice values of a cell, computed here independently of the octree's keys.
std::array<double, 64> lattice_values(const SignedDistance& sdf, const Box& cube, int level, std::uint64_t cell) {
  const double h = (cube.hi.x - cube.lo.x) / std::pow(3.0, level);
  const auto [i, j, k] = octree_unkey(cell);
  std::array<Vec3, 64> p;
  for (int q = 0; q < 64; ++q)
    p[q] = cube.lo + Vec3{(i + (q % 4) / 3.0) * h, (j + (q / 4 % 4) / 3.0) * h, (k + (q / 16) / 3.0) * h};
  std::array<double, 64> v;
  sdf.evaluate(p, v);
  return v;
}

std::vector<std::uint64_t> children_of_refined(const Octree& t, int level) {
  if (level == 0) return {0};
  std::vector<std::uint64_t> cells;
  for (std::uint64_t p : t.refined_cells(level - 1)) {
    const auto [i, j, k] = octree_unkey(p);
    for (int c = 0; c < 27; ++c) cells.push_back(octree_key(3 * i + c % 3, 3 * j + c / 3 % 3, 3 * k + c / 9));
  }
  return cells;
}

TEST(octree, OneSdfBatchPerLevelAndEveryPointOnce) {
  const ShapeSdf sphere(ShapeKind::kSphere);
  RecordingSdf rec(sphere);
  OctreeStats stats;
  const Box cube = padded_cube(sphere.bounds(), 0.1);
  const AdaptiveOptions options{0.05, 4};
  const Octree t = refine_octree(rec, cube, options, &stats);
  std::size_t levels_sampled = 0;
  for (int l = 0; l < 4; ++l) levels_sampled += stats.levels[l].sampled > 0;
  EXPECT_EQ(rec.batches.size(), levels_sampled);
  EXPECT_GE(levels_sampled, 3u);
  std::vector<Vec3> pts = rec.all;
  std::sort(pts.begin(), pts.end(), [](Vec3 p, Vec3 q) { return std::tie(p.x, p.y, p.z) < std::tie(q.x, q.y, q.z); });
  EXPECT_EQ(std::adjacent_find(pts.begin(), pts.end()), pts.end()) << "a point evaluated twice";
  // The refined cells are exactly those that may hold the surface and whose error exceeds
  // T * finest cell size (recomputed here from the shape directly).
  const double edge = cube.hi.x - cube.lo.x;
  const double tolerance = 0.05 * edge / 81;
  EXPECT_EQ(adaptive_tolerance(cube, options), tolerance);
  std::size_t refined = 0, clear = 0, smooth = 0;
  for (int level = 0; level < 4; ++level) {
    const double h = edge / std::pow(3.0, level);
    for (std::uint64_t cell : children_of_refined(t, level)) {
      const auto v = lattice_values(sphere, cube, level, cell);
      const double e = refinement_error(v, h);
      // Skip the rare cell within rounding of the threshold (positions here are computed
      // differently from the octree's integer-keyed ones).
      if (std::abs(e - tolerance) < 1e-9 * h) continue;
      const bool may_hold = cell_may_hold_surface(v, h);
      EXPECT_EQ(t.is_refined(level, cell), may_hold && e > tolerance) << "level " << level;
      refined += t.is_refined(level, cell);
      clear += !may_hold && e > tolerance;  // the error alone would have refined these
      smooth += may_hold && e <= tolerance;
    }
  }
  std::printf(
      "refined %zu; not refined: %zu surface-free with error over the tolerance, %zu holding the surface with error under it\n",
      refined, clear, smooth);
  EXPECT_GT(refined, 0u);
  EXPECT_GT(clear, 0u) << "the sphere's centre (the SDF's kink) has a large error and no surface";
}

// The criterion's safety: whenever the sphere's surface meets a cube (decided exactly from the
// distances of the cube's nearest and farthest points to the centre), cell_may_hold_surface says
// so. Cubes of every size relative to the sphere, placed at random near its surface.
TEST(octree, SurfaceTestNeverMissesTheSurface) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  std::size_t meets = 0, clear = 0;
  for (int trial = 0; trial < 40000; ++trial) {
    const double r = 0.05 + 2 * u(rng), h = std::pow(10.0, -2 + 3 * u(rng));
    const Vec3 c{0, 0, 0};
    // Near the surface: the cube's centre within a few sizes of the sphere.
    const double dist = r + (u(rng) - 0.5) * 4 * h;
    const Vec3 dir = normalized(Vec3{u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5});
    const Vec3 lo = c + dist * dir - Vec3{h / 2, h / 2, h / 2} + Vec3{u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5} * h;
    std::array<double, 64> v;
    for (int q = 0; q < 64; ++q) {
      const Vec3 p = lo + Vec3{(q % 4) * h / 3, (q / 4 % 4) * h / 3, (q / 16) * h / 3};
      v[q] = r - norm(p - c);
    }
    double near2 = 0, far2 = 0;
    for (int d = 0; d < 3; ++d) {
      const double a = lo[d] - c[d], b = a + h;
      const double n = a > 0 ? a : (b < 0 ? b : 0);
      near2 += n * n;
      far2 += std::max(a * a, b * b);
    }
    const bool surface_meets = std::sqrt(near2) <= r && r <= std::sqrt(far2);
    const bool may_hold = cell_may_hold_surface(v, h);
    if (surface_meets) {
      ++meets;
      EXPECT_TRUE(may_hold) << "trial " << trial;
    }
    clear += !may_hold;
  }
  EXPECT_GT(meets, 1000u);
  EXPECT_GT(clear, 1000u) << "the test rules out cubes the surface misses";
}

TEST(octree, SurfaceTestBounds) {
  // The plane f = c - x at the cube [0, 1]^3 (the surface misses it exactly when c > 1 or c < 0).
  // The whole cube's corners clear it from c > 1 + sqrt(3) / 2 on; the sub-cubes earlier: the last
  // one's corners x = 2/3 have |f| = c - 2/3, which covers that sub-cube (edge 1/3) once it
  // exceeds its diagonal sqrt(3) / 3. So it switches at c = 2/3 + sqrt(3) / 3 (and, mirrored, at
  // c = 1/3 - sqrt(3) / 3): conservative by 0.244 of the cube, never wrong.
  auto values = [](double c) {
    std::array<double, 64> v;
    for (int q = 0; q < 64; ++q) v[q] = c - (q % 4) / 3.0;
    return v;
  };
  const double above = 2.0 / 3 + std::sqrt(3.0) / 3, below = 1.0 / 3 - std::sqrt(3.0) / 3;
  EXPECT_TRUE(cell_may_hold_surface(values(0.5), 1));
  EXPECT_TRUE(cell_may_hold_surface(values(1.0), 1));
  EXPECT_TRUE(cell_may_hold_surface(values(0.0), 1));
  EXPECT_TRUE(cell_may_hold_surface(values(above - 1e-9), 1));
  EXPECT_FALSE(cell_may_hold_surface(values(above + 1e-9), 1));
  EXPECT_TRUE(cell_may_hold_surface(values(below + 1e-9), 1));
  EXPECT_FALSE(cell_may_hold_surface(values(below - 1e-9), 1));
  // Scale: the same at a cube of edge 1e-3 with f scaled alike.
  auto scaled = values(above - 1e-9);
  for (double& x : scaled) x *= 1e-3;
  EXPECT_TRUE(cell_may_hold_surface(scaled, 1e-3));
  // Values of both signs (an open surface's SDF can flip away from the surface) or a zero among
  // the tested corners keep the cell. At c = 1.5 every sub-cube clears, the whole cube does not.
  ASSERT_FALSE(cell_may_hold_surface(values(1.5), 1));
  auto flipped = values(1.5);
  flipped[child_lattice_index(1, 1, 1)] = -1.5;
  EXPECT_TRUE(cell_may_hold_surface(flipped, 1));
  auto zero = values(1.5);
  zero[child_lattice_index(2, 1, 3)] = 0;
  EXPECT_TRUE(cell_may_hold_surface(zero, 1));
  // Far from the surface the cell's own corners clear it, whatever lies between them.
  auto far = values(5);
  far[child_lattice_index(1, 2, 1)] = -5;
  EXPECT_FALSE(cell_may_hold_surface(far, 1));
}

TEST(octree, RefinementFollowsTheSurfaceNotTheMedialAxis) {
  // The paper's error is large at the sphere's centre (|grad f| jumps there) and the torus's core
  // circle; before balancing, every refined cell must meet the surface (decided exactly).
  for (ShapeKind kind : {ShapeKind::kSphere, ShapeKind::kTorus}) {
    const ShapeSdf shape(kind);
    const Box cube = padded_cube(shape.bounds(), 0.1);
    const Octree t = refine_octree(shape, cube, {0.05, 5});
    const double edge = cube.hi.x - cube.lo.x;
    std::size_t refined = 0;
    for (int level = 0; level < 5; ++level) {
      const double h = edge / std::pow(3.0, level);
      for (std::uint64_t cell : t.refined_cells(level)) {
        const auto [i, j, k] = octree_unkey(cell);
        // Samples of the closed cube at spacing h / 9, the child lattice among them: a refined
        // cell has a sign change on its lattice or a lattice point within sqrt(3) / 6 h (half a
        // sub-cube's diagonal) of the surface, so the surface passes within that of the cell.
        double lo_abs = 1e300;
        bool pos = false, neg = false;
        std::vector<Vec3> p;
        for (int a = 0; a <= 9; ++a)
          for (int b = 0; b <= 9; ++b)
            for (int c = 0; c <= 9; ++c)
              p.push_back(cube.lo + Vec3{(i + a / 9.0) * h, (j + b / 9.0) * h, (k + c / 9.0) * h});
        std::vector<double> f(p.size());
        shape.evaluate(p, f);
        for (double x : f) {
          lo_abs = std::min(lo_abs, std::abs(x));
          pos |= x > 0;
          neg |= x <= 0;
        }
        EXPECT_TRUE((pos && neg) || lo_abs <= h * std::sqrt(3.0) / 6 * (1 + 1e-9))
            << shape_name(kind) << " level " << level << " cell (" << i << ", " << j << ", " << k << ")";
        ++refined;
      }
    }
    EXPECT_GT(refined, 100u);
    // The surface band ends one level above max_depth here (T = 0.05 of a finest cell is met
    // there): nothing reaches the deepest level, the kink included.
    EXPECT_TRUE(t.refined_cells(4).empty()) << shape_name(kind);
  }
}

TEST(octree, TinyThresholdGivesTheUniformGrid) {
  // With a tiny threshold every cell that holds the sphere's surface refines to max_depth; at
  // depth 2 that is all of level 1 but the centre, whose 8 marked corners give it the uniform
  // template (its 27 children; no refinement needed): the complex is the uniform grid, point for
  // point (the template's inner points, computed from 1/14400 units, get the same coordinates as the
  // integer-keyed ones).
  const ShapeSdf sphere(ShapeKind::kSphere);
  const Box cube = padded_cube(sphere.bounds(), 0.1);
  Octree t = refine_octree(sphere, cube, {1e-12, 2});
  EXPECT_EQ(t.refined_cells(1).size(), 26u);
  EXPECT_EQ(balance_octree(t), 0u);
  const AdaptiveGrid g = build_adaptive_complex(t);
  EXPECT_EQ(g.leaves_per_template[kUniformTemplate], 1u);
  const UniformGrid u(cube, 2);
  ASSERT_EQ(g.complex.cells.size(), u.cell_count());
  std::vector<Vec3> a = g.complex.points, b = u.vertices();
  auto less = [](Vec3 p, Vec3 q) { return std::tie(p.x, p.y, p.z) < std::tie(q.x, q.y, q.z); };
  std::sort(a.begin(), a.end(), less);
  std::sort(b.begin(), b.end(), less);
  EXPECT_EQ(a, b);
}

TEST(octree, SortedDistinctMatchesSortAndUnique) {
  // Both of its paths: key and position packed in one word (few key bits) and separate pairs.
  std::mt19937_64 rng(3);
  for (int bits : {1, 7, 20, 33, 40, 58, 64})
    for (std::size_t n : {0u, 1u, 5u, 1000u, 200000u}) {
      std::vector<std::uint64_t> keys(n);
      const std::uint64_t range = bits == 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << bits) - 1;
      // Few distinct values, so that there are many repeats.
      std::vector<std::uint64_t> pool(1 + n / 7);
      for (auto& p : pool) p = rng() & range;
      for (auto& k : keys) k = pool[rng() % pool.size()];
      std::vector<std::uint32_t> index(n);
      const std::vector<std::uint64_t> got = sorted_distinct(keys, bits, index);
      std::vector<std::uint64_t> want = keys;
      std::sort(want.begin(), want.end());
      want.erase(std::unique(want.begin(), want.end()), want.end());
      ASSERT_EQ(got, want) << bits << " bits, " << n << " keys";
      for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(got[index[i]], keys[i]);
    }
  std::vector<std::uint32_t> index(1);
  EXPECT_THROW(sorted_distinct({1u << 10}, 10, index), std::logic_error);
}

// The complex's values are the refinement's samples where it took them and one more batch
// elsewhere, equal bit for bit to evaluating the SDF at every point afresh (same integer key, same
// coordinates, same value).
TEST(octree, ComplexReusesTheRefinementSamples) {
  const ShapeSdf sphere(ShapeKind::kSphere);
  const TriangleSurface mesh = tessellate(ShapeKind::kTorus, 48);
  const SurfaceSdf torus(mesh);
  for (const SignedDistance* sdf :
       {static_cast<const SignedDistance*>(&sphere), static_cast<const SignedDistance*>(&torus)}) {
    const Box cube = padded_cube(sdf->bounds(), 0.1);
    RecordingSdf rec(*sdf);
    OctreeStats stats;
    Octree t = refine_octree(rec, cube, {0.05, 4}, &stats);
    balance_octree(t);
    AdaptiveGrid g = build_adaptive_complex(t);
    const std::size_t evaluated_in_refinement = rec.all.size();
    ASSERT_EQ(g.values.size(), g.complex.points.size());
    EXPECT_TRUE(std::is_sorted(g.unsampled.begin(), g.unsampled.end()));
    for (std::size_t p = 0; p < g.values.size(); ++p)
      EXPECT_EQ(std::isnan(g.values[p]), std::binary_search(g.unsampled.begin(), g.unsampled.end(), p));
    const std::size_t reused = g.complex.points.size() - g.unsampled.size();
    EXPECT_GT(reused, g.complex.points.size() / 10);
    EXPECT_LE(reused, evaluated_in_refinement);
    evaluate_unsampled(g, rec);
    EXPECT_EQ(rec.batches.size(), std::size_t(std::count_if(stats.levels.begin(), stats.levels.end(),
                                                            [](const OctreeLevelStats& l) { return l.sampled > 0; })) +
                                      1)
        << "one more batch, for the unsampled points";
    EXPECT_TRUE(g.unsampled.empty());
    std::vector<double> fresh(g.complex.points.size());
    sdf->evaluate(g.complex.points, fresh);
    EXPECT_EQ(std::memcmp(fresh.data(), g.values.data(), fresh.size() * sizeof(double)), 0);
    std::printf("%zu points, %zu reused from the refinement's %zu samples\n", g.complex.points.size(), reused,
                evaluated_in_refinement);
  }
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
    ThreadLimit c(1);
    one = sphere_complex(4, 0.05);
  }
  {
    ThreadLimit c(2);
    two = sphere_complex(4, 0.05);
  }
  ASSERT_EQ(one.complex.points.size(), two.complex.points.size());
  ASSERT_EQ(one.complex.cells.size(), two.complex.cells.size());
  EXPECT_EQ(std::memcmp(one.complex.points.data(), two.complex.points.data(), one.complex.points.size() * sizeof(Vec3)),
            0);
  EXPECT_EQ(one.complex.cells, two.complex.cells);
  EXPECT_EQ(one.cell_type, two.cell_type);
  EXPECT_EQ(one.unsampled, two.unsampled);
  ASSERT_EQ(one.values.size(), two.values.size());
  EXPECT_EQ(std::memcmp(one.values.data(), two.values.data(), one.values.size() * sizeof(double)), 0);
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
  AdaptiveGrid g = sphere_complex(5, 0.05, &stats);
  // The centre (the SDF's kink) is not refined, and the surface stops at level 4, where the error
  // is under 0.05 of a finest cell (2 h^2 / R against 0.05 h, h = 2.4 / 243, R = 1).
  EXPECT_EQ(g.levels, 5);
  expect_conforming(g, "sphere");
  std::printf(
      "sphere depth 5 threshold 0.05: %zu cells (uniform depth 4: 531441), leaves single/edge/face/three-corner %zu/%zu/%zu/%zu, balance rounds %d\n",
      g.complex.cells.size(), g.leaves_per_template[0], g.leaves_per_template[1], g.leaves_per_template[2],
      g.leaves_per_template[3], stats.balance_rounds);
  const ShapeSdf sphere(ShapeKind::kSphere);
  evaluate_unsampled(g, sphere);
  const MeshPair m = remove_outside(g.complex, g.values);
  const MeshCheck check = check_mesh(m.inside, &m.outside, &g.complex.box);
  EXPECT_TRUE(check.ok) << (check.errors.empty() ? "" : check.errors.front());
  EXPECT_GT(m.inside.hexes.size(), 0u);
  EXPECT_EQ(check.inside.quality.certified, check.inside.quality.count);
  // Every cell the surface cuts (corner values of both signs) is at the finest level, so the MCHex
  // surface is the uniform depth-4 grid's.
  std::size_t cut = 0;
  for (std::size_t c = 0; c < g.complex.cells.size(); ++c) {
    bool pos = false, neg = false;
    for (std::uint32_t p : g.complex.cells[c]) (g.values[p] > 0 ? pos : neg) = true;
    if (!(pos && neg)) continue;
    ++cut;
    EXPECT_EQ(g.cell_level[c], 4) << "cell " << c;
  }
  EXPECT_GT(cut, 10000u);
}

}  // namespace
}  // namespace mchex
