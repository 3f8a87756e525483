// OBJ: the precheck of read_surface (surface_io.cpp says why there is one).
//
// Only "v" and "f" statements matter; each coordinate and face corner is checked (indices 1-based
// or negative, counting back, within the vertices the file defines), and Assimp is then given a
// rewrite that holds only those statements, vertices first and indices absolute, so that its OBJ
// reader never meets a material statement, a forward reference or a number it misreads.
#include <algorithm>
#include <charconv>
#include <cstdint>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "core/io/surface_formats.h"
#include "core/io/surface_text.h"

namespace mchex::io_detail {

namespace fs = std::filesystem;

ObjGeometry check_obj(const fs::path& path, std::string_view text) {
  check_text(path, text, "OBJ");
  uint64_t total_vertices = 0;
  {
    Lines lines(text);
    std::string_view line, keyword;
    while (lines.next(line)) {
      Tokens tokens(line);
      if (tokens.next(keyword) && keyword == "v") ++total_vertices;
    }
  }

  // Vertices go first so that a face may use a vertex defined after it, as Assimp cannot.
  ObjGeometry geometry;
  std::string faces;
  geometry.text.reserve(text.size());
  Lines lines(text);
  std::string_view line, token;
  uint64_t vertices_so_far = 0;
  std::vector<bool> used(total_vertices, false);
  std::vector<uint64_t> corners;
  bool points_or_lines = false;
  while (lines.next(line)) {
    Tokens tokens(line);
    if (!tokens.next(token)) continue;
    if (token == "v") {
      geometry.text += 'v';
      for (int k = 0; k < 3; ++k) {
        if (!tokens.next(token) || token.starts_with('#'))
          fail_at(path, lines.number(), "a vertex needs three coordinates");
        parse_coordinate(path, lines.number(), token);
        geometry.text += ' ';
        // Assimp's OBJ reader drops a vertex whose number starts with the decimal point.
        if (token.starts_with('.')) geometry.text += '0';
        geometry.text += token;
      }
      geometry.text += '\n';
      ++vertices_so_far;
    } else if (token == "f") {
      corners.clear();
      while (tokens.next(token) && !token.starts_with('#')) {
        const std::string_view index_text = token.substr(0, token.find('/'));
        int64_t index = 0;
        const auto [end, error] = std::from_chars(index_text.data(), index_text.data() + index_text.size(), index);
        if (index_text.empty() || error != std::errc{} || end != index_text.data() + index_text.size()) {
          fail_at(path, lines.number(),
                  quote(token) + " is not a face corner (vertex index, optionally /texture/normal)");
        }
        if (index == 0) fail_at(path, lines.number(), "face index 0 is invalid: OBJ vertex indices start at 1");
        if (index > 0 && static_cast<uint64_t>(index) > total_vertices) {
          fail_at(path, lines.number(),
                  "face refers to vertex " + std::to_string(index) + ", but the file defines only " +
                      std::to_string(total_vertices) + " vertices");
        }
        // Negative indices count back from the most recent vertex.
        if (index < 0 && static_cast<uint64_t>(-(index + 1)) >= vertices_so_far) {
          fail_at(path, lines.number(),
                  "face refers to vertex " + std::to_string(index) + " (counting back), but only " +
                      std::to_string(vertices_so_far) + " vertices come before it");
        }
        corners.push_back(index > 0 ? static_cast<uint64_t>(index - 1)
                                    : vertices_so_far - static_cast<uint64_t>(-index));
      }
      if (corners.size() < 3) {
        points_or_lines = true;
        continue;
      }
      if (corners.size() > kMaxPolygonCorners) {
        fail_at(path, lines.number(),
                "face has " + std::to_string(corners.size()) + " corners; at most " +
                    std::to_string(kMaxPolygonCorners) + " are supported (triangulate the model first)");
      }
      faces += 'f';
      for (uint64_t v : corners) {
        used[v] = true;
        faces += ' ';
        faces += std::to_string(v + 1);
      }
      faces += '\n';
    } else if (token == "l" || token == "p") {
      points_or_lines = true;
    }
  }
  geometry.text += faces;
  geometry.used_records = static_cast<uint64_t>(std::count(used.begin(), used.end(), true));
  if (geometry.used_records == 0)
    fail(path, points_or_lines ? "contains no triangles, only points or lines" : "contains no triangles");
  return geometry;
}

}  // namespace mchex::io_detail
