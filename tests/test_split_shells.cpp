// split_shells (core/pipeline/regions.h), the shells of one file as regions: exact on small
// hand-made surfaces whose components are known (tetrahedra touching at a vertex and along an
// edge, an open strip, shells listed interleaved).
#include <gtest/gtest.h>

#include <array>
#include <vector>

#include "core/pipeline/regions.h"

namespace mchex {
namespace {

// A tetrahedron on four given vertex ids of `s` (outward when the ids' points are).
void tetrahedron(TriangleSurface& s, uint32_t a, uint32_t b, uint32_t c, uint32_t d) {
  s.triangles.push_back({a, c, b});
  s.triangles.push_back({a, b, d});
  s.triangles.push_back({b, c, d});
  s.triangles.push_back({c, a, d});
}

TEST(SplitShells, TetrahedraTouchingAtAVertexOrAlongAnEdgeStayApart) {
  TriangleSurface s;
  s.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}, {1, 1, 1}, {1, 1, -1}};
  tetrahedron(s, 0, 1, 2, 3);  // shell 1
  tetrahedron(s, 0, 4, 5, 6);  // touches shell 1 at vertex 0
  tetrahedron(s, 1, 2, 7, 8);  // shares shell 1's edge 1-2 (in four triangles: not manifold)
  const std::vector<TriangleSurface> shells = split_shells(s);
  ASSERT_EQ(shells.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(shells[i].triangles.size(), 4u);
    EXPECT_EQ(shells[i].vertices.size(), 4u);
    // The same triangles, in file order, through the shell's own vertex ids.
    for (std::size_t t = 0; t < 4; ++t)
      for (int k = 0; k < 3; ++k)
        EXPECT_EQ(shells[i].vertices[shells[i].triangles[t][k]], s.vertices[s.triangles[4 * i + t][k]]);
  }
}

TEST(SplitShells, InterleavedShellsComeInTheOrderOfTheirFirstTriangle) {
  TriangleSurface a, s;
  a.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {5, 0, 0}, {6, 0, 0}, {5, 1, 0}, {5, 0, 1}};
  tetrahedron(a, 4, 5, 6, 7);
  tetrahedron(a, 0, 1, 2, 3);
  s.vertices = a.vertices;
  for (int t = 0; t < 4; ++t) {  // alternate: second shell's triangle first
    s.triangles.push_back(a.triangles[4 + t]);
    s.triangles.push_back(a.triangles[t]);
  }
  const std::vector<TriangleSurface> shells = split_shells(s);
  ASSERT_EQ(shells.size(), 2u);
  EXPECT_EQ(shells[0].vertices[0], (Vec3{0, 0, 0}));
  EXPECT_EQ(shells[1].vertices[0], (Vec3{5, 0, 0}));
}

TEST(SplitShells, TrianglesJoinedByBoundaryEdgesOnlyAreSeparate) {
  // Two triangles of an open strip share an edge: manifold, one component; a third meeting them
  // only at a vertex is another.
  TriangleSurface s;
  s.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {2, 2, 0}, {2, 1, 0}};
  s.triangles = {{0, 1, 2}, {1, 3, 2}, {3, 5, 4}};
  const std::vector<TriangleSurface> shells = split_shells(s);
  ASSERT_EQ(shells.size(), 2u);
  EXPECT_EQ(shells[0].triangles.size(), 2u);
  EXPECT_EQ(shells[1].triangles.size(), 1u);
}

}  // namespace
}  // namespace mchex
