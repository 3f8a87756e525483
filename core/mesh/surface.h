// A triangle surface: the mesher's input. Indexed (welded) vertices and triangles, with the
// validation report that tells the user what kind of surface they gave us.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
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
  std::size_t welded_vertices = 0;       // duplicates merged by the reader's weld
  std::size_t edges = 0;
  std::size_t boundary_edges = 0;        // edges with one triangle (holes)
  std::size_t nonmanifold_edges = 0;     // edges with three or more triangles
  std::size_t degenerate_faces = 0;      // repeated vertex index or zero area
  std::size_t inconsistent_edges = 0;    // two-triangle edges traversed the same way by both
  std::size_t components = 0;            // connected by shared edges
  bool closed = false;                   // no boundary and no non-manifold edge
  bool consistently_oriented = false;
  double volume = 0;                     // signed volume (divergence theorem); > 0 means outward normals
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

}  // namespace mchex
