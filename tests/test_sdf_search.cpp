// The reference SDF's search (core/sdf/sdf.cpp) against the paper's brute-force loop, bit for bit, where
// its shortcuts are most exposed: exact ties at shared vertices and edges (every incident triangle
// at exactly the same distance; the lowest index must win, as in the loop), points far out in
// vertex regions (many nearly tied triangles, the float bounds' slack decides), flat faces split
// into many coplanar triangles (the least-area box frames), and answers that must not depend on
// which candidate a point starts from (batch composition and order).
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <numeric>
#include <random>

#include "core/sdf/sdf.h"
#include "core/sdf/shapes.h"

namespace mchex {
namespace {

// A closed cube [-1, 1]^3, each face an m x m grid of squares split along alternating diagonals,
// vertices shared (welded by their grid coordinates), triangles oriented outward.
TriangleSurface gridded_cube(int m) {
  TriangleSurface s;
  std::map<std::array<int, 3>, uint32_t> index;
  auto vertex = [&](std::array<int, 3> g) {
    auto [it, added] = index.try_emplace(g, uint32_t(s.vertices.size()));
    if (added) s.vertices.push_back({2.0 * g[0] / m - 1, 2.0 * g[1] / m - 1, 2.0 * g[2] / m - 1});
    return it->second;
  };
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;  // (u, v, axis) is right-handed
      for (int i = 0; i < m; ++i)
        for (int j = 0; j < m; ++j) {
          auto at = [&](int a, int b) {
            std::array<int, 3> g{};
            g[axis] = side * m, g[u] = a, g[v] = b;
            return vertex(g);
          };
          uint32_t q[4] = {at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)};  // counter-clockwise about +axis
          if (side == 0) std::swap(q[1], q[3]);  // the -axis face looks the other way
          if ((i + j) % 2) {
            s.triangles.push_back({q[0], q[1], q[2]});
            s.triangles.push_back({q[0], q[2], q[3]});
          } else {
            s.triangles.push_back({q[0], q[1], q[3]});
            s.triangles.push_back({q[1], q[2], q[3]});
          }
        }
    }
  return s;
}

// Every vertex and every edge midpoint, each also moved along its mean face normal by distances
// from 1e-9 to 3 (inside and out): exact ties at the feature itself, vertex and edge regions
// farther out.
std::vector<Vec3> feature_points(const TriangleSurface& s) {
  std::vector<Vec3> normal(s.vertices.size());
  std::map<std::pair<uint32_t, uint32_t>, Vec3> edges;
  for (const auto& t : s.triangles) {
    const Vec3 n = cross(s.vertices[t[1]] - s.vertices[t[0]], s.vertices[t[2]] - s.vertices[t[0]]);
    for (int k = 0; k < 3; ++k) {
      normal[t[k]] += n;
      edges[std::minmax(t[k], t[(k + 1) % 3])] += n;
    }
  }
  std::vector<Vec3> pts;
  const double offsets[] = {0, 1e-9, -1e-9, 0.01, -0.01, 0.2, -0.2, 3};
  auto add = [&](Vec3 p, Vec3 n) {
    for (double t : offsets) pts.push_back(p + t * normalized(n));
  };
  for (std::size_t v = 0; v < s.vertices.size(); ++v) add(s.vertices[v], normal[v]);
  for (const auto& [e, n] : edges) add(0.5 * (s.vertices[e.first] + s.vertices[e.second]), n);
  return pts;
}

// Both search trees (fitted boxes for repeated use; for one batch, axis-aligned boxes over leaves
// of four consecutive triangles) must give the loop's values bit for bit: the boxes and leaves
// only decide what is opened, never the answer.
void expect_brute_force_values(const TriangleSurface& mesh, const std::vector<Vec3>& pts) {
  std::vector<double> brute(pts.size());
  brute_force_sdf(mesh, pts, brute);
  for (const SearchUse use : {SearchUse::kRepeated, SearchUse::kOneBatchInFours}) {
    const SurfaceSdf sdf(mesh, SignRule::kPseudonormal, use);
    std::vector<double> fast(pts.size());
    sdf.evaluate(pts, fast);
    for (std::size_t i = 0; i < pts.size(); ++i)
      ASSERT_EQ(fast[i], brute[i]) << "point " << i << " (search use " << int(use) << ")";
  }
  // Fours with one short group at the end, which holds the mesh's own last triangle: a copy of
  // the first triangle (which changes no distance) goes in front.
  TriangleSurface uneven = mesh;
  uneven.triangles.insert(uneven.triangles.begin(), mesh.triangles.front());
  ASSERT_NE(uneven.triangles.size() % 4, 0u);
  const SurfaceSdf sdf(uneven, SignRule::kPseudonormal, SearchUse::kOneBatchInFours);
  std::vector<double> distance(pts.size());
  sdf.distance(pts, distance);
  for (std::size_t i = 0; i < pts.size(); ++i) ASSERT_EQ(distance[i], std::abs(brute[i])) << "point " << i;
}

TEST(SurfaceSdfSearch, ExactTiesAtSharedVerticesAndEdgesOfACurvedMesh) {
  const TriangleSurface torus = tessellate(ShapeKind::kTorus, 24);
  expect_brute_force_values(torus, feature_points(torus));
}

TEST(SurfaceSdfSearch, ExactTiesOnFlatFacesOfManyCoplanarTriangles) {
  const TriangleSurface cube = gridded_cube(9);
  auto pts = feature_points(cube);
  // A grid through the cube and around it: whole packets of neighbours, many of them directly
  // above the shared vertices and edges of a face.
  const int n = 23;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        pts.push_back(Vec3{-1.5, -1.5, -1.5} + (3.0 / (n - 1)) * Vec3{double(i), double(j), double(k)});
  expect_brute_force_values(cube, pts);
}

TEST(SurfaceSdfSearch, AnswersDoNotDependOnTheBatchAroundAPoint) {
  // Each point starts its search from a triangle another point of its batch found: alone, in
  // its grid batch, and in a shuffled batch it must get the same value.
  const TriangleSurface mesh = tessellate(ShapeKind::kTorus, 40);
  const SurfaceSdf sdf(mesh);
  std::vector<Vec3> grid;
  const int n = 17;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) grid.push_back(Vec3{-1.7, -1.7, -0.7} + Vec3{3.4 * i, 3.4 * j, 1.4 * k} / (n - 1));
  std::vector<double> whole(grid.size());
  sdf.evaluate(grid, whole);
  std::vector<uint32_t> perm(grid.size());
  std::iota(perm.begin(), perm.end(), 0u);
  std::shuffle(perm.begin(), perm.end(), std::mt19937(5));
  std::vector<Vec3> shuffled(grid.size());
  for (std::size_t i = 0; i < grid.size(); ++i) shuffled[i] = grid[perm[i]];
  std::vector<double> mixed(grid.size());
  sdf.evaluate(shuffled, mixed);
  for (std::size_t i = 0; i < grid.size(); ++i) ASSERT_EQ(mixed[i], whole[perm[i]]) << i;
  for (std::size_t i = 0; i < grid.size(); i += 7) {
    double alone = 0;
    sdf.evaluate(std::span(&grid[i], 1), std::span(&alone, 1));
    ASSERT_EQ(alone, whole[i]) << i;
  }
  std::vector<double> brute(grid.size());
  brute_force_sdf(mesh, grid, brute);
  for (std::size_t i = 0; i < grid.size(); ++i) ASSERT_EQ(whole[i], brute[i]) << i;
}

}  // namespace
}  // namespace mchex
