// core/grid/complex_topology.h against a direct reading of its contract: edges and faces numbered in
// the ascending order of their point sets, every cell's entries naming them, the owner the
// lowest cell around, a face's points in the stated cyclic order; and the errors. The reference
// here groups with std::map, independently of the counting sort the implementation uses.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <numeric>
#include <random>
#include <stdexcept>
#include <vector>

#include "core/cutting/mc33.h"
#include "core/grid/complex_topology.h"
#include "core/grid/grid.h"
#include "core/grid/octree.h"
#include "core/mesh/hex_faces.h"

namespace mchex {
namespace {

void expect_topology_is_the_reference(const HexComplex& cx, const ComplexTopology& t) {
  using Edge = std::array<std::uint32_t, 2>;
  using Face = std::array<std::uint32_t, 4>;
  std::map<Edge, std::vector<std::pair<std::uint32_t, int>>> edges;  // (cell, local) in cell order
  std::map<Face, std::vector<std::pair<std::uint32_t, int>>> faces;
  for (std::uint32_t c = 0; c < cx.cells.size(); ++c) {
    for (int e = 0; e < 12; ++e) {
      Edge k = {cx.cells[c][kCubeEdges[e][0]], cx.cells[c][kCubeEdges[e][1]]};
      std::sort(k.begin(), k.end());
      edges[k].push_back({c, e});
    }
    for (int f = 0; f < 6; ++f) {
      Face k;
      for (int i = 0; i < 4; ++i) k[i] = cx.cells[c][kHexFaces[f][i]];
      std::sort(k.begin(), k.end());
      faces[k].push_back({c, f});
    }
  }
  ASSERT_EQ(t.edge_points.size(), edges.size());
  ASSERT_EQ(t.face_points.size(), faces.size());
  std::uint32_t id = 0;
  for (const auto& [k, users] : edges) {
    EXPECT_EQ(t.edge_points[id], k);
    EXPECT_EQ(t.edge_owner[id], users.front().first);
    for (const auto& [c, e] : users) EXPECT_EQ(t.cell_edges[c][e], id);
    ++id;
  }
  id = 0;
  for (const auto& [k, users] : faces) {
    const auto [owner, local] = users.front();
    EXPECT_EQ(t.face_owner[id], owner);
    EXPECT_EQ(t.face_cells[id], users.size());
    for (const auto& [c, f] : users) EXPECT_EQ(t.cell_faces[c][f], id);
    // The owner's cycle, from the lowest point, towards the lower of its two neighbours.
    Face q;
    for (int i = 0; i < 4; ++i) q[i] = cx.cells[owner][kHexFaces[local][i]];
    std::rotate(q.begin(), std::min_element(q.begin(), q.end()), q.end());
    if (q[3] < q[1]) std::swap(q[1], q[3]);
    EXPECT_EQ(t.face_points[id], q);
    ++id;
  }
}

TEST(complex_topology, UniformGridMatchesTheReference) {
  const UniformGrid grid(Box{{0, 0, 0}, {1, 1, 1}}, 2);
  const HexComplex cx = uniform_complex(grid);
  expect_topology_is_the_reference(cx, build_topology(cx));
}

TEST(complex_topology, AdaptiveTemplatesAndShuffledPointsMatchTheReference) {
  // Node, edge and face templates around a refined centre: cells of several shapes and sizes.
  Octree tree(Box{{0, 0, 0}, {1, 1, 1}}, 2);
  tree.refine(0, octree_key(0, 0, 0));
  tree.refine(1, octree_key(1, 1, 1));
  HexComplex cx = build_adaptive_complex(tree).complex;
  expect_topology_is_the_reference(cx, build_topology(cx));
  // Point ids in a random order: buckets of every size, and ties broken by the cell.
  std::vector<std::uint32_t> perm(cx.points.size());
  std::iota(perm.begin(), perm.end(), 0u);
  std::shuffle(perm.begin(), perm.end(), std::mt19937_64(7));
  for (auto& cell : cx.cells)
    for (auto& p : cell) p = perm[p];
  expect_topology_is_the_reference(cx, build_topology(cx));
}

TEST(complex_topology, BrokenComplexesAreRefused) {
  const UniformGrid grid(Box{{0, 0, 0}, {1, 1, 1}}, 1);
  const HexComplex good = uniform_complex(grid);
  HexComplex repeated = good;
  repeated.cells[5][3] = repeated.cells[5][0];
  EXPECT_THROW(build_topology(repeated), std::invalid_argument);
  HexComplex past_the_end = good;
  past_the_end.cells[26][7] = static_cast<std::uint32_t>(good.points.size());
  EXPECT_THROW(build_topology(past_the_end), std::invalid_argument);
  HexComplex three_on_a_face = good;
  three_on_a_face.cells.push_back(good.cells[13]);
  EXPECT_THROW(build_topology(three_on_a_face), std::invalid_argument);
}

}  // namespace
}  // namespace mchex
