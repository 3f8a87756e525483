// The uniform grid, the RO method and the fidelity measures against hand-computed answers.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>

#include "core/base/error.h"
#include "core/check/fidelity.h"
#include "core/check/mesh_check.h"
#include "core/cutting/ro.h"
#include "core/grid/grid.h"
#include "core/grid/hex_complex.h"
#include "core/mesh/quality.h"
#include "core/sdf/shapes.h"

namespace mchex {
namespace {

TEST(UniformGrid, CountsIndexingAndExactEnds) {
  const UniformGrid g({{-1, -2, -3}, {2, 1, 0}}, 3);
  EXPECT_EQ(g.cells_per_axis(), 27u);
  EXPECT_EQ(g.cell_count(), 27u * 27 * 27);
  EXPECT_EQ(g.vertex_count(), 28u * 28 * 28);
  const auto v = g.vertices();
  EXPECT_EQ(v.front(), (Vec3{-1, -2, -3}));
  EXPECT_EQ(v.back(), (Vec3{2, 1, 0}));
  EXPECT_EQ(v[g.vertex_index(1, 0, 0)], (Vec3{-1 + 3.0 / 27, -2, -3}));
  // Corners follow the VTK order: bottom 0-1-2-3 counter-clockwise, top 4-7 above them.
  const auto c = g.cell_corners(2, 5, 7);
  const Vec3 o = v[c[0]], h{3.0 / 27, 3.0 / 27, 3.0 / 27};
  const Vec3 expect[8] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  for (int i = 0; i < 8; ++i) {
    EXPECT_NEAR(v[c[i]].x - o.x, expect[i].x * h.x, 1e-14);
    EXPECT_NEAR(v[c[i]].y - o.y, expect[i].y * h.y, 1e-14);
    EXPECT_NEAR(v[c[i]].z - o.z, expect[i].z * h.z, 1e-14);
  }
  EXPECT_THROW(UniformGrid({{0, 0, 0}, {1, 1, 1}}, kMaxUniformDepth + 1), InputError);
}

TEST(UniformGrid, PaddedCubeHoldsTheInputWithItsMargin) {
  const Box cube = padded_cube({{0, 0, 0}, {4, 2, 1}}, 0.1);
  EXPECT_DOUBLE_EQ(cube.size().x, 4.8);
  EXPECT_DOUBLE_EQ(cube.size().y, 4.8);
  EXPECT_DOUBLE_EQ(cube.size().z, 4.8);
  EXPECT_EQ(cube.center(), (Vec3{2, 1, 0.5}));
  EXPECT_THROW(padded_cube({{1, 1, 1}, {1, 1, 1}}, 0.1), InputError);
  EXPECT_THROW(padded_cube(Box{}, 0.1), InputError);
}

TEST(RemoveOutside, KeepsExactlyTheCellsWithAPositiveCornerSum) {
  const ShapeSdf torus(ShapeKind::kTorus);
  const UniformGrid g(padded_cube(torus.bounds(), 0.1), 3);
  const auto pts = g.vertices();
  std::vector<double> f(pts.size());
  torus.evaluate(pts, f);
  const MeshPair m = mesh_remove_outside(g, f);
  EXPECT_EQ(m.inside.hexes.size() + m.outside.hexes.size(), g.cell_count());
  std::size_t expected_inside = 0;
  for (uint32_t k = 0; k < 27; ++k)
    for (uint32_t j = 0; j < 27; ++j)
      for (uint32_t i = 0; i < 27; ++i) {
        double sum = 0;
        for (uint32_t v : g.cell_corners(i, j, k)) sum += torus(pts[v]);
        expected_inside += sum > 0;
      }
  EXPECT_EQ(m.inside.hexes.size(), expected_inside);
  for (std::size_t h = 0; h < m.inside.hexes.size(); ++h) {
    double sum = 0;
    for (const Vec3& p : m.inside.corners(h)) sum += torus(p);
    ASSERT_GT(sum, 0);
  }
  for (int32_t r : m.inside.region) ASSERT_EQ(r, kInside);
  for (int32_t r : m.outside.region) ASSERT_EQ(r, kOutside);
  const Box box = g.box();
  const MeshCheck check = check_mesh(m.inside, &m.outside, &box);
  EXPECT_TRUE(check.ok);
  EXPECT_EQ(check.inside.boundary.euler_characteristic, 0);  // a torus of cells
  EXPECT_TRUE(check.inside.boundary.closed_manifold());
}

TEST(RemoveOutside, ComplexOfTheGridGivesTheSameMeshes) {
  const ShapeSdf torus(ShapeKind::kTorus);
  const UniformGrid g(padded_cube(torus.bounds(), 0.1), 2);
  const HexComplex cx = uniform_complex(g);
  ASSERT_EQ(cx.cells.size(), g.cell_count());
  std::vector<double> f(cx.points.size());
  torus.evaluate(cx.points, f);
  const MeshPair a = mesh_remove_outside(g, f), b = mesh_remove_outside(cx, f);
  EXPECT_EQ(a.inside.hexes, b.inside.hexes);
  EXPECT_EQ(a.outside.hexes, b.outside.hexes);
  EXPECT_EQ(a.inside.points.size(), b.inside.points.size());
  EXPECT_THROW(mesh_remove_outside(cx, std::span<const double>(f).first(5)), InputError);
}

TEST(Fidelity, CubeOfCellsAgainstTheUnitSphere) {
  // The cube [-0.5, 0.5]^3 lies inside the unit sphere: IoU = 1 / (4 pi / 3); the Hausdorff
  // distance is 0.5 (face centre to sphere, and sphere pole to face).
  const UniformGrid g({{-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5}}, 1);
  std::vector<Hex> hexes;
  for (uint32_t k = 0; k < 3; ++k)
    for (uint32_t j = 0; j < 3; ++j)
      for (uint32_t i = 0; i < 3; ++i) hexes.push_back(g.cell_corners(i, j, k));
  const auto pts = g.vertices();
  const HexMesh cube = compact_mesh(pts, hexes, kInside);
  const ShapeSdf sphere(ShapeKind::kSphere);
  // Lattice step 0.02 from -1.26: the cube's faces fall halfway between sample centres, so the
  // lattice counts exactly 50^3 samples in the cube.
  const Box box{{-1.26, -1.26, -1.26}, {1.26, 1.26, 1.26}};
  const double spacing = 0.01;
  const auto samples = sample_surface(sphere, box, spacing);
  for (const Vec3& s : samples) ASSERT_NEAR(norm(s), 1.0, 1e-9);
  const Fidelity f = measure_fidelity(cube, sphere, samples, box, 126, spacing);
  EXPECT_NEAR(f.mesh_volume, 1.0, 1e-12);
  // The sphere's lattice volume is off by at most its area times half a step.
  EXPECT_NEAR(f.solid_volume, 4 * std::numbers::pi / 3, 4 * std::numbers::pi * 0.01);
  EXPECT_NEAR(f.iou, 1.0 / f.solid_volume, 1e-12);
  EXPECT_NEAR(f.iou, 1.0 / (4 * std::numbers::pi / 3), 0.01);
  EXPECT_NEAR(f.mesh_to_surface, 0.5, 1e-12);  // a face centre is a sample
  EXPECT_NEAR(f.surface_to_mesh, 0.5, 2e-3);
  EXPECT_NEAR(f.hausdorff_ratio, 0.5 / std::sqrt(12.0), 1e-3);
  EXPECT_EQ(f.unresolved, 0u);
  EXPECT_EQ(boundary_quads(cube).size(), 6u * 9);
}

// A hex far smaller than its distance from the origin (the clamped crossings' slivers at the
// surface are 1e-3 of a cell) is located like any other: its inverse map is known only to about
// eps |x| / size, and a fixed step tolerance below that left the sample unresolved (not counted),
// so the IoU moved with the last bits of the corners. One sample at (1.5, 1.5, 1.5) in each of 200
// random distorted hexes of 1e-7 to 1e-4 that hold it at a random parametric point.
TEST(Fidelity, BoundaryDistanceIsTheSameInChunksOfAnySize) {
  // A block of 24 x 24 x 6 hexes over jittered points (1,728 curved boundary quads) and points
  // around and inside it: in chunks of any size the distances are those of one chunk (the whole
  // boundary's tree) bit for bit, and those are the least over every quad's four triangles
  // through its bilinear centre (brute force).
  const int n[3] = {24, 24, 6};
  HexMesh mesh;
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> u(-1, 1);
  auto id = [&](int i, int j, int k) { return uint32_t(i + (n[0] + 1) * (j + (n[1] + 1) * k)); };
  for (int k = 0; k <= n[2]; ++k)
    for (int j = 0; j <= n[1]; ++j)
      for (int i = 0; i <= n[0]; ++i) mesh.points.push_back({i + 0.3 * u(rng), j + 0.3 * u(rng), k + 0.3 * u(rng)});
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i)
        mesh.hexes.push_back({id(i, j, k), id(i + 1, j, k), id(i + 1, j + 1, k), id(i, j + 1, k), id(i, j, k + 1),
                              id(i + 1, j, k + 1), id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1)});
  mesh.region.assign(mesh.hexes.size(), 1);
  std::vector<Vec3> points(3000);
  for (Vec3& p : points) p = {12 + 15 * u(rng), 12 + 15 * u(rng), 3 + 6 * u(rng)};

  const std::vector<double> whole = distance_to_boundary(mesh, points, std::size_t(1) << 30);
  for (std::size_t chunk : {1, 7, 100, 1000}) {
    const std::vector<double> d = distance_to_boundary(mesh, points, chunk);
    ASSERT_EQ(d.size(), points.size());
    for (std::size_t i = 0; i < points.size(); ++i)
      ASSERT_EQ(std::bit_cast<uint64_t>(d[i]), std::bit_cast<uint64_t>(whole[i]))
          << "chunk " << chunk << " point " << i;
  }
  const auto quads = boundary_quads(mesh);
  ASSERT_EQ(quads.size(), 2u * (24 * 24 + 24 * 6 + 24 * 6));
  for (std::size_t i = 0; i < 300; ++i) {
    double least = std::numeric_limits<double>::infinity();
    for (const auto& q : quads) {
      const Vec3 c[4] = {mesh.points[q[0]], mesh.points[q[1]], mesh.points[q[2]], mesh.points[q[3]]};
      const Vec3 centre = 0.25 * (c[0] + c[1] + c[2] + c[3]);
      for (int e = 0; e < 4; ++e)
        least = std::min(least, closest_point_on_triangle(points[i], c[e], c[(e + 1) % 4], centre).squared_distance);
    }
    ASSERT_EQ(whole[i], std::sqrt(least)) << "point " << i;
  }
  EXPECT_THROW(distance_to_boundary(mesh, points, 0), std::invalid_argument);
  // No boundary: nothing is near.
  const std::vector<double> none = distance_to_boundary(HexMesh{}, std::span<const Vec3>(points).first(3));
  EXPECT_EQ(none, std::vector<double>(3, std::numeric_limits<double>::infinity()));
}

TEST(Fidelity, TinyHexesFarFromTheOriginHoldTheirSample) {
  const ShapeSdf sphere(ShapeKind::kSphere);
  const Box box{{0, 0, 0}, {3, 3, 3}};  // lattice 3: samples at 0.5, 1.5, 2.5
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(0, 1), wobble(-0.2, 0.2);
  const Vec3 sample{1.5, 1.5, 1.5};
  for (int trial = 0; trial < 200; ++trial) {
    const double h = std::pow(10.0, -7 + 3 * unit(rng));
    std::array<Vec3, 8> unit_cube = {
        {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}}};
    HexCorners c;
    for (int k = 0; k < 8; ++k) c[k] = h * (unit_cube[k] + Vec3{wobble(rng), wobble(rng), wobble(rng)});
    // Placed so that the sample is the map of a random parametric point.
    const Vec3 at = trilinear_map(c, {0.1 + 0.8 * unit(rng), 0.1 + 0.8 * unit(rng), 0.1 + 0.8 * unit(rng)});
    HexMesh m;
    for (const Vec3& p : c) m.points.push_back(sample + (p - at));
    m.hexes = {{0, 1, 2, 3, 4, 5, 6, 7}};
    m.region = {kInside};
    const Fidelity f = measure_fidelity(m, sphere, {}, box, 3, 0.5);
    ASSERT_EQ(f.unresolved, 0u) << trial << " size " << h;
    ASSERT_EQ(f.mesh_volume, 1.0) << trial << " size " << h;  // the one sample, of a unit lattice cell
  }
}

TEST(Fidelity, ShearedHexesAreLocatedByTheirTrilinearMap) {
  // One sheared, non-parallel hex: a sample is inside exactly when the inverse map lands in the
  // unit cube; compare the lattice volume against the exact trilinear volume.
  HexMesh m;
  m.points = {{0, 0, 0}, {1, 0, 0}, {1.2, 1, 0}, {0, 0.9, 0}, {0.1, 0, 1}, {1, 0.1, 1.1}, {1.3, 1.2, 1}, {0, 1, 0.9}};
  m.hexes = {{0, 1, 2, 3, 4, 5, 6, 7}};
  m.region = {kInside};
  const ShapeSdf sphere(ShapeKind::kSphere);
  const Box box{{-0.1, -0.1, -0.1}, {1.4, 1.4, 1.4}};
  const Fidelity f = measure_fidelity(m, sphere, {}, box, 120, 0.05);
  const MeshCheck c = check_mesh(m, nullptr, nullptr);
  EXPECT_NEAR(f.mesh_volume, c.inside.quality.volume, 0.01 * c.inside.quality.volume);
  EXPECT_EQ(f.unresolved, 0u);
}

}  // namespace
}  // namespace mchex
