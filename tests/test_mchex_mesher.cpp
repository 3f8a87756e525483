// The MCHex mesher on uniform grids (core/cutting/mchex_mesher.h): the analytic sphere, torus and
// two-holed solid at depths 2-4. Asserted: the inside/outside pair passes check_mesh (no
// structural error, gap or overlap; volumes add up to the box: the conformity the global keys
// are for), the inside boundary is a closed 2-manifold with the shape's Euler characteristic,
// the hex count is the sum over cells of local_refinement_hexes (Theorem 4.1: one hex per
// polyhedron vertex), every hex is Bernstein-certified (paper Section 5: plain subdivision where
// it is proven, local refinement where it is not), and the output is deterministic.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <numeric>
#include <random>
#include <span>
#include <string>
#include <tuple>
#include <vector>

#include "core/base/parallel.h"
#include "core/check/fidelity.h"
#include "core/check/mesh_check.h"
#include "core/cutting/mchex_mesher.h"
#include "core/cutting/ro.h"
#include "core/grid/grid.h"
#include "core/grid/hex_complex.h"
#include "core/sdf/shapes.h"

namespace mchex {
namespace {

struct MchexRun {
  UniformGrid grid;
  Box box;
  MeshPair mesh;
  MchexStats stats;
  double seconds = 0;
};

MchexRun mesh_shape(ShapeKind kind, int depth, double eps = 1e-3) {
  const ShapeSdf sdf(kind);
  const Box box = padded_cube(sdf.bounds(), 0.1);
  UniformGrid grid(box, depth);
  const std::vector<Vec3> points = grid.vertices();
  std::vector<double> values(points.size());
  sdf.evaluate(points, values);
  const auto t0 = std::chrono::steady_clock::now();
  MchexStats stats;
  MeshPair mesh = mesh_mchex(grid, values, eps, &stats);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return {grid, box, std::move(mesh), stats, s};
}

struct Param {
  ShapeKind kind;
  int depth;
};

class MchexShapes : public testing::TestWithParam<Param> {};

TEST_P(MchexShapes, ConformingClosedAndCounted) {
  const auto [kind, depth] = GetParam();
  const MchexRun r = mesh_shape(kind, depth);
  const MeshCheck check = check_mesh(r.mesh.inside, &r.mesh.outside, &r.box);
  const std::size_t hexes = r.mesh.inside.hexes.size() + r.mesh.outside.hexes.size();
  const QualityStats& qi = check.inside.quality;
  const QualityStats& qo = check.outside->quality;
  std::printf("[mchex] %-9s depth %d: %zu cells, %zu refined cells, %zu+%zu hexes, %zu points, "
              "certified inside %.2f%% outside %.2f%%, min scaled Jacobian inside %.4f outside %.4f, "
              "mesh %.3f s\n",
              std::string(shape_name(kind)).c_str(), depth, r.grid.cell_count(), r.stats.refined_cells,
              r.mesh.inside.hexes.size(), r.mesh.outside.hexes.size(), r.stats.points,
              qi.count ? 100.0 * qi.certified / qi.count : 100.0, qo.count ? 100.0 * qo.certified / qo.count : 100.0,
              qi.min_scaled_jacobian, qo.min_scaled_jacobian, r.seconds);
  EXPECT_TRUE(check.ok) << (check.errors.empty() ? "" : check.errors.front());
  EXPECT_EQ(qi.certified, qi.count);
  EXPECT_EQ(qo.certified, qo.count);
  EXPECT_EQ(check.combined->gap_faces, 0u);
  EXPECT_EQ(check.combined->overlap_faces, 0u);
  EXPECT_TRUE(check.combined->volume_ok) << check.combined->volume_relative_error;
  EXPECT_TRUE(check.inside.boundary.closed_manifold());
  EXPECT_EQ(check.inside.boundary.euler_characteristic, shape_euler_characteristic(kind));
  EXPECT_EQ(hexes, r.stats.expected_hexes);
  std::size_t cells = 0;
  for (std::size_t c : r.stats.cases) cells += c;
  EXPECT_EQ(cells, r.grid.cell_count());
  // All inside points also appear in the outside mesh where they are on the interface: the
  // checker matched them by exact coordinates above (interface faces > 0).
  EXPECT_GT(check.combined->interface_faces, 0u);
}

// Depth 2 (9^3 cells) resolves the sphere and the torus; at depth 2 the two-holed solid's holes
// are narrower than the grid resolves (measured: its inside boundary is then one sphere, Euler
// characteristic 2, still a valid conforming mesh), so its topology is tested from depth 3.
// Depth 4 is 81^3 cells.
INSTANTIATE_TEST_SUITE_P(Shapes, MchexShapes,
                         testing::Values(Param{ShapeKind::kSphere, 2}, Param{ShapeKind::kSphere, 3},
                                         Param{ShapeKind::kSphere, 4}, Param{ShapeKind::kTorus, 2},
                                         Param{ShapeKind::kTorus, 3}, Param{ShapeKind::kTorus, 4},
                                         Param{ShapeKind::kTwoHoled, 3}, Param{ShapeKind::kTwoHoled, 4}),
                         [](const testing::TestParamInfo<Param>& info) {
                           std::string name(shape_name(info.param.kind));
                           for (char& c : name)
                             if (c == '-') c = '_';
                           return name + "_depth" + std::to_string(info.param.depth);
                         });

TEST(Mchex, Deterministic) {
  const MchexRun a = mesh_shape(ShapeKind::kTorus, 3), b = mesh_shape(ShapeKind::kTorus, 3);
  for (const auto* pair : {&a.mesh, &b.mesh}) ASSERT_FALSE(pair->inside.hexes.empty());
  EXPECT_EQ(a.mesh.inside.hexes, b.mesh.inside.hexes);
  EXPECT_EQ(a.mesh.outside.hexes, b.mesh.outside.hexes);
  ASSERT_EQ(a.mesh.inside.points.size(), b.mesh.inside.points.size());
  ASSERT_EQ(a.mesh.outside.points.size(), b.mesh.outside.points.size());
  for (std::size_t i = 0; i < a.mesh.inside.points.size(); ++i) {
    EXPECT_EQ(a.mesh.inside.points[i].x, b.mesh.inside.points[i].x);
    EXPECT_EQ(a.mesh.inside.points[i].y, b.mesh.inside.points[i].y);
    EXPECT_EQ(a.mesh.inside.points[i].z, b.mesh.inside.points[i].z);
  }
}

TEST(Mchex, UncutGridGivesTheOctantsOfEveryCell) {
  // All values negative: every cell is kEmpty and its cube polyhedron gives 8 octant hexes, so
  // the outside mesh is the grid refined once by 2 per axis.
  const UniformGrid grid({{0, 0, 0}, {1, 1, 1}}, 1);
  const std::vector<double> values(grid.vertex_count(), -1.0);
  MchexStats stats;
  const MeshPair m = mesh_mchex(grid, values, 1e-3, &stats);
  EXPECT_TRUE(m.inside.hexes.empty());
  EXPECT_EQ(m.outside.hexes.size(), 27u * 8);
  EXPECT_EQ(m.outside.points.size(), 7u * 7 * 7);
  EXPECT_EQ(stats.cases[0], 27u);
  const Box box{{0, 0, 0}, {1, 1, 1}};
  const MeshCheck check = check_mesh(m.outside, nullptr, &box);
  EXPECT_TRUE(check.ok);
}

TEST(Mchex, ZeroValuesCountAsOutside) {
  // A plane through grid vertices (f = 0 on the middle layer): the zero rule makes those vertices
  // outside, so the solid is the layer of cells strictly above, cut at s = eps.
  const UniformGrid grid({{0, 0, 0}, {3, 3, 3}}, 1);
  const std::vector<Vec3> p = grid.vertices();
  std::vector<double> values(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) values[i] = p[i].z - 2.0;  // z = 2 exactly zero
  MchexStats stats;
  const MeshPair m = mesh_mchex(grid, values, 1e-3, &stats);
  EXPECT_EQ(stats.perturbed_values, 16u);
  const Box box{{0, 0, 0}, {3, 3, 3}};
  const MeshCheck check = check_mesh(m.inside, &m.outside, &box);
  EXPECT_TRUE(check.ok) << (check.errors.empty() ? "" : check.errors.front());
  EXPECT_EQ(check.inside.boundary.euler_characteristic, 2);
  EXPECT_NEAR(check.inside.quality.volume, 9.0 * (1 - 1e-3), 1e-9);
}

// Random values on a small grid: every MC33 subcase turns up, the refined ones (tunnels included)
// by the thousand, with crossings anywhere in [eps, 1 - eps]. Asserted: no gap, overlap,
// non-manifold or misoriented face, interface faces matched exactly, volumes adding up to the
// box, the hex count, and every hex of both meshes Bernstein-certified.
TEST(Mchex, RandomFieldsConformAndCertifyIncludingRefinedCells) {
  std::mt19937_64 rng(20250601);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Box box{{0, 0, 0}, {1, 1, 1}};
  const UniformGrid grid(box, 2);
  std::size_t refined = 0;
  std::array<std::size_t, kMchexCaseSlots> seen{};
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<double> values(grid.vertex_count());
    for (double& v : values) v = u(rng);
    MchexStats stats;
    const MeshPair m = mesh_mchex(grid, values, 1e-3, &stats);
    refined += stats.refined_cells;
    for (int i = 0; i < kMchexCaseSlots; ++i) seen[i] += stats.cases[i];
    const MeshCheck c = check_mesh(m.inside, &m.outside, &box);
    for (const MeshStats* ms : {&c.inside, &*c.outside}) {
      EXPECT_EQ(ms->nonmanifold_faces, 0u);
      EXPECT_EQ(ms->orientation_errors, 0u);
      EXPECT_EQ(ms->cyclic_mismatches, 0u);
      EXPECT_EQ(ms->repeated_vertex_hexes, 0u);
    }
    EXPECT_EQ(c.combined->gap_faces, 0u);
    EXPECT_EQ(c.combined->overlap_faces, 0u);
    EXPECT_EQ(c.combined->interface_errors, 0u);
    EXPECT_TRUE(c.combined->volume_ok) << c.combined->volume_relative_error;
    EXPECT_EQ(m.inside.hexes.size() + m.outside.hexes.size(), stats.expected_hexes);
    EXPECT_EQ(c.inside.quality.certified, c.inside.quality.count);
    EXPECT_EQ(c.outside->quality.certified, c.outside->quality.count);
  }
  std::size_t subcases_seen = 0;
  for (std::size_t n : seen) subcases_seen += n > 0;
  std::printf("[mchex] random fields: %zu refined cells, %zu of 32 subcase slots seen\n", refined, subcases_seen);
  EXPECT_EQ(subcases_seen, std::size_t(kMchexCaseSlots));
  EXPECT_GT(refined, 1000u);
}

TEST(Mchex, SameBytesOnOneAndTwoThreads) {
  MchexRun one = [] {
    ThreadLimit limit(1);
    return mesh_shape(ShapeKind::kTwoHoled, 3);
  }();
  MchexRun two = [] {
    ThreadLimit limit(2);
    return mesh_shape(ShapeKind::kTwoHoled, 3);
  }();
  for (const auto& [a, b] :
       {std::pair{&one.mesh.inside, &two.mesh.inside}, std::pair{&one.mesh.outside, &two.mesh.outside}}) {
    ASSERT_FALSE(a->hexes.empty());
    EXPECT_EQ(a->hexes, b->hexes);
    ASSERT_EQ(a->points.size(), b->points.size());
    EXPECT_EQ(0, std::memcmp(a->points.data(), b->points.data(), a->points.size() * sizeof(Vec3)));
  }
}

// The names of shared points come from the complex's topology, not from grid indices: renumber
// the points and shuffle the cells (each cell's corners kept in VTK order) and the mesh is the
// same set of hexes, corner for corner in coordinates.
TEST(Mchex, AnyNumberingOfTheComplexGivesTheSameHexes) {
  const ShapeSdf sdf(ShapeKind::kTorus);
  const UniformGrid grid(padded_cube(sdf.bounds(), 0.1), 2);
  const HexComplex a = uniform_complex(grid);
  std::vector<double> fa(a.points.size());
  sdf.evaluate(a.points, fa);

  std::mt19937_64 rng(7);
  std::vector<std::uint32_t> new_id(a.points.size());
  std::iota(new_id.begin(), new_id.end(), 0u);
  std::shuffle(new_id.begin(), new_id.end(), rng);
  HexComplex b = a;
  std::vector<double> fb(fa.size());
  for (std::size_t i = 0; i < a.points.size(); ++i) {
    b.points[new_id[i]] = a.points[i];
    fb[new_id[i]] = fa[i];
  }
  for (CellCorners& c : b.cells)
    for (std::uint32_t& v : c) v = new_id[v];
  std::shuffle(b.cells.begin(), b.cells.end(), rng);

  MchexStats sa, sb;
  const MeshPair ma = mesh_mchex(a, fa, 1e-3, &sa), mb = mesh_mchex(b, fb, 1e-3, &sb);
  EXPECT_EQ(sa.points, sb.points);
  auto geometric = [](const HexMesh& m) {
    std::vector<std::array<double, 24>> hexes;
    for (const Hex& h : m.hexes) {
      std::array<double, 24> g;
      for (int c = 0; c < 8; ++c) {
        // Rounded to 1e-9 so that ulp-level differences cannot reorder the sort.
        g[3 * c] = std::round(m.points[h[c]].x * 1e9);
        g[3 * c + 1] = std::round(m.points[h[c]].y * 1e9);
        g[3 * c + 2] = std::round(m.points[h[c]].z * 1e9);
      }
      hexes.push_back(g);
    }
    std::sort(hexes.begin(), hexes.end());
    return hexes;
  };
  // Equal to rounding: a shared point's coordinates come from its owner cell, which depends on
  // the cell order.
  const auto ga = geometric(ma.inside), gb = geometric(mb.inside);
  ASSERT_EQ(ga.size(), gb.size());
  ASSERT_FALSE(ga.empty());
  double worst = 0;
  for (std::size_t i = 0; i < ga.size(); ++i)
    for (int k = 0; k < 24; ++k) worst = std::max(worst, std::abs(ga[i][k] - gb[i][k]));
  EXPECT_LE(worst, 1.0);  // in units of 1e-9
  EXPECT_EQ(ma.outside.hexes.size(), mb.outside.hexes.size());
  const MeshCheck check = check_mesh(mb.inside, &mb.outside, &a.box);
  EXPECT_TRUE(check.ok);
  EXPECT_EQ(check.inside.boundary.euler_characteristic, 0);
}

// A curved complex (every grid point moved by a smooth map, so the cells are general trilinear
// hexes, not cubes) still conforms: the names never look at coordinates.
TEST(Mchex, CurvedComplexConforms) {
  const ShapeSdf sdf(ShapeKind::kSphere);
  const UniformGrid grid(padded_cube(sdf.bounds(), 0.1), 3);
  HexComplex cx = uniform_complex(grid);
  std::vector<double> f(cx.points.size());
  sdf.evaluate(cx.points, f);
  for (Vec3& p : cx.points) {
    const Vec3 q = p;
    p = {q.x + 0.04 * std::sin(3 * q.y), q.y + 0.04 * std::sin(3 * q.z), q.z + 0.04 * std::sin(3 * q.x)};
  }
  Box box;
  for (const Vec3& p : cx.points) box.extend(p);
  const MeshPair m = mesh_mchex(cx, f, 1e-3);
  const MeshCheck c = check_mesh(m.inside, &m.outside, nullptr);
  for (const MeshStats* ms : {&c.inside, &*c.outside}) {
    EXPECT_EQ(ms->nonmanifold_faces, 0u);
    EXPECT_EQ(ms->orientation_errors, 0u);
    EXPECT_EQ(ms->repeated_vertex_hexes, 0u);
  }
  EXPECT_EQ(c.combined->interface_errors, 0u);
  EXPECT_EQ(c.inside.boundary.euler_characteristic, 2);
  EXPECT_TRUE(c.inside.boundary.closed_manifold());
}

// Issue 5's fidelity bar and the paper's point against RO (Section 6): on the same grid, the
// MCHex inside mesh of the torus fits the exact torus better than the RO mesh, in volume (IoU)
// and in boundary distance (Hausdorff ratio), at depths 3 and 4.
TEST(Mchex, FitsTheTorusBetterThanRemoveOutside) {
  const ShapeSdf torus(ShapeKind::kTorus);
  const Box box = padded_cube(torus.bounds(), 0.1);
  const double spacing = box.diagonal() / 400;
  const std::vector<Vec3> samples = sample_surface(torus, box, spacing);
  for (int depth : {3, 4}) {
    const UniformGrid grid(box, depth);
    const std::vector<Vec3> points = grid.vertices();
    std::vector<double> f(points.size());
    torus.evaluate(points, f);
    const MeshPair mchex = mesh_mchex(grid, f, 1e-3), ro = mesh_remove_outside(grid, f);
    const Fidelity a = measure_fidelity(mchex.inside, torus, samples, box, 96, spacing);
    const Fidelity b = measure_fidelity(ro.inside, torus, samples, box, 96, spacing);
    std::printf("[mchex] torus depth %d: IoU mchex %.4f ro %.4f, Hausdorff ratio mchex %.4f%% ro %.4f%% "
                "(%zu unresolved samples)\n",
                depth, a.iou, b.iou, 100 * a.hausdorff_ratio, 100 * b.hausdorff_ratio, a.unresolved);
    EXPECT_GT(a.iou, b.iou) << "depth " << depth;
    EXPECT_LT(a.hausdorff_ratio, b.hausdorff_ratio) << "depth " << depth;
    // Samples whose hex the Newton inversion could not settle (thin hexes at crossings near
    // eps) are reported by measure_fidelity; they must be too few to move the IoU comparison.
    EXPECT_LT(double(a.unresolved), 1e-3 * 96 * 96 * 96) << "depth " << depth;
  }
}

// Exact crossings (MchexCrossings): the field's own zero on every cut edge of the complex.

// `f` meshed on the grid's complex: its values at the points and, with `exact`, f itself for the
// crossings' search.
struct FieldRun {
  MeshPair mesh;
  MchexStats stats;
};
FieldRun mesh_field(const UniformGrid& grid, const std::function<double(Vec3)>& f, bool exact) {
  const HexComplex cx = uniform_complex(grid);
  std::vector<double> values(cx.points.size());
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = f(cx.points[i]);
  MchexCrossings crossings;
  if (exact)
    crossings.field = [&](std::span<const Vec3> p, std::span<double> v) {
      for (std::size_t i = 0; i < p.size(); ++i) v[i] = f(p[i]);
    };
  FieldRun r;
  r.mesh = mesh_mchex(cx, values, 1e-3, &r.stats, {}, crossings);
  return r;
}

// check_mesh of the pair in `box`, asserted: no error, every hex certified.
MeshCheck expect_valid_pair(const MeshPair& m, const Box& box) {
  MeshCheck check = check_mesh(m.inside, &m.outside, &box);
  EXPECT_TRUE(check.ok) << (check.errors.empty() ? "" : check.errors.front());
  EXPECT_EQ(check.inside.quality.certified, check.inside.quality.count);
  EXPECT_EQ(check.outside->quality.certified, check.outside->quality.count);
  return check;
}

// The interface points (in both meshes) on a grid line of `grid`: the crossings.
std::vector<Vec3> interface_points_on_grid_lines(const MeshPair& m, const UniformGrid& grid) {
  std::vector<Vec3> outside = m.outside.points;
  auto less = [](const Vec3& a, const Vec3& b) { return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z); };
  std::sort(outside.begin(), outside.end(), less);
  const double h = grid.cell_size();
  auto on_plane = [&](double x, int axis) {
    const double k = (x - grid.box().lo[axis]) / h;
    return std::abs(k - std::round(k)) < 1e-9;
  };
  std::vector<Vec3> out;
  for (const Vec3& p : m.inside.points) {
    if (!std::binary_search(outside.begin(), outside.end(), p, less)) continue;
    if (on_plane(p.x, 0) + on_plane(p.y, 1) + on_plane(p.z, 2) == 2) out.push_back(p);
  }
  return out;
}

TEST(Mchex, ExactCrossingsLieOnTheSurface) {
  const ShapeSdf sphere(ShapeKind::kSphere);
  const Box box = padded_cube(sphere.bounds(), 0.1);
  auto f = [&](Vec3 p) {
    double v;
    sphere.evaluate(std::span<const Vec3>(&p, 1), std::span<double>(&v, 1));
    return v;
  };
  for (int depth : {2, 3}) {
    const UniformGrid grid(box, depth);
    double worst[2] = {0, 0};
    for (bool exact : {false, true}) {
      const FieldRun r = mesh_field(grid, f, exact);
      expect_valid_pair(r.mesh, box);
      const std::vector<Vec3> crossings = interface_points_on_grid_lines(r.mesh, grid);
      ASSERT_GT(crossings.size(), 20u);
      for (const Vec3& p : crossings) worst[exact] = std::max(worst[exact], std::abs(f(p)));
      if (exact) {
        EXPECT_GT(r.stats.exact_crossings, 0u);
        EXPECT_LE(r.stats.crossing_residual, 1e-9);
      }
    }
    std::printf("[mchex] sphere depth %d: largest |f| at a crossing: linear %.3g, exact %.3g (cell %.3g)\n", depth,
                worst[0], worst[1], grid.cell_size());
    // The linear crossings cut the chords of the sphere; the exact ones are on it (the eps clamp
    // does not bind on this grid: no crossing lies within 1e-3 of a corner).
    EXPECT_GT(worst[0], 1e-4 * grid.cell_size()) << "depth " << depth;
    EXPECT_LE(worst[1], 1e-9 * grid.cell_size()) << "depth " << depth;
  }
}

TEST(Mchex, ExactCrossingsOfALinearFieldAreTheLinearOnes) {
  // Along every edge the field is linear, so the first point searched (the linear crossing) is
  // its zero and the two rules give the same mesh, bit for bit.
  const UniformGrid grid(Box{{-1, -1, -1}, {1, 1, 1}}, 3);
  auto f = [](Vec3 p) { return 0.3 - 0.8 * p.x + 0.5 * p.y - 0.3 * p.z; };
  const FieldRun a = mesh_field(grid, f, false), b = mesh_field(grid, f, true);
  ASSERT_FALSE(a.mesh.inside.hexes.empty());
  EXPECT_EQ(a.mesh.inside.hexes, b.mesh.inside.hexes);
  EXPECT_EQ(a.mesh.outside.hexes, b.mesh.outside.hexes);
  ASSERT_EQ(a.mesh.inside.points.size(), b.mesh.inside.points.size());
  for (std::size_t i = 0; i < a.mesh.inside.points.size(); ++i)
    ASSERT_EQ(std::memcmp(&a.mesh.inside.points[i], &b.mesh.inside.points[i], sizeof(Vec3)), 0) << "point " << i;
  EXPECT_EQ(b.stats.crossing_batches, 1u);
}

TEST(Mchex, ExactCrossingsKeepASharpBoxSharper) {
  // A cube of edge 1 turned about two axes, so that its sharp edges run across the grid: its
  // signed distance (inside: to the nearest face; outside: to the box) is not linear along the
  // grid edges near them, and the linear crossings round them off. Its volume is exactly 1.
  const double c1 = std::cos(0.5), s1 = std::sin(0.5), c2 = std::cos(0.3), s2 = std::sin(0.3);
  auto f = [&](Vec3 p) {
    const Vec3 r{c1 * p.x - s1 * p.y, s1 * p.x + c1 * p.y, p.z};
    const Vec3 q{std::abs(r.x) - 0.5, std::abs(c2 * r.y - s2 * r.z) - 0.5, std::abs(s2 * r.y + c2 * r.z) - 0.5};
    const Vec3 out{std::max(q.x, 0.0), std::max(q.y, 0.0), std::max(q.z, 0.0)};
    return -(norm(out) + std::min(std::max({q.x, q.y, q.z}), 0.0));
  };
  const Box box{{-1, -1, -1}, {1, 1, 1}};
  for (int depth : {2, 3}) {
    const UniformGrid grid(box, depth);
    double error[2];
    for (bool exact : {false, true}) {
      const FieldRun r = mesh_field(grid, f, exact);
      const MeshCheck check = expect_valid_pair(r.mesh, box);
      EXPECT_TRUE(check.inside.boundary.closed_manifold());
      error[exact] = std::abs(check.inside.quality.volume - 1.0);
    }
    std::printf("[mchex] turned cube depth %d: volume error linear %.4f, exact %.4f\n", depth, error[0], error[1]);
    EXPECT_LT(error[1], 0.75 * error[0]) << "depth " << depth;
  }
}

TEST(Mchex, RejectsBadInput) {
  const UniformGrid grid({{0, 0, 0}, {1, 1, 1}}, 1);
  const std::vector<double> values(grid.vertex_count(), 1.0);
  EXPECT_THROW(mesh_mchex(grid, values, 0.0, nullptr), std::exception);
  EXPECT_THROW(mesh_mchex(grid, values, 0.5, nullptr), std::exception);
  EXPECT_THROW(mesh_mchex(grid, std::span<const double>(values).first(3), 1e-3, nullptr), std::exception);
}

}  // namespace
}  // namespace mchex
