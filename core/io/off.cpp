// OFF: the precheck of read_surface (surface_io.cpp says why there is one), and the normalised
// text Assimp reads instead of the file.
//
// Accepted is what the OFF format (Geomview's) allows: the header keyword with its prefixes (ST,
// C, N, 4, n), the three counts (on the keyword's line or the next), then one vertex per line and
// one face per line; '#' starts a comment anywhere, blank lines and lines of spaces anywhere, and
// a vertex's extra values (normal, colour, texture coordinate) and a face's trailing colour are
// read past. Assimp 5.2's reader takes comments and blank lines only before the first vertex and
// reads a 4OFF's w as nothing, so it is given a normalised copy: "OFF", the counts, each vertex's
// three coordinates (a 4OFF's divided by w) and each face's corner indices, one per line. Every
// line the header's counts announce is walked before anything is allocated for them; every
// coordinate is a finite single-precision number and every face index names one of the vertices.
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/io/surface_formats.h"
#include "core/io/surface_text.h"
#include "core/io/text_numbers.h"

namespace mchex::io_detail {
namespace {

namespace fs = std::filesystem;

// Assimp's OFF reader copies each line into a 4096-byte buffer and splits longer ones: a
// normalised line (three coordinates, or a face's indices) must fit.
constexpr std::size_t kMaxOffLine = 4000;

// The line up to its comment.
std::string_view uncommented(std::string_view line) { return line.substr(0, line.find('#')); }
// Assimp's OFF reader drops faces with more corners than this.
constexpr uint64_t kMaxOffCorners = 9;

}  // namespace

std::string check_off(const fs::path& path, std::string_view text) {
  check_text(path, text, "OFF");
  Lines lines(text);
  std::string_view line, token;

  // Header tokens until the line's comment; returns false at the end of the line.
  Tokens tokens{{}};
  const auto next_in_line = [&]() { return tokens.next(token); };
  const auto next_header_line = [&]() {
    while (lines.next(line)) {
      line = uncommented(line);
      tokens = Tokens(line);
      Tokens probe(line);
      std::string_view first;
      if (probe.next(first)) return true;
    }
    fail(path, "the file ends inside the OFF header (it needs the keyword and vertex, face and edge counts)");
  };

  next_header_line();
  next_in_line();
  std::string_view keyword = token;
  bool has_dimension = false;
  // Values per vertex line: the position, then in this order an optional homogeneous w (4),
  // a normal (N), one to four colour values (C) and a texture coordinate (ST).
  std::size_t vertex_values = 3;
  if (keyword.starts_with("ST")) {
    keyword.remove_prefix(2);
    vertex_values += 2;
  }
  bool vertex_values_have_w = false;
  for (char prefix : {'C', 'N', '4', 'n'}) {
    if (keyword.starts_with(prefix)) {
      keyword.remove_prefix(1);
      has_dimension = has_dimension || prefix == 'n';
      vertex_values_have_w = vertex_values_have_w || prefix == '4';
      vertex_values += prefix == 'C' ? 1 : prefix == 'N' ? 3 : prefix == '4' ? 1 : 0;
    }
  }
  // The keyword is optional in the format, but without it Assimp takes a leading '4' or 'n' of
  // the vertex count for a header prefix.
  if (keyword != "OFF") {
    fail_at(path, lines.number(),
            "expected the OFF header keyword ('OFF', 'COFF', 'NOFF', ...), found " + quote(token));
  }
  if (has_dimension) {
    if (!next_in_line()) {
      next_header_line();
      next_in_line();
    }
    const auto dimension = parse_count(token);
    if (!dimension || *dimension != 3)
      fail_at(path, lines.number(), "only 3-D vertices are supported, the header says " + quote(token));
  }

  // Assimp reads the counts as tokens and the first vertex from wherever the edge count ends,
  // so a missing edge count would swallow the first coordinate: insist on all three together.
  std::vector<std::string_view> count_text;
  if (!next_in_line()) {
    next_header_line();
    next_in_line();
  }
  do {
    if (token == "BINARY") fail_at(path, lines.number(), "binary OFF is not supported; save it as text OFF");
    count_text.push_back(token);
  } while (count_text.size() < 4 && next_in_line());
  if (count_text.size() != 3) {
    fail_at(path, lines.number(),
            "the OFF header needs the vertex, face and edge counts on one line, found " +
                std::to_string(count_text.size()) + " values" +
                (count_text.size() == 2 ? " (the edge count is missing: write 0)" : ""));
  }
  std::array<uint64_t, 3> counts{};
  for (std::size_t k = 0; k < 3; ++k) {
    const auto count = parse_count(count_text[k]);
    if (!count) {
      fail_at(path, lines.number(), "expected the vertex, face and edge counts, found " + quote(count_text[k]));
    }
    counts[k] = *count;
  }
  const std::size_t header_line = lines.number();
  const uint64_t vertex_count = counts[0], face_count = counts[1];
  if (vertex_count >= (uint64_t{1} << 31) || face_count >= (uint64_t{1} << 31)) {
    fail_at(path, header_line,
            "the header declares " + std::to_string(vertex_count) + " vertices and " + std::to_string(face_count) +
                " faces, more than the file can hold");
  }
  if (face_count == 0) fail(path, "contains no triangles (the OFF header declares 0 faces)");
  if (vertex_count == 0) fail(path, "contains no vertices (the OFF header declares 0 vertices)");

  std::string normalised = "OFF\n" + std::to_string(vertex_count) + " " + std::to_string(face_count) + " 0\n";
  // The next line with a token, its comment cut off.
  const auto next_body_line = [&](const char* what, uint64_t index, uint64_t count) {
    std::string_view first;
    for (;;) {
      if (!lines.next(line)) {
        fail(path, "the file ends after " + std::to_string(index) + " of the " + std::to_string(count) + " " + what +
                       " its header declares (one per line is expected)");
      }
      line = uncommented(line);
      if (Tokens(line).next(first)) return Tokens(line);
    }
  };
  const auto add_line = [&](std::size_t start) {
    if (normalised.size() - start > kMaxOffLine)
      fail_at(path, lines.number(), "line is longer than " + std::to_string(kMaxOffLine) + " characters");
    normalised += '\n';
  };

  const bool homogeneous = vertex_values_have_w;
  for (uint64_t v = 0; v < vertex_count; ++v) {
    Tokens tokens = next_body_line("vertices", v, vertex_count);
    std::array<std::string_view, 3> position;
    for (std::string_view& p : position) {
      if (!tokens.next(p)) fail_at(path, lines.number(), "a vertex needs three coordinates");
      parse_coordinate(path, lines.number(), p);
    }
    // The values the header keyword adds (w, normal, colour, ...) must be numbers too.
    std::size_t values = 3;
    std::optional<double> w;
    for (; tokens.next(token); ++values) {
      const auto value = parse_number(token);
      if (!value) fail_at(path, lines.number(), quote(token) + " is not a number");
      if (values == 3) w = value;
    }
    if (values < vertex_values) {
      fail_at(path, lines.number(),
              "the header keyword asks for " + std::to_string(vertex_values) + " values per vertex, found " +
                  std::to_string(values));
    }
    const std::size_t start = normalised.size();
    if (homogeneous) {
      if (!(*w != 0) || !std::isfinite(*w))
        fail_at(path, lines.number(), "the homogeneous coordinate w must be a finite non-zero number");
      for (std::size_t k = 0; k < 3; ++k) {
        const double x = parse_coordinate(path, lines.number(), position[k]) / *w;
        if (!std::isfinite(float(x))) fail_at(path, lines.number(), "a coordinate divided by w is not finite");
        if (k != 0) normalised += ' ';
        put_number(normalised, x);
      }
    } else {
      normalised.append(position[0]).append(" ").append(position[1]).append(" ").append(position[2]);
    }
    add_line(start);
  }
  for (uint64_t f = 0; f < face_count; ++f) {
    Tokens tokens = next_body_line("faces", f, face_count);
    tokens.next(token);
    const auto corners = parse_count(token);
    if (!corners) fail_at(path, lines.number(), "expected the number of face corners, found " + quote(token));
    if (*corners == 0) fail_at(path, lines.number(), "face has no corners");
    if (*corners > kMaxOffCorners) {
      fail_at(path, lines.number(),
              "face has " + std::to_string(*corners) + " corners; the OFF reader supports at most " +
                  std::to_string(kMaxOffCorners) + " (triangulate the model first)");
    }
    const std::size_t start = normalised.size();
    normalised.append(token);
    for (uint64_t k = 0; k < *corners; ++k) {
      if (!tokens.next(token)) {
        fail_at(path, lines.number(), "face has fewer indices than its corner count " + std::to_string(*corners));
      }
      const auto index = parse_count(token);
      if (!index) fail_at(path, lines.number(), quote(token) + " is not a vertex index");
      if (*index >= vertex_count) {
        fail_at(path, lines.number(),
                "face refers to vertex " + std::to_string(*index) + ", but the file has only " +
                    std::to_string(vertex_count) + " vertices (indices start at 0)");
      }
      normalised.append(" ").append(token);
    }
    // What follows the indices is the face's colour (0 to 4 values), not geometry.
    add_line(start);
  }
  return normalised;
}

}  // namespace mchex::io_detail
