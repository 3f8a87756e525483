// The certified optimiser (core/optimize/optimize.h) and the input's feature curves (core/mesh/
// feature_curves.h). References: a distorted regular grid (whose optimum, the undistorted grid,
// has scaled Jacobian 1 everywhere), the analytic sphere |p| = 1, a box's twelve edges and eight
// corners, every-triangle closest points, every-segment nearest points, and the mesh checker for
// certificates and conformity.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <map>
#include <random>
#include <span>
#include <tuple>
#include <vector>

#include "core/base/parallel.h"
#include "core/check/mesh_check.h"
#include "core/cutting/mchex_mesher.h"
#include "core/grid/grid.h"
#include "core/mesh/feature_curves.h"
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

// Outside points with an inside point at the same coordinates: the interface, shared bit for bit.
std::size_t interface_points(const MeshPair& pair) {
  const auto in = coordinate_set(pair.inside.points);
  std::size_t shared = 0;
  for (const Vec3& x : pair.outside.points) shared += in.count({x.x, x.y, x.z});
  return shared;
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
  EXPECT_EQ(interface_points(pair), interface_points(original));
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

// The boundary snap (snap_boundary): the analytic sphere's boundary moves onto |p| = 1 where the
// hexes allow it, each hex stays certified and within the limits (its scaled Jacobian at least
// min(its own, floor), its edge ratio at most max(its own, max_edge_ratio)), the hexes and the
// interface are kept, and the boundary comes nearer the sphere; by default most of it reaches it.
TEST(Snap, BoundaryGoesOntoTheSphereKeepingCertificatesAndLimits) {
  for (const SnapLimits limits : {SnapLimits{}, kSnapKeepingQuality})
    for (int depth : {2, 3}) {
      SCOPED_TRACE(testing::Message() << "depth " << depth << " floor " << limits.floor);
      MeshPair pair = sphere_pair(depth);
      const MeshPair original = pair;
      const ShapeSdf sdf(ShapeKind::kSphere);
      const SnapStats st = snap_boundary(pair, sdf, limits);
      ASSERT_EQ(pair.inside.hexes, original.inside.hexes);
      ASSERT_EQ(pair.outside.hexes, original.outside.hexes);
      std::vector<uint8_t> on(pair.inside.points.size(), 0);
      for (const auto& q : boundary_quads(pair.inside))
        for (uint32_t v : q) on[v] = 1;
      std::size_t boundary = 0, on_sphere = 0, moved = 0;
      double sum_before = 0, sum_after = 0;
      for (std::size_t v = 0; v < on.size(); ++v) {
        const Vec3 a = original.inside.points[v], b = pair.inside.points[v];
        if (!on[v]) {
          EXPECT_EQ(a, b) << "an interior vertex moved";
          continue;
        }
        ++boundary;
        moved += !(a == b);
        on_sphere += std::abs(norm(b) - 1) < 1e-9;
        sum_before += std::abs(norm(a) - 1);
        sum_after += std::abs(norm(b) - 1);
      }
      EXPECT_EQ(st.vertices, boundary);
      EXPECT_EQ(st.moved + st.partly + st.stayed, boundary);
      EXPECT_EQ(st.moved + st.partly, moved);
      EXPECT_GE(on_sphere, st.moved);
      EXPECT_GT(st.moved + st.partly, 0u);
      EXPECT_LT(sum_after, sum_before);
      if (limits.floor == kSnapFloor) {  // keeping quality, a sliver of 1e-3 of a cell holds its vertices
        EXPECT_GT(st.moved, boundary / 2);
        EXPECT_LT(sum_after, 0.5 * sum_before);
      }
      for (const auto* m : {&pair.inside, &pair.outside})
        for (std::size_t h = 0; h < m->hexes.size(); ++h) {
          const HexCorners x0 = (m == &pair.inside ? original.inside : original.outside).corners(h);
          const HexCorners x = m->corners(h);
          ASSERT_TRUE(bernstein_certified(x)) << h;
          ASSERT_GE(scaled_jacobian(x), std::min(scaled_jacobian(x0), limits.floor)) << h;
          ASSERT_LE(edge_ratio(x), std::max(edge_ratio(x0), limits.max_edge_ratio)) << h;
        }
      // The outside mesh's points on the interface moved with the inside ones.
      EXPECT_EQ(interface_points(pair), interface_points(original));
      const MeshCheck c = check_mesh(pair.inside, &pair.outside, nullptr);
      EXPECT_TRUE(c.ok) << (c.errors.empty() ? "" : c.errors.front());
    }
}

TEST(Snap, SameResultOnOneAndTwoThreads) {
  const ShapeSdf sdf(ShapeKind::kSphere);
  MeshPair a = sphere_pair(3), b = a;
  SnapStats sa, sb;
  {
    const ThreadLimit one(1);
    sa = snap_boundary(a, sdf);
  }
  {
    const ThreadLimit two(2);
    sb = snap_boundary(b, sdf);
  }
  EXPECT_EQ(sa.moved, sb.moved);
  EXPECT_EQ(sa.partly, sb.partly);
  ASSERT_EQ(a.inside.points, b.inside.points);
  ASSERT_EQ(a.outside.points, b.outside.points);
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

// An axis-aligned box of half sides `half` about `centre`, two triangles a face, outward.
TriangleSurface box_surface(Vec3 centre, Vec3 half) {
  TriangleSurface s;
  for (int k = 0; k < 8; ++k)
    s.vertices.push_back(centre +
                         Vec3{(k & 1 ? 1 : -1) * half.x, (k & 2 ? 1 : -1) * half.y, (k & 4 ? 1 : -1) * half.z});
  // Faces as corner bit patterns, counter-clockwise seen from outside.
  const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces) {
    s.triangles.push_back({uint32_t(f[0]), uint32_t(f[1]), uint32_t(f[2])});
    s.triangles.push_back({uint32_t(f[0]), uint32_t(f[2]), uint32_t(f[3])});
  }
  return s;
}

TEST(FeatureCurves, BoxHasTwelveEdgesAndEightCornersASphereNone) {
  const TriangleSurface box = box_surface({0.1, 0.2, 0.3}, {1, 0.75, 0.5});
  const FeatureCurves f(box, 40);
  EXPECT_EQ(f.sharp_edges(), 12u);  // the face diagonals are flat
  EXPECT_EQ(f.corners(), 8u);
  EXPECT_EQ(f.curves(), 12u);  // every edge ends at two corners
  // A flipped triangle pair still reads as flat: orientation is taken into account.
  TriangleSurface flipped = box;
  std::swap(flipped.triangles[0][1], flipped.triangles[0][2]);
  std::swap(flipped.triangles[1][1], flipped.triangles[1][2]);
  EXPECT_EQ(FeatureCurves(flipped, 40).sharp_edges(), 12u);
  EXPECT_TRUE(FeatureCurves(tessellate(ShapeKind::kSphere, 48), 40).empty());
  EXPECT_TRUE(FeatureCurves(box, 95).empty());
}

TEST(FeatureCurves, NearestPointMatchesEverySegment) {
  const TriangleSurface box = box_surface({0, 0, 0}, {1, 0.75, 0.5});
  const FeatureCurves f(box, 40);
  // The box's edges (from the corner bit patterns that differ in one bit).
  std::vector<std::array<Vec3, 2>> edges;
  for (int a = 0; a < 8; ++a)
    for (int b = a + 1; b < 8; ++b)
      if (std::popcount(unsigned(a ^ b)) == 1) edges.push_back({box.vertices[a], box.vertices[b]});
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> d(-1.5, 1.5);
  for (int i = 0; i < 300; ++i) {
    const Vec3 p{d(rng), d(rng), d(rng)};
    double best = INFINITY;
    for (const auto& e : edges) {
      const Vec3 u = e[1] - e[0];
      const double t = std::clamp(dot(p - e[0], u) / dot(u, u), 0.0, 1.0);
      best = std::min(best, squared_norm(p - (e[0] + t * u)));
    }
    const FeatureCurves::Nearest n = f.nearest(p);
    ASSERT_NE(n.curve, FeatureCurves::kAnyCurve);
    EXPECT_NEAR(n.squared_distance, best, 1e-12);
    EXPECT_NEAR(squared_norm(p - n.point), n.squared_distance, 1e-12);
    EXPECT_NEAR(std::abs(n.tangent.x) + std::abs(n.tangent.y) + std::abs(n.tangent.z), 1, 1e-12);
    // On its own curve the point is the same; within a radius below the distance, none.
    EXPECT_EQ(f.nearest(p, n.curve).point, n.point);
    EXPECT_EQ(f.nearest(p, FeatureCurves::kAnyCurve, 0.99 * std::sqrt(best)).curve, FeatureCurves::kAnyCurve);
    double corner = INFINITY;
    for (const Vec3& c : box.vertices) corner = std::min(corner, squared_norm(p - c));
    EXPECT_NEAR(f.nearest(p, FeatureCurves::kCorner).squared_distance, corner, 1e-12);
  }
}

// A closed surface meshed on a uniform grid at the optimiser's clamp.
MeshPair surface_pair(const TriangleSurface& surface, int depth) {
  const SurfaceSdf sdf(surface);
  const UniformGrid grid(padded_cube(sdf.bounds(), 0.1), depth);
  const std::vector<Vec3> points = grid.vertices();
  std::vector<double> v(points.size());
  sdf.evaluate(points, v);
  return mesh_mchex(grid, v, kOptimizeEps, nullptr);
}

// A closed prism over a regular n-gon of radius r, from z = -h to h, outward.
TriangleSurface prism_surface(int n, double r, double h) {
  TriangleSurface s;
  for (int k = 0; k < n; ++k) {
    const double a = 2 * M_PI * (k + 0.3) / n;
    s.vertices.push_back({r * std::cos(a), r * std::sin(a), -h});
    s.vertices.push_back({r * std::cos(a), r * std::sin(a), h});
  }
  s.vertices.push_back({0, 0, -h});
  s.vertices.push_back({0, 0, h});
  const uint32_t lo = uint32_t(2 * n), hi = lo + 1;
  for (int k = 0; k < n; ++k) {
    const uint32_t a0 = uint32_t(2 * k), a1 = a0 + 1, b0 = uint32_t(2 * ((k + 1) % n)), b1 = b0 + 1;
    s.triangles.push_back({a0, b0, b1});
    s.triangles.push_back({a0, b1, a1});
    s.triangles.push_back({lo, b0, a0});
    s.triangles.push_back({hi, a1, b1});
  }
  return s;
}

// A pentagonal prism on a grid it is not aligned with: its boundary folds along the prism's
// edges, the input's feature curves (108 and 90 degrees there; the mesh's folds are softer).
TEST(Optimize, FeatureVerticesApproachAndSlideAlongThePrismEdges) {
  const TriangleSurface prism = prism_surface(5, 1, 0.6);
  const SurfaceSdf sdf(prism);
  MeshPair pair = surface_pair(prism, 3);
  const MeshPair original = pair;
  const OptimizeStats s = optimize(pair, &sdf, {}, &prism);
  EXPECT_EQ(s.feature_edges, 15u);
  EXPECT_EQ(s.feature_curves, 15u);  // each ends at two of the ten corners
  EXPECT_GT(s.curve_vertices, 0u);
  EXPECT_GT(s.snapped_vertices, 0u);
  EXPECT_EQ(s.fixed_vertices, 8u);  // the corners of the outer box; no boundary vertex
  EXPECT_GE(s.min_sj_after, s.min_sj_before);
  EXPECT_EQ(s.certified_after, s.hexes);
  // Every boundary vertex that moved is on the prism, or (one the mesher put off it, moved by the
  // search) no farther from it than it was; at least the snapped ones are on an edge.
  const FeatureCurves f(prism, 40);
  std::vector<double> distance(1), distance_before(1);
  std::vector<uint8_t> boundary(pair.inside.points.size(), 0);
  for (const auto& q : boundary_quads(pair.inside))
    for (uint32_t v : q) boundary[v] = 1;
  std::size_t moved = 0, on_edges = 0, on_surface = 0;
  for (uint32_t v = 0; v < boundary.size(); ++v) {
    const Vec3 x = pair.inside.points[v];
    if (!boundary[v] || x == original.inside.points[v]) continue;
    ++moved;
    on_edges += f.nearest(x).squared_distance < 1e-24;
    sdf.distance(std::span<const Vec3>(&x, 1), distance);
    sdf.distance(std::span<const Vec3>(&original.inside.points[v], 1), distance_before);
    EXPECT_TRUE(distance[0] < 1e-12 || distance[0] <= distance_before[0]) << distance[0] << " " << distance_before[0];
    on_surface += distance[0] < 1e-12;
  }
  EXPECT_GT(moved, 0u);
  EXPECT_GT(on_surface, moved * 9 / 10);
  EXPECT_GE(on_edges, s.snapped_vertices);
  // Without the input's triangles there are no features, and no boundary vertex is held.
  MeshPair plain = original;
  const OptimizeStats t = optimize(plain, &sdf, {});
  EXPECT_EQ(t.feature_vertices, 0u);
  EXPECT_EQ(t.fixed_vertices, 8u);
}

// A feature vertex already on its target counts as snapped before any move: the vertices a first
// run put on the prism's edges and corners are snapped in a second run of no sweeps. (Were they
// not, the rule that keeps a snapping vertex from moving away from its target would hold them
// where they are for good.)
TEST(Optimize, VerticesAlreadyOnTheirFeatureAreSnappedFromTheStart) {
  const TriangleSurface prism = prism_surface(5, 1, 0.6);
  const SurfaceSdf sdf(prism);
  MeshPair pair = surface_pair(prism, 3);
  const OptimizeStats first = optimize(pair, &sdf, {}, &prism);
  ASSERT_GT(first.snapped_vertices, 0u);
  OptimizeOptions none;
  none.max_sweeps = 0;
  none.ratio_sweeps = 0;
  const MeshPair optimized = pair;
  const OptimizeStats again = optimize(pair, &sdf, none, &prism);
  EXPECT_GE(again.snapped_vertices, first.snapped_vertices);
  EXPECT_LE(again.snapped_vertices, again.feature_vertices);
  for (std::size_t i = 0; i < pair.inside.points.size(); ++i)
    ASSERT_EQ(pair.inside.points[i], optimized.inside.points[i]);
}

TEST(Optimize, SameResultOnOneAndTwoThreadsWithFeatures) {
  const TriangleSurface prism = prism_surface(5, 1, 0.6);
  const SurfaceSdf sdf(prism);
  MeshPair a = surface_pair(prism, 3), b = a;
  OptimizeStats sa, sb;
  {
    const ThreadLimit one(1);
    sa = optimize(a, &sdf, {}, &prism);
  }
  {
    const ThreadLimit two(2);
    sb = optimize(b, &sdf, {}, &prism);
  }
  EXPECT_EQ(sa.moves_accepted, sb.moves_accepted);
  EXPECT_EQ(sa.curve_vertices, sb.curve_vertices);
  EXPECT_EQ(sa.snapped_vertices, sb.snapped_vertices);
  for (std::size_t i = 0; i < a.inside.points.size(); ++i) ASSERT_EQ(a.inside.points[i], b.inside.points[i]) << i;
  for (std::size_t i = 0; i < a.outside.points.size(); ++i) ASSERT_EQ(a.outside.points[i], b.outside.points[i]) << i;
}

}  // namespace
// FNV-1a over the bits of every point of the pair.
uint64_t fingerprint(const MeshPair& m) {
  uint64_t f = 1469598103934665603ull;
  for (const HexMesh* mesh : {&m.inside, &m.outside})
    for (const Vec3& p : mesh->points) {
      unsigned char bytes[sizeof p];
      std::memcpy(bytes, &p, sizeof p);
      for (unsigned char c : bytes) f = (f ^ c) * 1099511628211ull;
    }
  return f;
}

// The second phase visits a vertex that shares no hex with a surface vertex only when one of its
// hexes is below search_active_below: with that bound at 0, every such vertex keeps the position
// the plain sweeps gave it, while the surface's vertices and their neighbours go on moving; and
// the guarantees hold with any bound.
TEST(Optimize, SecondPhaseVisitsInteriorVerticesOnlyBelowItsBound) {
  const ShapeSdf sdf(ShapeKind::kSphere);
  const MeshPair start = sphere_pair(3);
  // Coordinates of the inside boundary's vertices (the interface, the same in both meshes).
  std::map<std::tuple<double, double, double>, int> surface;
  for (const auto& q : boundary_quads(start.inside))
    for (uint32_t v : q) surface[{start.inside.points[v].x, start.inside.points[v].y, start.inside.points[v].z}] = 1;
  auto beside = [&](const HexMesh& m) {
    std::vector<uint8_t> b(m.points.size(), 0);
    for (const Hex& h : m.hexes) {
      bool touches = false;
      for (uint32_t v : h) touches = touches || surface.count({m.points[v].x, m.points[v].y, m.points[v].z});
      if (touches)
        for (uint32_t v : h) b[v] = 1;
    }
    return b;
  };
  const std::vector<uint8_t> beside_in = beside(start.inside), beside_out = beside(start.outside);

  OptimizeOptions plain;
  plain.search = false;
  MeshPair first = start;
  const OptimizeStats p = optimize(first, &sdf, plain);
  ASSERT_LT(p.sweeps, plain.max_sweeps);  // the plain sweeps stalled: the second phase follows them

  OptimizeOptions none;
  none.search_active_below = 0;
  none.ratio_sweeps = 0;  // the third phase moves interior vertices above the edge-ratio cap
  MeshPair both = start;
  const OptimizeStats s = optimize(both, &sdf, none);
  EXPECT_EQ(s.plain_sweeps, p.sweeps);
  EXPECT_GT(s.sweeps, s.plain_sweeps);
  std::size_t interior = 0, moved_beside = 0;
  for (int mesh = 0; mesh < 2; ++mesh) {
    const HexMesh &a = mesh ? first.outside : first.inside, &b = mesh ? both.outside : both.inside;
    const std::vector<uint8_t>& near = mesh ? beside_out : beside_in;
    for (std::size_t v = 0; v < a.points.size(); ++v) {
      if (near[v]) {
        moved_beside += !(a.points[v] == b.points[v]);
        continue;
      }
      ++interior;
      ASSERT_EQ(a.points[v], b.points[v]) << (mesh ? "outside " : "inside ") << v;
    }
  }
  EXPECT_GT(interior, 0u);
  EXPECT_GT(moved_beside, 0u);  // the second phase did move vertices at the surface
  EXPECT_GE(s.min_sj_after, p.min_sj_after);
  EXPECT_EQ(s.certified_after, s.hexes);

  // The default bound: interior vertices below it move too, and the result is never below the
  // plain sweeps' own.
  MeshPair dflt = start;
  const OptimizeStats d = optimize(dflt, &sdf, {});
  EXPECT_EQ(d.plain_sweeps, p.sweeps);
  EXPECT_GE(d.min_sj_after, p.min_sj_after);
  EXPECT_EQ(d.certified_after, d.hexes);
}

// The third phase lowers the edge ratios above the cap: against the same run without it (the first
// two phases are the same), every hex's ratio is at most max(cap, what it was), fewer hexes are
// above the cap, no hex falls below the pair's minimum it started from, and every hex keeps its
// certificate. Uniform depth-3 sphere, cap 8.3 (Awad et al.'s shortest-over-longest 0.12).
TEST(Optimize, EdgeRatioPhaseLowersTheRatiosAboveTheCap) {
  const ShapeSdf sdf(ShapeKind::kSphere);
  const MeshPair start = sphere_pair(3);
  OptimizeOptions without;
  without.max_edge_ratio = 8.3;
  without.ratio_sweeps = 0;
  OptimizeOptions with = without;
  with.ratio_sweeps = 20;
  MeshPair a = start, b = start;
  const OptimizeStats sa = optimize(a, &sdf, without);
  const OptimizeStats sb = optimize(b, &sdf, with);
  EXPECT_EQ(sa.ratio_sweeps, 0);
  EXPECT_GT(sb.ratio_sweeps, 0);
  EXPECT_EQ(sb.sweeps - sb.ratio_sweeps, sa.sweeps);
  ASSERT_GT(sa.above_edge_ratio_cap_after, 0u);
  EXPECT_LT(sb.above_edge_ratio_cap_after, sa.above_edge_ratio_cap_after);
  EXPECT_LE(sb.max_edge_ratio_after, sa.max_edge_ratio_after);
  EXPECT_GE(sb.min_sj_after, sa.min_sj_after);
  EXPECT_EQ(sb.certified_after, sb.hexes);
  std::size_t above_a = 0, above_b = 0;
  for (int mesh = 0; mesh < 2; ++mesh) {
    const HexMesh &ma = mesh ? a.outside : a.inside, &mb = mesh ? b.outside : b.inside;
    for (std::size_t h = 0; h < ma.hexes.size(); ++h) {
      const double ra = edge_ratio(ma.corners(h)), rb = edge_ratio(mb.corners(h));
      EXPECT_LE(rb, std::max(8.3, ra)) << (mesh ? "outside " : "inside ") << h;
      EXPECT_GE(scaled_jacobian(mb.corners(h)), sa.min_sj_after);
      above_a += ra > 8.3 * (1 + 1e-9);
      above_b += rb > 8.3 * (1 + 1e-9);
    }
  }
  EXPECT_EQ(above_a, sa.above_edge_ratio_cap_after);
  EXPECT_EQ(above_b, sb.above_edge_ratio_cap_after);
}

// The sweeps measure candidates with MovingCorner (a hex's unchanged points kept per visit), stop
// at the first hex below the floor, measure first the hex that refused the last candidate and take
// the visit's current measures from the cached per-hex values. None of it may change a bit of the
// result: the fingerprints below are those of the full evaluation (every hex's 9 points recomputed
// for every candidate, main at feeec23, whose optimiser had the plain sweeps only, 30 at most:
// the options below; its mesher given exact_lerp, geometry.h, as the input meshes have it), on a distorted grid (no
// surface), a sphere pair (surface vertices projected) and a prism pair (feature vertices snapping to the input's
// edges). The search phase measures its steps by the same evaluation.
TEST(Optimize, SameResultAsTheFullEvaluation) {
  OptimizeOptions plain;
  plain.search = false;
  plain.max_sweeps = 30;
  MeshPair grid;
  grid.inside = distorted_grid(6, 0.3, 41);
  optimize(grid, nullptr, plain);
  const ShapeSdf sdf(ShapeKind::kSphere);
  MeshPair sphere = sphere_pair(2);
  optimize(sphere, &sdf, plain);
  const TriangleSurface prism = prism_surface(5, 1, 0.6);
  const SurfaceSdf exact(prism);
  MeshPair features = surface_pair(prism, 3);
  optimize(features, &exact, plain, &prism);
  EXPECT_EQ(fingerprint(grid), 14097049714018974509ull);
  EXPECT_EQ(fingerprint(sphere), 15853101348634749541ull);
  EXPECT_EQ(fingerprint(features), 13207845689400264431ull);
}

}  // namespace mchex
