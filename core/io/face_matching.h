// Which faces of a hex mesh are on its boundary (one hex has them) and which lie between two
// regions (two hexes of different region labels share them): what the Exodus writer's boundary
// node set and interface side sets are made of (exodus_writer.cpp).
//
// A face is its four corner indices, sorted; two faces match when those are equal. The hexes are
// cut into a fixed number of consecutive slices, matched on all threads: each slice walks its hexes
// in order, keeping the faces not matched yet in a hash table (an open face is removed when its
// partner comes), so the table holds the slice's front rather than all its faces. A mesher's hexes
// come in spatial order, so the front is small (a layer of the mesh) and the tables stay in the
// core's cache; the unmatched faces of all slices are then matched in slice order, and what is left
// is the boundary. Memory: the tables, the interface and boundary lists; nothing per face or per
// hex (a fresh allocation costs 23 us per 4 KiB page on the development VM, so an array per face
// would cost more than the matching).
//
// In a mesh where every face belongs to one or two hexes (any mesh the pipeline makes) the result
// is that pairing. Where three or more faces have the same corners, a face is paired with the one
// left unmatched before it (in slice order, then hex order), and an odd one out counts as
// boundary; this depends on the hex order only, never on the threads.
#pragma once

#include <cstdint>
#include <vector>

#include "core/mesh/hex_mesh.h"

namespace mchex::io_detail {

// Faces are numbered 6h + k, k the kHexFaces face of hex h (core/mesh/hex_faces.h).
struct RegionInterface {
  int32_t lower = 0, upper = 0;      // the two region labels, lower < upper
  std::vector<std::uint32_t> faces;  // the shared faces as faces of the lower region's hexes, ascending
};

struct MatchedFaces {
  std::vector<std::uint32_t> boundary;      // faces of one hex, in no particular order
  std::vector<RegionInterface> interfaces;  // ascending (lower, upper); none empty
};

// Needs 6 * hexes < 2^32.
MatchedFaces match_faces(const HexMesh& mesh);

}  // namespace mchex::io_detail
