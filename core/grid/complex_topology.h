// The edges and faces of a HexComplex, numbered once, so that everything the mesher puts on a
// shared edge or face (a crossing, an edge midpoint, a face-piece centroid) has one global name
// that every cell around it computes without a hash lookup, and one owner cell that writes its
// coordinates (the lowest-numbered cell around it), which keeps the parallel mesher
// deterministic: a shared point's coordinates never depend on which thread got there first.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/grid/hex_complex.h"

namespace mchex {

struct ComplexTopology {
  // Edge e joins points edge_points[e][0] < edge_points[e][1].
  std::vector<std::array<std::uint32_t, 2>> edge_points;
  // Face f's 4 points in cyclic order, starting at its lowest point id and going on towards the
  // lower of that point's two face neighbours: the same list from both cells beside the face.
  std::vector<std::array<std::uint32_t, 4>> face_points;
  // Per cell: its 12 edges (core/cutting/mc33.h kCubeEdges order) and 6 faces (core/mesh/hex_faces.h order).
  std::vector<std::array<std::uint32_t, 12>> cell_edges;
  std::vector<std::array<std::uint32_t, 6>> cell_faces;
  // The lowest cell id around each edge / face.
  std::vector<std::uint32_t> edge_owner, face_owner;
  // Per face: how many cells have it (1 on the boundary of the complex, 2 inside; more means the
  // complex is not conforming, and build_topology throws).
  std::vector<std::uint8_t> face_cells;
};

// Numbers edges and faces by sorting the cells' (point-pair / point-quad, cell) entries: ids
// follow the sorted order, so they depend on the complex alone, never on the thread count.
// Throws std::invalid_argument when a face is shared by more than two cells, a cell repeats a
// point or names one past the complex's points.
ComplexTopology build_topology(const HexComplex& complex);

// Position of point p in face_points[f] (0..3); -1 if p is not on the face.
inline int face_rank(const ComplexTopology& t, std::uint32_t f, std::uint32_t p) {
  for (int r = 0; r < 4; ++r)
    if (t.face_points[f][r] == p) return r;
  return -1;
}

}  // namespace mchex
