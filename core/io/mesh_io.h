// Hex mesh files, chosen by the file extension, case-insensitive: MEDIT .mesh (ascii) and .meshb
// (binary), VTK XML .vtu, Gmsh .msh (4.1, ascii or binary), Exodus II .exo and Abaqus/CalculiX
// .inp. docs/formats.md has the layouts and the facts behind them.
//
// Every format keeps the HexMesh corner order (VTK_HEXAHEDRON, which MEDIT's Hexahedra, Gmsh's
// element type 5, Exodus's HEX8 and Abaqus's C3D8 share), the point order, the hex order and one
// region label per hex:
//   .mesh  the element reference of each Hexahedra record; vertex references are written 0.
//   .meshb the same records in libMeshb's binary layout (version 3, or 4 for huge meshes).
//   .vtu   Float64 points, Int64 connectivity/offsets, UInt8 types (12), Int32 CellData "region",
//          as raw appended little-endian data with UInt64 block headers.
//   .msh   one volume entity per region value, the region as its physical tag (meshio's
//          "gmsh:physical"); element blocks follow runs of equal regions so that hex order is kept;
//          ascii by default, binary with MeshWriteOptions::binary (as `gmsh -bin` writes it).
//   .exo   one HEX8 element block per region (named "region_R"), the element number map holding
//          the hex order, a node set "boundary" (nodes on faces of one hex only) and a side set
//          "interface_a_b" per pair of regions that share faces.
//   .inp   *NODE and one *ELEMENT, TYPE=C3D8, ELSET=REGIONr block per run of equal regions.
// Ascii coordinates are the shortest decimal strings that parse back to the same double, so a
// write followed by a read gives bit-identical points; the one exception is .inp, whose fields
// CalculiX reads from 20 characters: a coordinate whose shortest form is longer (a 3-digit
// exponent with both signs, e.g. -2.2250738585072014e-308) is rounded to 13-16 digits there.
//
// Writes are atomic: the data goes to a hidden temporary file in the target's folder that is
// renamed over the target at the end; on any failure the temporary file is removed, the target
// is left as it was and an InputError "PATH: reason" is thrown.
//
// Reads accept files from other tools as far as they hold an all-hex mesh:
//   .mesh  free-form tokens, '#' comments; Vertices and Hexahedra (or Hexaedra) are read, surface
//          and annotation sections (Edges, Triangles, Quadrilaterals, Corners, Normals, ...) are
//          skipped; any other volume element (Tetrahedra, Prisms, Pyramids) is an error.
//   .meshb versions 1-4, either byte order; other keywords skipped by their next-keyword position.
//   .exo   HEX8 blocks; other 3D blocks an error, lower-dimension blocks skipped.
//   .inp   *NODE, C3D8* *ELEMENT blocks, REGIONr element sets; other keywords skipped.
//   .msh   4.1 ascii or binary; points in node-tag order, hexes in element-tag order; elements of entities
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
#include <span>

#include "core/mesh/hex_mesh.h"

namespace mchex {

enum class MeshFormat { kMedit, kMeditBinary, kVtu, kGmsh, kExodus, kAbaqus };

struct MeshWriteOptions {
  bool binary = false;  // .msh as Gmsh 4.1 binary; the other formats have one form each
  // .vtu: each hex's scaled Jacobian for the "scaled_jacobian" cell array, in hex order, as the
  // caller already has them (HexQuality::scaled_jacobian of core/mesh/quality.h, bit for bit what
  // scaled_jacobian(mesh.corners(h)) gives); empty: the writer computes them, which is most of a
  // .vtu write's time. Must hold one value per hex (InputError otherwise); ignored by the other
  // formats. The values are not checked against the mesh.
  std::span<const double> scaled_jacobians = {};
};

// The format named by the extension of `path`; InputError when it names none, so that a caller can
// reject a bad output name before any expensive work.
MeshFormat mesh_format(const std::filesystem::path& path);

// Throws InputError when the mesh cannot be written as it is (an index out of range, a region
// count that differs from the hex count, a non-finite coordinate) or when the file system fails.
void write_hex_mesh(const HexMesh& mesh, const std::filesystem::path& path, const MeshWriteOptions& options = {});

HexMesh read_hex_mesh(const std::filesystem::path& path);

}  // namespace mchex
