// The per-format prechecks behind read_surface (stl.cpp, obj.cpp, off.cpp, ply.cpp) and the
// Assimp import they guard (assimp_scene.cpp); surface_io.cpp says what they protect against.
//
// A check either accepts the file's bytes, saying what Assimp should be given (the bytes, a part
// of them or a minimal rewrite) and what the reader must find, or throws InputError("PATH:
// reason"). Assimp never sees bytes that no check has accepted.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "core/mesh/surface.h"

namespace mchex::io_detail {

struct StlLayout {
  bool binary = false;
  uint64_t triangles = 0;
  std::string_view bytes;  // what Assimp should parse
};

StlLayout check_stl(const std::filesystem::path& path, std::string_view bytes);

// What Assimp should parse of a checked STL: layout.bytes, or a repaired copy of them in `patched`.
std::string_view stl_assimp_input(const StlLayout& layout, std::string& patched);

// What Assimp gets instead of the OBJ file: its vertex and polygon statements only, with
// absolute vertex indices. Assimp 5.2's OBJ reader crashes on some material statements (a
// "map_Kd" line after an "mtllib" it cannot open writes through a null pointer), and nothing but
// positions and faces matters here.
struct ObjGeometry {
  std::string text;
  uint64_t used_records = 0;  // vertex records the polygons use: Assimp gives every corner its own
                              // vertex, so the weld count is measured against these
};

ObjGeometry check_obj(const std::filesystem::path& path, std::string_view text);

// What Assimp gets instead of the OFF file: "OFF", the counts, each vertex's position and each
// face's indices, one per line, with comments, blank lines, colours, normals and texture
// coordinates left out (off.cpp says why).
std::string check_off(const std::filesystem::path& path, std::string_view text);

// Where the parts of a checked PLY file start, for the padding read_surface adds.
struct PlyLayout {
  bool binary = false;
  std::size_t header_body = 0;  // just after the format line
  std::size_t data = 0;         // just after the end_header line
};

PlyLayout check_ply(const std::filesystem::path& path, std::string_view bytes);

// Assimp 5.2 skips a line feed at the start of binary PLY data, so a file whose first data
// byte is 0x0a (one in 256 of them) is read one byte out of step. A one-byte element placed
// first in the data, with a letter as its value, keeps the real data where it belongs. It must
// be an element Assimp knows ("edge", which it reads and ignores): it takes the count of any
// other element for 0.
std::string pad_binary_ply(std::string_view bytes, const PlyLayout& layout);

// The triangles of every mesh instance of a scene, vertices in order of first use, not yet welded.
struct Collected {
  TriangleSurface surface;
  std::size_t other_primitives = 0;  // points and lines, ignored
};

// Parses `bytes` with Assimp (`hint`: the extension it picks its reader by; `format`: the name a
// message gives), checks the scene, triangulates polygons and collects every mesh instance.
Collected import_scene(const std::filesystem::path& path, std::string_view bytes, const char* hint, const char* format);

}  // namespace mchex::io_detail
