// The reference SDF against independent references: analytic shapes, dense sampling of
// triangles, the brute-force loop (the paper's method), and thread-count determinism.
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>

#include "core/base/parallel.h"
#include "core/sdf/sdf.h"
#include "core/sdf/shapes.h"

namespace mchex {
namespace {

std::vector<Vec3> random_points(std::size_t n, double lo, double hi, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(lo, hi);
  std::vector<Vec3> p(n);
  for (auto& x : p) x = {u(rng), u(rng), u(rng)};
  return p;
}

TEST(ClosestPointOnTriangle, MatchesDenseSamplingAndNamesTheFeature) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 200; ++trial) {
    const Vec3 a{u(rng), u(rng), u(rng)}, b{u(rng), u(rng), u(rng)}, c{u(rng), u(rng), u(rng)};
    const Vec3 p{2 * u(rng), 2 * u(rng), 2 * u(rng)};
    const ClosestPoint cp = closest_point_on_triangle(p, a, b, c);
    // Dense barycentric sampling gives an upper bound that converges to the true distance.
    double sampled = 1e300;
    const int k = 200;
    for (int i = 0; i <= k; ++i)
      for (int j = 0; i + j <= k; ++j)
        sampled = std::min(sampled, squared_norm(p - (a + (double(i) / k) * (b - a) + (double(j) / k) * (c - a))));
    EXPECT_LE(cp.squared_distance, sampled + 1e-12);
    EXPECT_GE(std::sqrt(cp.squared_distance), std::sqrt(sampled) - 0.02);
    EXPECT_NEAR(squared_norm(p - cp.point), cp.squared_distance, 1e-12);
  }
  const Vec3 a{0, 0, 0}, b{1, 0, 0}, c{0, 1, 0};
  EXPECT_EQ(closest_point_on_triangle({-1, -1, 0.5}, a, b, c).region, 0);
  EXPECT_EQ(closest_point_on_triangle({2, -0.5, 0}, a, b, c).region, 1);
  EXPECT_EQ(closest_point_on_triangle({-0.5, 2, 0}, a, b, c).region, 2);
  EXPECT_EQ(closest_point_on_triangle({0.5, -1, 0}, a, b, c).region, 3);
  EXPECT_EQ(closest_point_on_triangle({1, 1, 0}, a, b, c).region, 4);
  EXPECT_EQ(closest_point_on_triangle({-1, 0.5, 0}, a, b, c).region, 5);
  EXPECT_EQ(closest_point_on_triangle({0.25, 0.25, 3}, a, b, c).region, 6);
  // A zero-area (collinear) triangle has a closest point on its segments.
  const ClosestPoint flat = closest_point_on_triangle({0.5, 1, 0}, a, b, {2, 0, 0});
  EXPECT_NEAR(flat.squared_distance, 1.0, 1e-15);
}

TEST(SurfaceSdf, SignIsExactOnClosedTessellations) {
  for (ShapeKind kind : {ShapeKind::kSphere, ShapeKind::kTorus}) {
    const TriangleSurface mesh = tessellate(kind, 96);
    const SurfaceSdf sdf(mesh);
    const ShapeSdf exact(kind);
    const auto pts = random_points(20000, -1.6, 1.6, 11);
    std::vector<double> f(pts.size());
    sdf.evaluate(pts, f);
    // The tessellation's deviation from the analytic surface (its vertices lie on it; the
    // sag is largest inside triangles). Beyond that band both must agree on the side, and the
    // two distances differ by at most the deviation.
    double band = 0;
    for (const auto& t : mesh.triangles)
      for (int i = 0; i <= 8; ++i)
        for (int j = 0; i + j <= 8; ++j) {
          const Vec3 a = mesh.vertices[t[0]], b = mesh.vertices[t[1]], c = mesh.vertices[t[2]];
          band = std::max(band, std::abs(exact(a + (i / 8.0) * (b - a) + (j / 8.0) * (c - a))));
        }
    band = 1.05 * band + 1e-12;
    int compared = 0;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const double e = exact(pts[i]);
      if (std::abs(e) < band) continue;
      ++compared;
      ASSERT_EQ(f[i] > 0, e > 0) << shape_name(kind) << " at point " << i;
      ASSERT_NEAR(f[i], e, band);
    }
    EXPECT_GT(compared, 19000);
  }
}

TEST(SurfaceSdf, EqualsBruteForceAndIsDeterministicAcrossThreadCounts) {
  const TriangleSurface mesh = tessellate(ShapeKind::kTorus, 40);
  const SurfaceSdf sdf(mesh);
  auto pts = random_points(5000, -1.6, 1.6, 3);
  // Adversarial points: exactly on vertices, on edge midpoints and on face centroids.
  for (std::size_t t = 0; t < mesh.triangles.size(); t += 7) {
    const Vec3 a = mesh.vertices[mesh.triangles[t][0]], b = mesh.vertices[mesh.triangles[t][1]],
               c = mesh.vertices[mesh.triangles[t][2]];
    pts.push_back(a);
    pts.push_back(0.5 * (a + b));
    pts.push_back((a + b + c) / 3.0);
  }
  std::vector<double> fast(pts.size()), brute(pts.size()), one(pts.size());
  sdf.evaluate(pts, fast);
  brute_force_sdf(mesh, pts, brute);
  {
    ThreadLimit single(1);
    sdf.evaluate(pts, one);
  }
  for (std::size_t i = 0; i < pts.size(); ++i) {
    ASSERT_EQ(fast[i], brute[i]) << i;  // same nearest triangle, same arithmetic
    ASSERT_EQ(fast[i], one[i]) << i;
  }
  for (std::size_t i = 5000; i < pts.size(); ++i) EXPECT_LT(std::abs(fast[i]), 1e-12);
}

TEST(SurfaceSdf, AnswerIsIndependentOfBatchOrderAndSurvivesDegenerateTriangles) {
  // The search regroups a batch along a Morton curve and tests triangles against their plane and
  // edge lines before measuring them: neither may change a value. Zero-area triangles (a repeated
  // vertex, three collinear points) and a needle have no edge lines and must still be found.
  TriangleSurface mesh = tessellate(ShapeKind::kTorus, 24);
  const uint32_t a = mesh.triangles[0][0], b = mesh.triangles[0][1];
  const uint32_t mid = uint32_t(mesh.vertices.size());
  mesh.vertices.push_back(0.5 * (mesh.vertices[a] + mesh.vertices[b]));
  mesh.vertices.push_back(mesh.vertices[b] + Vec3{0, 0, 1e-9});
  mesh.vertices.push_back({0.3, 1.7, 0.2});  // a lone needle off the surface
  mesh.vertices.push_back({0.3, 1.7, 0.2 + 1e-12});
  mesh.triangles.push_back({a, a, b});
  mesh.triangles.push_back({a, mid, b});
  mesh.triangles.push_back({a, b, mid + 1});
  mesh.triangles.push_back({mid + 2, mid + 3, mid + 2});
  const SurfaceSdf sdf(mesh);
  std::vector<Vec3> grid;  // coherent points: whole packets of neighbours
  const int n = 19;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        grid.push_back(Vec3{-1.6, -1.6, -0.8} + (3.2 / (n - 1)) * Vec3{double(i), double(j), 0.5 * k});
  grid.push_back(mesh.vertices[mid + 2]);
  std::vector<uint32_t> perm(grid.size());
  std::iota(perm.begin(), perm.end(), 0u);
  std::shuffle(perm.begin(), perm.end(), std::mt19937(17));
  std::vector<Vec3> shuffled(grid.size());
  for (std::size_t i = 0; i < grid.size(); ++i) shuffled[i] = grid[perm[i]];
  std::vector<double> f(grid.size()), g(grid.size()), brute(grid.size());
  sdf.evaluate(grid, f);
  sdf.evaluate(shuffled, g);
  brute_force_sdf(mesh, grid, brute);
  for (std::size_t i = 0; i < grid.size(); ++i) {
    ASSERT_EQ(f[i], brute[i]) << i;
    ASSERT_EQ(g[i], f[perm[i]]) << i;
  }
  EXPECT_EQ(std::abs(f.back()), 0.0);  // on the needle
}

TEST(SurfaceSdf, FloatBoundsStayConservativeFarFromTheOrigin) {
  // Coordinates of 1e4 with details of 1e-2: the search tree's float boxes are coarse here, and
  // the per-query slack must keep every bound below the true distance. Brute force decides.
  TriangleSurface mesh = tessellate(ShapeKind::kTorus, 64);
  for (Vec3& v : mesh.vertices) v = v + Vec3{1e4, -2e4, 5e3};
  const SurfaceSdf sdf(mesh);
  auto pts = random_points(3000, -1.5, 1.5, 21);
  for (Vec3& p : pts) p = p + Vec3{1e4, -2e4, 5e3};
  for (int i = 0; i < 200; ++i) pts.push_back(pts[i] * 3.0);  // far away, and near the origin
  std::vector<double> fast(pts.size()), brute(pts.size());
  sdf.evaluate(pts, fast);
  brute_force_sdf(mesh, pts, brute);
  for (std::size_t i = 0; i < pts.size(); ++i) ASSERT_EQ(fast[i], brute[i]) << i;
}

TEST(SurfaceSdf, UnsignedDistanceIsTheMagnitude) {
  const TriangleSurface mesh = tessellate(ShapeKind::kSphere, 32);
  const SurfaceSdf sdf(mesh);
  const auto pts = random_points(2000, -2, 2, 5);
  std::vector<double> f(pts.size()), d(pts.size());
  sdf.evaluate(pts, f);
  sdf.distance(pts, d);
  for (std::size_t i = 0; i < pts.size(); ++i) EXPECT_EQ(std::abs(f[i]), d[i]);
}

TEST(SurfaceSdf, OpenAndNonManifoldSurfacesGiveFiniteValues) {
  // A unit cube with its top face missing, plus one extra fin on an edge (non-manifold).
  TriangleSurface s;
  s.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}, {0.5, -1, 0.5}};
  s.triangles = {{0, 2, 1}, {0, 3, 2}, {0, 1, 5}, {0, 5, 4}, {1, 2, 6}, {1, 6, 5},
                 {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}, {0, 1, 8}};
  const SurfaceSdf sdf(s);
  const auto pts = random_points(3000, -2, 3, 9);
  std::vector<double> f(pts.size());
  sdf.evaluate(pts, f);
  for (double v : f) EXPECT_TRUE(std::isfinite(v));
  // Deep inside the open box the nearest feature is still a correctly oriented wall.
  const std::vector<Vec3> centre{{0.5, 0.5, 0.3}};
  std::vector<double> fc(1);
  sdf.evaluate(centre, fc);
  EXPECT_NEAR(fc[0], 0.3, 1e-12);
}

TEST(ShapeSdf, ClosedFormValuesAtKnownPoints) {
  const ShapeSdf sphere(ShapeKind::kSphere), torus(ShapeKind::kTorus), box(ShapeKind::kRoundedBox),
      eight(ShapeKind::kTwoHoled);
  EXPECT_DOUBLE_EQ(sphere({0, 0, 0}), 1.0);
  EXPECT_DOUBLE_EQ(sphere({0, 3, 0}), -2.0);
  EXPECT_DOUBLE_EQ(torus({1, 0, 0}), 0.4);
  EXPECT_DOUBLE_EQ(torus({0, 0, 0}), 0.4 - 1.0);
  EXPECT_DOUBLE_EQ(torus({0, 0, 2}), 0.4 - std::sqrt(5.0));
  EXPECT_DOUBLE_EQ(box({0, 0, 0}), 0.5);
  EXPECT_DOUBLE_EQ(box({2, 0, 0}), -1.0);
  EXPECT_NEAR(box({1.5, 1.25, 0}), -(std::hypot(0.7, 0.7) - 0.2), 1e-15);
  EXPECT_DOUBLE_EQ(eight({1.2, 0, 0}), 0.25);        // on the core circle
  EXPECT_DOUBLE_EQ(eight({0.6, 0, 0}), 0.25 - 0.6);  // centre of the right hole
  EXPECT_LT(eight({-0.6, 0, 0}), 0);                 // centre of the left hole
  EXPECT_GT(eight({0, 0, 0}), 0);                    // the junction
}

TEST(ShapeSdf, OneLipschitzAndBoundsHoldTheSolid) {
  for (const auto& info : shape_catalog()) {
    const ShapeSdf shape(info.kind);
    const Box b = shape.bounds();
    const auto pts = random_points(20000, -2, 2, 17);
    std::mt19937_64 rng(1);
    std::normal_distribution<double> n(0, 0.05);
    for (const Vec3& p : pts) {
      const Vec3 q = p + Vec3{n(rng), n(rng), n(rng)};
      ASSERT_LE(std::abs(shape(p) - shape(q)), norm(p - q) * (1 + 1e-12)) << info.name;
      if (shape(p) > 0) {
        ASSERT_TRUE(b.contains(p)) << info.name;
      }
    }
  }
}

}  // namespace
}  // namespace mchex
