// Reading STL (ascii and binary), OBJ, OFF and PLY surfaces through Assimp, behind our own checks.
//
// Assimp 5.2 is lenient or fragile on exactly the inputs a mesher must refuse. Found by trying
// it on the Debian and npm sample files, on hand-made bad files and with libFuzzer:
//   - it silently misreads: OFF indices out of range are clamped, OFF polygons over nine
//     corners and extra ascii STL facet vertices are dropped, "blah" or "3.1+e2" read as 0 or
//     3.1, NaN and infinity pass, a binary PLY whose data starts with 0x0a or holds an element
//     it does not know is read out of step, an OBJ number written ".5" loses its vertex;
//   - it allocates what a header claims (OFF and PLY counts, in 32 bits): gigabytes and minutes
//     for one corrupt number, and a binary STL size check that wraps;
//   - it crashes: aiProcess_Triangulate aborts on a malformed OFF, a repeated PLY element
//     writes past a buffer, an OBJ material statement writes through a null pointer.
// So the file is read into memory once and a cheap format-specific pass (stl.cpp, obj.cpp,
// off.cpp, ply.cpp) rejects what Assimp would get wrong, with a line number where there is one.
// Assimp then parses those bytes (or a minimal rewrite of them: OBJ geometry only, a padding byte
// for binary PLY) from memory, with no access to other files (assimp_scene.cpp). The scene is
// checked again (indices, finite coordinates, polygon size) before triangulation, since
// aiProcess_Triangulate assumes a well-formed mesh. No Assimp logger is created, so Assimp prints
// nothing. Here: the format by extension, the file's bytes, and the weld.
#include "core/io/surface_io.h"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>

#include "core/io/surface_formats.h"
#include "core/io/surface_text.h"

namespace mchex {
namespace {

namespace fs = std::filesystem;
using namespace io_detail;

enum class Format { stl, obj, off, ply };

const char* format_name(Format format) {
  switch (format) {
    case Format::stl: return "STL";
    case Format::obj: return "OBJ";
    case Format::off: return "OFF";
    case Format::ply: return "PLY";
  }
  return "";
}

// Assimp's loaders keep file sizes in 32-bit unsigned ints.
constexpr std::uintmax_t kMaxFileBytes = 0xffffff00u;

Format format_of(const fs::path& path) {
  std::string extension = path.extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (extension == ".stl") return Format::stl;
  if (extension == ".obj") return Format::obj;
  if (extension == ".off") return Format::off;
  if (extension == ".ply") return Format::ply;
  if (extension.empty()) fail(path, "has no file extension; name it .stl, .obj, .off or .ply");
  fail(path,
       "unknown file extension " + quote(path.extension().string()) + "; supported are .stl, .obj, .off and .ply");
}

std::string read_bytes(const fs::path& path) {
  std::error_code error;
  const fs::file_status status = fs::status(path, error);
  if (status.type() == fs::file_type::not_found) fail(path, "no such file");
  if (error) fail(path, "cannot be accessed: " + error.message());
  if (fs::is_directory(status)) fail(path, "is a directory, not a surface file");
  // A FIFO or device could block or never end.
  if (!fs::is_regular_file(status)) fail(path, "is not a regular file");
  const std::uintmax_t size = fs::file_size(path, error);
  if (error) fail(path, "cannot be read: " + error.message());
  if (size == 0) fail(path, "the file is empty");
  if (size > kMaxFileBytes) fail(path, "is larger than 4 GiB, which the surface readers cannot handle");

  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot be opened (check that it is readable)");
  std::string bytes(static_cast<std::size_t>(size), '\0');
  in.read(bytes.data(), static_cast<std::streamsize>(size));
  if (static_cast<std::uintmax_t>(in.gcount()) != size) fail(path, "could not be read completely");
  return bytes;
}

}  // namespace

TriangleSurface read_surface(const std::filesystem::path& path, std::size_t* welded) {
  const Format format = format_of(path);
  const std::string bytes = read_bytes(path);

  std::string_view to_parse = bytes;
  std::optional<uint64_t> expected_triangles;
  std::optional<uint64_t> vertex_records;  // when the reader does not keep the file's indexing
  std::string patched;                     // when the bytes Assimp sees must differ from the file's
  switch (format) {
    case Format::stl: {
      const StlLayout layout = check_stl(path, bytes);
      expected_triangles = layout.triangles;
      to_parse = stl_assimp_input(layout, patched);
      break;
    }
    case Format::obj: {
      ObjGeometry geometry = check_obj(path, strip_utf8_bom(bytes));
      vertex_records = geometry.used_records;
      patched = std::move(geometry.text);
      to_parse = patched;
      break;
    }
    case Format::off:
      patched = check_off(path, strip_utf8_bom(bytes));
      to_parse = patched;
      break;
    case Format::ply: {
      const PlyLayout layout = check_ply(path, bytes);
      if (layout.binary && layout.data < bytes.size() && bytes[layout.data] == '\n') {
        patched = pad_binary_ply(bytes, layout);
        to_parse = patched;
      }
      break;
    }
  }

  const char* hint = format == Format::stl   ? "stl"
                     : format == Format::obj ? "obj"
                     : format == Format::off ? "off"
                                             : "ply";
  Collected collected = import_scene(path, to_parse, hint, format_name(format));
  TriangleSurface& surface = collected.surface;
  if (surface.triangles.empty()) {
    fail(path,
         collected.other_primitives > 0 ? "contains no triangles, only points or lines" : "contains no triangles");
  }
  if (expected_triangles && surface.triangles.size() != *expected_triangles) {
    fail(path, "the STL reader found " + std::to_string(surface.triangles.size()) + " triangles where the file has " +
                   std::to_string(*expected_triangles) + " facets");
  }

  const std::size_t merged = weld_vertices(surface);
  if (welded != nullptr) {
    *welded =
        !vertex_records
            ? merged
            : static_cast<std::size_t>(*vertex_records - std::min<uint64_t>(*vertex_records, surface.vertices.size()));
  }
  return surface;
}

}  // namespace mchex
