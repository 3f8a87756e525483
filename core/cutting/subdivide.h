// Midpoint subdivision of a 3-regular polyhedron into hexes (Tong & Zhang 2025, Definition 4.3
// and Theorem 4.1): one hex per vertex v, with corners v, the midpoints of v's 3 edges, the
// centroids (vertex means) of v's 3 faces and the volume centre (the mean of all vertices, or
// Polyhedron::volume_centre where cut_cell set one: the offset centre of Section 5, Eq. 14).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/cutting/polyhedron.h"
#include "core/mesh/quality.h"

namespace mchex {

// What a hex corner is, so that later stages can merge the corners of neighbouring hexes:
//   kVertex  polyhedron vertex with cell key a;
//   kEdge    midpoint of the polyhedron edge between the vertices with cell keys a < b;
//   kFace    centroid of the polyhedron's face number a (index into Polyhedron::faces; a face
//            shared with another polyhedron or cell needs its vertex keys to be matched);
//   kCentre  the polyhedron's volume centre.
struct SubdivisionPointKey {
  enum class Kind : std::uint8_t { kVertex, kEdge, kFace, kCentre };
  Kind kind = Kind::kVertex;
  std::uint8_t a = 0, b = 0;
  friend constexpr bool operator==(const SubdivisionPointKey&, const SubdivisionPointKey&) = default;
};

struct SubdivisionHex {
  HexCorners corners{};  // VTK order, right-handed when the polyhedron is convex enough
  std::array<SubdivisionPointKey, 8> keys{};
  std::uint32_t vertex = 0;  // the polyhedron vertex the hex surrounds (its corner 0)
};

// One hex per vertex, in vertex order. Corner 0 is the vertex v; corners 1 and 3 are the
// midpoints of the two edges of one face F at v, taken so that F's counter-clockwise order (seen
// from outside) runs corner 1 -> v -> corner 3; corner 2 is F's centroid; corner 4 is the
// midpoint of v's third edge, 5 and 7 the centroids of the faces through edges (1, 4) and (3, 4),
// and 6 the volume centre. With faces oriented counter-clockwise from outside, the edge vectors
// 1 - 0, 3 - 0, 4 - 0 form a right-handed frame at a convex vertex (a cube corner gives exactly
// the VTK hex). Throws std::invalid_argument if a vertex does not have exactly 3 faces with
// consistent orientation around it (Theorem 4.1 needs 3-regularity).
std::vector<SubdivisionHex> midpoint_subdivide(const Polyhedron& p);
// The same into `hexes`, which keeps its storage (certify subdivides millions of polyhedra); on
// a throw its contents are unspecified.
void midpoint_subdivide(const Polyhedron& p, std::vector<SubdivisionHex>& hexes);

}  // namespace mchex
