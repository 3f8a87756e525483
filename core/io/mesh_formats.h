// The per-format readers and writers behind mesh_io.h (medit.cpp, meshb.cpp, vtu.cpp, gmsh.cpp,
// exodus.cpp, abaqus.cpp).
//
// A writer gets a mesh that check_writable (mesh_io.cpp) has accepted: a region per hex, indices in
// range, finite coordinates, at most kMaxPoints points. A reader gets the whole file as text and
// returns a mesh with those same properties or throws FormatError with the reason; mesh_io.cpp
// puts the path in front. Neither ever sees a partial file: AtomicFile and MappedFile see to that.
#pragma once

#include <cstdint>
#include <filesystem>
#include <limits>
#include <span>
#include <string_view>

#include "core/io/atomic_file.h"
#include "core/mesh/hex_mesh.h"

namespace mchex::io_detail {

// Point indices are 32-bit (Hex holds uint32_t), so 2^32 points can be addressed.
inline constexpr std::uint64_t kMaxPoints = std::uint64_t{std::numeric_limits<uint32_t>::max()} + 1;

void write_medit(const HexMesh& mesh, AtomicFile& out);
// `scaled_jacobians`: one per hex, written as given; empty: computed here.
void write_vtu(const HexMesh& mesh, AtomicFile& out, std::span<const double> scaled_jacobians = {});
// `binary`: Gmsh 4.1 binary (file-type 1) instead of ascii.
void write_gmsh(const HexMesh& mesh, AtomicFile& out, bool binary = false);
void write_meshb(const HexMesh& mesh, AtomicFile& out);
void write_abaqus(const HexMesh& mesh, AtomicFile& out);
// libexodusii writes to out.temporary() itself; `out` keeps the atomic rename.
void write_exodus(const HexMesh& mesh, AtomicFile& out);

HexMesh read_medit(std::string_view text);
HexMesh read_vtu(std::string_view text);
HexMesh read_gmsh(std::string_view text);
HexMesh read_meshb(std::string_view bytes);
HexMesh read_abaqus(std::string_view text);
// `bytes` are the file's; a netCDF-4 file is read by libexodusii from `path`.
HexMesh read_exodus(const std::filesystem::path& path, std::string_view bytes);

}  // namespace mchex::io_detail
