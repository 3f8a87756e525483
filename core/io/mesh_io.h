// Hex mesh files: MEDIT .mesh (ascii), VTK XML .vtu and Gmsh .msh (4.1 ascii), chosen by the
// file extension, case-insensitive.
//
// Every format keeps the HexMesh corner order (VTK_HEXAHEDRON, which MEDIT's Hexahedra and Gmsh's
// element type 5 share), the point order, the hex order and one region label per hex:
//   .mesh  the element reference of each Hexahedra record; vertex references are written 0.
//   .vtu   Float64 points, Int64 connectivity/offsets, UInt8 types (12), Int32 CellData "region",
//          as raw appended little-endian data with UInt64 block headers.
//   .msh   one volume entity per region value, the region as its physical tag (meshio's
//          "gmsh:physical"); element blocks follow runs of equal regions so that hex order is kept.
// Ascii coordinates are the shortest decimal strings that parse back to the same double, so a
// write followed by a read gives bit-identical points in all three formats.
//
// Writes are atomic: the data goes to a hidden temporary file in the target's folder that is
// renamed over the target at the end; on any failure the temporary file is removed, the target
// is left as it was and an InputError "PATH: reason" is thrown.
//
// Reads accept files from other tools as far as they hold an all-hex mesh:
//   .mesh  free-form tokens, '#' comments; Vertices and Hexahedra (or Hexaedra) are read, surface
//          and annotation sections (Edges, Triangles, Quadrilaterals, Corners, Normals, ...) are
//          skipped; any other volume element (Tetrahedra, Prisms, Pyramids) is an error.
//   .msh   4.1 ascii; points in node-tag order, hexes in element-tag order; elements of entities
//          of dimension < 3 are skipped, 3D elements other than 8-node hexahedra are an error; the
//          region is the first physical tag of the hex's volume entity, else the entity tag.
//   .vtu   one Piece, ascii / base64 "binary" / appended (raw or base64) DataArrays, uncompressed,
//          either byte order, UInt32 or UInt64 headers; cells of dimension < 3 are skipped, 3D
//          cells other than VTK_HEXAHEDRON are an error; the region is the CellData array named
//          "region" (else "medit:ref", else "gmsh:physical", else 0).
// A file that is not such a mesh (truncated, counts the file cannot hold, indices out of range,
// non-finite coordinates, garbage) gives an InputError "PATH: reason", never a partial mesh.
#pragma once

#include <filesystem>

#include "core/mesh/hex_mesh.h"

namespace mchex {

enum class MeshFormat { kMedit, kVtu, kGmsh };

// The format named by the extension of `path`; InputError when it names none, so that a caller can
// reject a bad output name before any expensive work.
MeshFormat mesh_format(const std::filesystem::path& path);

// Throws InputError when the mesh cannot be written as it is (an index out of range, a region
// count that differs from the hex count, a non-finite coordinate) or when the file system fails.
void write_hex_mesh(const HexMesh& mesh, const std::filesystem::path& path);

HexMesh read_hex_mesh(const std::filesystem::path& path);

}  // namespace mchex
