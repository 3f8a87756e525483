// A triangle surface: the mesher's input. Indexed (welded) vertices and triangles, with the
// validation report that tells the user what kind of surface they gave us.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <utility>
#include <vector>

#include "core/base/geometry.h"

namespace mchex {

struct TriangleSurface {
  std::vector<Vec3> vertices;
  std::vector<std::array<uint32_t, 3>> triangles;

  Box bounds() const;
};

// What validate_surface() found. A surface is "closed" when every edge has exactly two
// triangles; "consistently oriented" when each such pair traverses the edge in opposite
// directions. The reference SDF's sign is exact only for closed, consistently oriented input.
struct SurfaceReport {
  std::size_t vertices = 0;
  std::size_t triangles = 0;
  std::size_t welded_vertices = 0;  // duplicates merged by the reader's weld
  std::size_t edges = 0;
  std::size_t boundary_edges = 0;      // edges with one triangle (holes)
  std::size_t nonmanifold_edges = 0;   // edges with three or more triangles
  std::size_t degenerate_faces = 0;    // repeated vertex index or zero area
  std::size_t inconsistent_edges = 0;  // two-triangle edges traversed the same way by both
  std::size_t components = 0;          // connected by shared edges
  bool closed = false;                 // no boundary and no non-manifold edge
  bool consistently_oriented = false;
  double volume = 0;  // signed volume (divergence theorem); > 0 means outward normals
};

// Merges vertices with bit-identical coordinates (+0 and -0 are the same), drops nothing else.
// The first occurrence of each position keeps its value and the survivors keep their order, so
// the result depends only on the input. Returns how many vertices were merged.
std::size_t weld_vertices(TriangleSurface& surface);

// Triangles with a repeated vertex index count as degenerate and add no edges: welding collapses
// slivers to them, and their doubled edge would otherwise make a closed surface look
// non-manifold. They still join the component of their neighbours. An empty surface is not
// closed. The volume is taken about the centre of bounds() to keep far-off models accurate; it
// is origin-independent only for closed surfaces. welded_vertices is copied into the report
// (validate_surface cannot know what the reader merged). Throws InputError if a triangle
// refers to a vertex that does not exist.
SurfaceReport validate_surface(const TriangleSurface& surface, std::size_t welded_vertices = 0);

// ---------------------------------------------------------------------------------------------
// The edge table and volume that validate_surface() and repair_orientation()
// (core/mesh/orientation.h) both read, so that the two agree on what an edge, a boundary and a
// volume are.

// One triangle's use of an edge.
struct EdgeUse {
  uint32_t triangle = 0;
  bool forward = false;    // the triangle runs from the edge's smaller vertex to its larger
  bool collapsed = false;  // the triangle has a repeated vertex index: it only connects components
};

// Every edge of the surface with the triangles that use it, built by a counting sort on the
// smaller vertex (linear time). Edges come in increasing (smaller, larger) vertex order and each
// edge's uses in increasing triangle order, so everything derived from the table depends only on
// the input. A triangle with a repeated index contributes only its distinct-vertex edges.
struct SurfaceEdges {
  std::vector<std::array<uint32_t, 2>> vertices;  // edge e runs between vertices[e][0] < vertices[e][1]
  std::vector<std::size_t> first_use;             // edge e's uses are uses[first_use[e], first_use[e + 1])
  std::vector<EdgeUse> uses;

  std::size_t size() const { return vertices.size(); }
  std::span<const EdgeUse> uses_of(std::size_t e) const {
    return {uses.data() + first_use[e], uses.data() + first_use[e + 1]};
  }
};

// Throws InputError for a vertex index out of range and ResourceError from
// kMaxEdgeTableTriangles (the packing of its sort keys).
SurfaceEdges surface_edges(const TriangleSurface& surface);
inline constexpr std::size_t kMaxEdgeTableTriangles = std::size_t{1} << 30;
void check_surface_indices(const TriangleSurface& surface);  // the InputError above
void check_edge_table_size(const TriangleSurface& surface);  // the ResourceError above

// Union-find; the smaller index becomes the root so the forest (and anything derived from it
// later) does not depend on the order the unions come in.
struct DisjointSets {
  std::vector<uint32_t> parent;
  explicit DisjointSets(std::size_t n);
  uint32_t find(uint32_t x) {
    while (parent[x] != x) {
      parent[x] = parent[parent[x]];
      x = parent[x];
    }
    return x;
  }
  void unite(uint32_t a, uint32_t b) {
    a = find(a);
    b = find(b);
    if (a == b) return;
    if (a < b) std::swap(a, b);
    parent[a] = b;
  }
};

// Signed volume (divergence theorem) of the listed triangles about `origin`, with a compensated
// sum in list order; triangles with a repeated vertex index add nothing.
double signed_volume(const TriangleSurface& surface, std::span<const uint32_t> triangles, Vec3 origin);

}  // namespace mchex
