// The dispatch of mesh_io.h: the format by extension, the checks every writer relies on, and the
// one place where a format's reason becomes an InputError "PATH: reason". The formats themselves
// are in medit.cpp, meshb.cpp, vtu.cpp, gmsh.cpp, exodus.cpp and abaqus.cpp (mesh_formats.h).
#include "core/io/mesh_io.h"
#include "core/io/surface_text.h"

#include <algorithm>
#include <cstdint>
#include <string>

#include "core/base/error.h"
#include "core/io/atomic_file.h"
#include "core/io/format_error.h"
#include "core/io/mapped_file.h"
#include "core/io/mesh_formats.h"

namespace mchex {
namespace {

using io_detail::FormatError;
using io_detail::kMaxPoints;

// Every format can represent only a consistent mesh, and a reader of ours must accept what the
// writer wrote, so inconsistencies are refused before the first byte.
void check_writable(const HexMesh& mesh) {
  if (mesh.region.size() != mesh.hexes.size())
    throw FormatError("the mesh has " + std::to_string(mesh.hexes.size()) + " hexes but " +
                      std::to_string(mesh.region.size()) + " region labels");
  if (mesh.points.size() > kMaxPoints)
    throw FormatError(std::to_string(mesh.points.size()) + " points are more than 32-bit indices can address");
  for (std::size_t i = 0; i < mesh.points.size(); ++i)
    if (!is_finite(mesh.points[i])) throw FormatError("point " + std::to_string(i) + " has a non-finite coordinate");
  const std::size_t n = mesh.points.size();
  for (std::size_t h = 0; h < mesh.hexes.size(); ++h)
    for (const uint32_t v : mesh.hexes[h])
      if (v >= n)
        throw FormatError("hex " + std::to_string(h) + " refers to point " + std::to_string(v) + " but the mesh has " +
                          std::to_string(n) + " points");
}

}  // namespace

MeshFormat mesh_format(const std::filesystem::path& path) {
  const std::string extension = path.extension().string();
  std::string lower = extension;
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](char c) { return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c; });
  if (lower == ".mesh") return MeshFormat::kMedit;
  if (lower == ".meshb") return MeshFormat::kMeditBinary;
  if (lower == ".vtu") return MeshFormat::kVtu;
  if (lower == ".msh") return MeshFormat::kGmsh;
  if (lower == ".exo") return MeshFormat::kExodus;
  if (lower == ".inp") return MeshFormat::kAbaqus;
  constexpr const char* kKnown = " (use .mesh, .meshb, .vtu, .msh, .exo or .inp)";
  if (extension.empty()) throw InputError(path.string() + ": no file extension to tell the mesh format" + kKnown);
  throw InputError(path.string() + ": unknown mesh format '" + extension + "'" + kKnown);
}

void write_hex_mesh(const HexMesh& mesh, const std::filesystem::path& path, const MeshWriteOptions& options) {
  const MeshFormat format = mesh_format(path);
  try {
    check_writable(mesh);
    if (!options.scaled_jacobians.empty() && options.scaled_jacobians.size() != mesh.hexes.size())
      throw FormatError(std::to_string(options.scaled_jacobians.size()) + " scaled Jacobians given for " +
                        std::to_string(mesh.hexes.size()) + " hexes");
    AtomicFile out(path);
    switch (format) {
      case MeshFormat::kMedit: io_detail::write_medit(mesh, out); break;
      case MeshFormat::kVtu: io_detail::write_vtu(mesh, out, options.scaled_jacobians); break;
      case MeshFormat::kGmsh: io_detail::write_gmsh(mesh, out, options.binary); break;
      case MeshFormat::kMeditBinary: io_detail::write_meshb(mesh, out); break;
      case MeshFormat::kExodus: io_detail::write_exodus(mesh, out); break;
      case MeshFormat::kAbaqus: io_detail::write_abaqus(mesh, out); break;
    }
    out.commit();
  } catch (const FormatError& e) {
    throw InputError(io_detail::one_line(path.string()) + ": " + io_detail::one_line(e.what()));
  }
}

HexMesh read_hex_mesh(const std::filesystem::path& path) {
  const MeshFormat format = mesh_format(path);
  try {
    const io_detail::MappedFile file(path);
    const std::string_view text = file.text();
    switch (format) {
      case MeshFormat::kMedit: return io_detail::read_medit(text);
      case MeshFormat::kVtu: return io_detail::read_vtu(text);
      case MeshFormat::kGmsh: return io_detail::read_gmsh(text);
      case MeshFormat::kMeditBinary: return io_detail::read_meshb(text);
      case MeshFormat::kAbaqus: return io_detail::read_abaqus(text);
      case MeshFormat::kExodus: return io_detail::read_exodus(path, text);
    }
    throw FormatError("unknown format");
  } catch (const FormatError& e) {
    throw InputError(io_detail::one_line(path.string()) + ": " + io_detail::one_line(e.what()));
  }
}

}  // namespace mchex
