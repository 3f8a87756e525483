// The certified optimiser (core/optimize/optimize.h). References: a distorted regular grid (whose
// optimum, the undistorted grid, has scaled Jacobian 1 everywhere), the analytic sphere |p| = 1,
// every-triangle closest points, and the mesh checker for certificates and conformity.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <tuple>
#include <vector>

#include "core/base/parallel.h"
#include "core/check/mesh_check.h"
#include "core/cutting/mchex_mesher.h"
#include "core/grid/grid.h"
#include "core/mesh/quality.h"
#include "core/optimize/optimize.h"
#include "core/sdf/shapes.h"

namespace mchex {
namespace {

// n^3 unit cubes; interior points moved by up to `amount` in each coordinate (seeded).
HexMesh distorted_grid(int n, double amount, unsigned seed) {
  HexMesh m;
  auto id = [&](int i, int j, int k) { return uint32_t((k * (n + 1) + j) * (n + 1) + i); };
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> d(-amount, amount);
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        Vec3 p{double(i), double(j), double(k)};
        const bool interior = i > 0 && j > 0 && k > 0 && i < n && j < n && k < n;
        const Vec3 r{d(rng), d(rng), d(rng)};
        if (interior) p += r;
        m.points.push_back(p);
      }
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        m.hexes.push_back({id(i, j, k), id(i + 1, j, k), id(i + 1, j + 1, k), id(i, j + 1, k), id(i, j, k + 1),
                           id(i + 1, j, k + 1), id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1)});
        m.region.push_back(kInside);
      }
  return m;
}

struct Quality {
  double min = INFINITY, mean = 0;
  std::size_t certified = 0;
};
Quality quality(const HexMesh& m) {
  Quality q;
  for (std::size_t h = 0; h < m.hexes.size(); ++h) {
    const HexQuality x = hex_quality(m.corners(h));
    q.min = std::min(q.min, x.scaled_jacobian);
    q.mean += x.scaled_jacobian / double(m.hexes.size());
    q.certified += x.certified();
  }
  return q;
}

TEST(Optimize, DistortedGridMovesTowardsTheRegularGrid) {
  MeshPair pair;
  pair.inside = distorted_grid(6, 0.3, 7);
  const Quality before = quality(pair.inside);
  ASSERT_EQ(before.certified, pair.inside.hexes.size());
  ASSERT_LT(before.min, 0.5);
  const HexMesh original = pair.inside;
  const OptimizeStats s = optimize(pair, nullptr, {});
  const Quality after = quality(pair.inside);
  EXPECT_EQ(after.certified, pair.inside.hexes.size());
  EXPECT_GT(after.min, before.min + 0.2);
  EXPECT_GT(after.mean, before.mean);
  EXPECT_DOUBLE_EQ(s.min_sj_before, before.min);
  EXPECT_DOUBLE_EQ(s.min_sj_after, after.min);
  EXPECT_EQ(s.certified_after, pair.inside.hexes.size());
  // Without a surface the boundary is fixed.
  const std::vector<std::array<uint32_t, 4>> quads = boundary_quads(original);
  for (const auto& q : quads)
    for (uint32_t v : q) EXPECT_EQ(pair.inside.points[v], original.points[v]);
}

// A pair distorted so that some hexes are barely certified: no move may lose a certificate.
TEST(Optimize, CertificateNeverLapses) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    MeshPair pair;
    pair.inside = distorted_grid(5, 0.42, seed);
    const Quality before = quality(pair.inside);
    const OptimizeStats s = optimize(pair, nullptr, {});
    const Quality after = quality(pair.inside);
    EXPECT_GE(after.certified, before.certified) << seed;
    EXPECT_GE(after.min, before.min) << seed;
    EXPECT_EQ(s.certified_after, after.certified);
  }
}

MeshPair sphere_pair(int depth) {
  const ShapeSdf sdf(ShapeKind::kSphere);
  const UniformGrid grid(padded_cube(sdf.bounds(), 0.1), depth);
  const std::vector<Vec3> points = grid.vertices();
  std::vector<double> v(points.size());
  sdf.evaluate(points, v);
  return mesh_mchex(grid, v, 1e-3, nullptr);
}

std::map<std::tuple<double, double, double>, int> coordinate_set(const std::vector<Vec3>& p) {
  std::map<std::tuple<double, double, double>, int> s;
  for (const Vec3& x : p) ++s[{x.x, x.y, x.z}];
  return s;
}

TEST(Optimize, SphereBoundaryStaysOnTheSphereAndTheInterfaceShared) {
  MeshPair pair = sphere_pair(2);
  const MeshPair original = pair;
  const ShapeSdf sdf(ShapeKind::kSphere);
  const MeshCheck c0 = check_mesh(pair.inside, &pair.outside, nullptr);
  ASSERT_TRUE(c0.ok);
  const OptimizeStats s = optimize(pair, &sdf, {});
  EXPECT_GT(s.min_sj_after, s.min_sj_before);
  EXPECT_GT(s.moves_accepted, 0u);
  // Every boundary vertex that moved lies on |p| = 1.
  std::size_t moved = 0;
  for (const auto& q : boundary_quads(pair.inside))
    for (uint32_t v : q)
      if (!(pair.inside.points[v] == original.inside.points[v])) {
        ++moved;
        EXPECT_NEAR(norm(pair.inside.points[v]), 1.0, 1e-9);
      }
  EXPECT_GT(moved, 0u);
  // The interface: the outside points on it still have an inside point at the same place.
  const auto in = coordinate_set(pair.inside.points), in0 = coordinate_set(original.inside.points);
  std::size_t shared = 0, shared0 = 0;
  for (const Vec3& x : pair.outside.points) shared += in.count({x.x, x.y, x.z});
  for (const Vec3& x : original.outside.points) shared0 += in0.count({x.x, x.y, x.z});
  EXPECT_EQ(shared, shared0);
  const MeshCheck c1 = check_mesh(pair.inside, &pair.outside, nullptr);
  EXPECT_TRUE(c1.ok) << (c1.errors.empty() ? "" : c1.errors.front());
  EXPECT_EQ(c1.combined->interface_faces, c0.combined->interface_faces);
  EXPECT_EQ(c1.inside.quality.certified, pair.inside.hexes.size());
  EXPECT_EQ(c1.outside->quality.certified, pair.outside.hexes.size());
  EXPECT_NEAR(c1.combined->volume_relative_error, 0, 1e-9);
}

TEST(Optimize, SameResultOnOneAndTwoThreads) {
  const ShapeSdf sdf(ShapeKind::kSphere);
  MeshPair a = sphere_pair(2), b = a;
  OptimizeStats sa, sb;
  {
    const ThreadLimit one(1);
    sa = optimize(a, &sdf, {});
  }
  {
    const ThreadLimit two(2);
    sb = optimize(b, &sdf, {});
  }
  EXPECT_EQ(sa.moves_accepted, sb.moves_accepted);
  EXPECT_EQ(sa.min_sj_after, sb.min_sj_after);
  ASSERT_EQ(a.inside.points.size(), b.inside.points.size());
  for (std::size_t i = 0; i < a.inside.points.size(); ++i) ASSERT_EQ(a.inside.points[i], b.inside.points[i]) << i;
  for (std::size_t i = 0; i < a.outside.points.size(); ++i) ASSERT_EQ(a.outside.points[i], b.outside.points[i]) << i;
}

TEST(Optimize, ProjectionLandsOnTheSurface) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> d(-1.4, 1.4);
  std::vector<Vec3> p(200);
  for (Vec3& x : p) x = {d(rng), d(rng), d(rng)};
  // The analytic sphere: Newton steps on the field.
  std::vector<Vec3> q = p;
  project_to_surface(ShapeSdf(ShapeKind::kSphere), q);
  for (std::size_t i = 0; i < p.size(); ++i) {
    EXPECT_NEAR(norm(q[i]), 1.0, 1e-9);
    EXPECT_LT(norm(q[i] - normalized(p[i])), 1e-8);  // the closest point of a sphere
  }
  // A triangle surface: the exact closest point, against every triangle.
  const TriangleSurface s = tessellate(ShapeKind::kTorus, 24);
  const SurfaceSdf sdf(s);
  q = p;
  project_to_surface(sdf, q);
  for (std::size_t i = 0; i < p.size(); ++i) {
    double best = INFINITY;
    for (const auto& t : s.triangles)
      best = std::min(
          best, closest_point_on_triangle(p[i], s.vertices[t[0]], s.vertices[t[1]], s.vertices[t[2]]).squared_distance);
    EXPECT_NEAR(squared_norm(q[i] - p[i]), best, 1e-12);
  }
}

}  // namespace
}  // namespace mchex
