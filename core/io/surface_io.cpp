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
// So the file is read into memory once and a cheap format-specific pass rejects what Assimp
// would get wrong, with a line number where there is one. Assimp then parses those bytes (or a
// minimal rewrite of them: OBJ geometry only, a padding byte for binary PLY) from memory, with
// no access to other files. The scene is checked again (indices, finite coordinates, polygon
// size) before triangulation, since aiProcess_Triangulate assumes a well-formed mesh. No Assimp
// logger is created, so Assimp prints nothing.
#include <assimp/IOSystem.hpp>
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cfloat>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "core/base/error.h"
#include "core/io/surface_io.h"

namespace mchex {
namespace {

namespace fs = std::filesystem;

enum class Format { stl, obj, off, ply };

const char* format_name(Format format) {
  switch (format) {
    case Format::stl:
      return "STL";
    case Format::obj:
      return "OBJ";
    case Format::off:
      return "OFF";
    case Format::ply:
      return "PLY";
  }
  return "";
}

// Assimp's loaders keep file sizes in 32-bit unsigned ints.
constexpr std::uintmax_t kMaxFileBytes = 0xffffff00u;
// Assimp's OFF reader copies each line into a 4096-byte buffer and splits longer ones.
constexpr std::size_t kMaxOffLine = 4000;
// Assimp's OFF reader drops faces with more corners than this.
constexpr uint64_t kMaxOffCorners = 9;
// Assimp triangulates a polygon by ear clipping, quadratic in its corners: a corrupt face with
// a million corners would take hours.
constexpr std::size_t kMaxPolygonCorners = 1000;

std::string hex_byte(unsigned char c) {
  char buffer[8];
  std::snprintf(buffer, sizeof buffer, "\\x%02x", c);
  return buffer;
}

// A token quoted from a file: kept short and printable, because the file may be binary.
std::string quote(std::string_view token) {
  constexpr std::size_t kLimit = 40;
  std::string out = "'";
  for (std::size_t i = 0; i < token.size() && i < kLimit; ++i) {
    const auto c = static_cast<unsigned char>(token[i]);
    out += (c >= 0x20 && c < 0x7f) ? std::string(1, static_cast<char>(c)) : hex_byte(c);
  }
  if (token.size() > kLimit) out += "...";
  return out + "'";
}

// Error messages are one stderr line: control characters (a newline in a path, or in an
// Assimp message that quotes the rest of the file) become escapes; UTF-8 names stay readable.
std::string one_line(std::string_view text) {
  std::string out;
  for (char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    out += (c < 0x20 || c == 0x7f) ? hex_byte(c) : std::string(1, ch);
  }
  return out;
}

[[noreturn]] void fail(const fs::path& path, std::string_view reason) {
  throw InputError(one_line(path.string()) + ": " + one_line(reason));
}

[[noreturn]] void fail_at(const fs::path& path, std::size_t line, std::string_view reason) {
  fail(path, "line " + std::to_string(line) + ": " + std::string(reason));
}

Format format_of(const fs::path& path) {
  std::string extension = path.extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (extension == ".stl") return Format::stl;
  if (extension == ".obj") return Format::obj;
  if (extension == ".off") return Format::off;
  if (extension == ".ply") return Format::ply;
  if (extension.empty()) fail(path, "has no file extension; name it .stl, .obj, .off or .ply");
  fail(path, "unknown file extension " + quote(path.extension().string()) +
                 "; supported are .stl, .obj, .off and .ply");
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

// ---------------------------------------------------------------------------------------------
// Text scanning shared by the checks.

std::string_view strip_utf8_bom(std::string_view text) {
  return text.starts_with("\xEF\xBB\xBF") ? text.substr(3) : text;
}

// Splits at \n, \r\n or a lone \r, numbering lines from 1 as an editor does.
class Lines {
 public:
  explicit Lines(std::string_view text) : text_(text) {}
  bool next(std::string_view& line) {
    if (position_ >= text_.size()) return false;
    const std::size_t end = text_.find_first_of("\r\n", position_);
    ++number_;
    if (end == std::string_view::npos) {
      line = text_.substr(position_);
      position_ = text_.size();
      return true;
    }
    line = text_.substr(position_, end - position_);
    position_ = end + ((text_[end] == '\r' && end + 1 < text_.size() && text_[end + 1] == '\n') ? 2 : 1);
    return true;
  }
  std::size_t number() const { return number_; }
  std::size_t position() const { return position_; }

 private:
  std::string_view text_;
  std::size_t position_ = 0;
  std::size_t number_ = 0;
};

bool is_blank(char c) { return c == ' ' || c == '\t'; }

class Tokens {
 public:
  explicit Tokens(std::string_view line) : rest_(line) {}
  bool next(std::string_view& token) {
    std::size_t begin = 0;
    while (begin < rest_.size() && is_blank(rest_[begin])) ++begin;
    if (begin == rest_.size()) return false;
    std::size_t end = begin;
    while (end < rest_.size() && !is_blank(rest_[end])) ++end;
    token = rest_.substr(begin, end - begin);
    rest_ = rest_.substr(end);
    return true;
  }

 private:
  std::string_view rest_;
};

// Text formats must be text: a stray control byte means a binary or damaged file, and Assimp's
// readers treat some of them (\0, \f) as line ends where we would not.
void check_text(const fs::path& path, std::string_view text, const char* what) {
  if (text.starts_with("\xFE\xFF") || text.starts_with("\xFF\xFE")) {
    fail(path, std::string("is UTF-16 text; save the ") + what + " file as ASCII or UTF-8");
  }
  std::size_t line = 1;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c == '\n') ++line;
    if (c == '\r' && (i + 1 == text.size() || text[i + 1] != '\n')) ++line;
    if (c < 0x20 && c != '\n' && c != '\r' && c != '\t') {
      fail_at(path, line, "control character " + hex_byte(c) + ": this is not a text " + what + " file");
    }
  }
}

std::optional<double> parse_number(std::string_view token) {
  if (token.size() > 1 && token[0] == '+' && token[1] != '-' && token[1] != '+') token.remove_prefix(1);
  const char* first = token.data();
  const char* last = token.data() + token.size();
  double value = 0;
  std::from_chars_result result = std::from_chars(first, last, value);
  if (result.ec == std::errc::result_out_of_range) {
    // Beyond double's range: long double tells overflow from underflow.
    long double wide = 0;
    result = std::from_chars(first, last, wide);
    if (result.ec == std::errc::result_out_of_range) {
      const std::size_t e = token.find_first_of("eE");
      const bool tiny = e != std::string_view::npos && e + 1 < token.size() && token[e + 1] == '-';
      wide = std::copysign(tiny ? 0.0L : HUGE_VALL, token.starts_with('-') ? -1.0L : 1.0L);
      result.ec = std::errc{};
    }
    value = std::fabs(wide) > DBL_MAX ? std::copysign(HUGE_VAL, static_cast<double>(wide))
                                      : static_cast<double>(wide);
  }
  if (result.ec != std::errc{} || result.ptr != last) return std::nullopt;
  return value;
}

// Coordinates: Assimp stores them as float, so anything beyond float's range would become inf.
double parse_coordinate(const fs::path& path, std::size_t line, std::string_view token) {
  const std::optional<double> value = parse_number(token);
  if (!value) fail_at(path, line, quote(token) + " is not a number");
  if (!std::isfinite(*value))
    fail_at(path, line, "coordinate " + quote(token) + " is not finite; NaN and infinity cannot be meshed");
  if (std::fabs(*value) > FLT_MAX)
    fail_at(path, line, "coordinate " + quote(token) + " is beyond single precision, which the readers use");
  return *value;
}

std::optional<uint64_t> parse_count(std::string_view token) {
  uint64_t value = 0;
  const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (error != std::errc{} || end != token.data() + token.size()) return std::nullopt;
  return value;
}

// ---------------------------------------------------------------------------------------------
// STL

struct StlLayout {
  bool binary = false;
  uint64_t triangles = 0;
  std::string_view bytes;  // what Assimp should parse
};

class StlTokens {
 public:
  explicit StlTokens(std::string_view text) : lines_(text) {}
  bool next(std::string_view& token) {
    while (!tokens_.next(token)) {
      std::string_view line;
      if (!lines_.next(line)) return false;
      tokens_ = Tokens(line);
    }
    return true;
  }
  // Assimp reads a vertex's or normal's numbers from its own line only.
  bool next_in_line(std::string_view& token) { return tokens_.next(token); }
  void skip_line() { tokens_ = Tokens({}); }
  std::size_t line() const { return lines_.number(); }

 private:
  Lines lines_;
  Tokens tokens_{{}};
};

uint64_t check_ascii_stl(const fs::path& path, std::string_view text) {
  check_text(path, text, "STL");
  StlTokens tokens(text);
  std::string_view token;
  const auto expect = [&](std::string_view keyword, std::string_view after) {
    if (!tokens.next(token))
      fail_at(path, tokens.line(), "the file ends where '" + std::string(keyword) + "' was expected");
    if (token != keyword) {
      fail_at(path, tokens.line(),
              "expected '" + std::string(keyword) + "' " + std::string(after) + ", found " + quote(token));
    }
  };

  uint64_t facets = 0;
  bool in_solid = false;
  while (tokens.next(token)) {
    if (!in_solid && token.starts_with("solid")) {
      tokens.skip_line();  // the solid's name
      in_solid = true;
    } else if (in_solid && token == "endsolid") {
      tokens.skip_line();
      in_solid = false;
    } else if (in_solid && token == "facet") {
      const std::size_t facet_line = tokens.line();
      if (!tokens.next_in_line(token) || token != "normal") {
        fail_at(path, facet_line, "expected 'normal' after 'facet' on the same line");
      }
      for (int k = 0; k < 3; ++k) {
        // The normal is ignored (orientation comes from the vertex order), but must be there
        // for the reader to stay in step.
        if (!tokens.next_in_line(token))
          fail_at(path, tokens.line(), "the facet normal needs three numbers on its line");
        if (!parse_number(token))
          fail_at(path, tokens.line(), "the facet normal needs three numbers, found " + quote(token));
      }
      expect("outer", "after the facet normal");
      expect("loop", "after 'outer'");
      int corners = 0;
      for (;;) {
        if (!tokens.next(token)) fail_at(path, tokens.line(), "the file ends inside a facet");
        if (token != "vertex") break;
        for (int k = 0; k < 3; ++k) {
          if (!tokens.next_in_line(token))
            fail_at(path, tokens.line(), "a vertex needs three coordinates on its line");
          parse_coordinate(path, tokens.line(), token);
        }
        ++corners;
      }
      if (token != "endloop")
        fail_at(path, tokens.line(), "expected 'vertex' or 'endloop', found " + quote(token));
      if (corners != 3) {
        fail_at(path, facet_line,
                "facet has " + std::to_string(corners) + " vertices; STL facets must be triangles");
      }
      expect("endfacet", "after 'endloop'");
      ++facets;
    } else {
      fail_at(path, tokens.line(),
              std::string(in_solid ? "expected 'facet' or 'endsolid'"
                                   : "expected 'solid' or the end of the file") +
                  ", found " + quote(token));
    }
  }
  return facets;
}

StlLayout check_stl(const fs::path& path, std::string_view bytes) {
  const uint64_t size = bytes.size();
  if (size >= 84) {
    uint32_t declared = 0;
    std::memcpy(&declared, bytes.data() + 80, sizeof declared);  // little-endian, like every target
    const uint64_t needed = 84 + 50 * uint64_t{declared};
    if (needed == size) {
      if (declared == 0) fail(path, "contains no triangles (binary STL with a count of 0)");
      return {true, declared, bytes};
    }
  }

  // ASCII STL never holds a NUL; a binary header often starts with "solid" anyway.
  std::string_view text = strip_utf8_bom(bytes);
  // Assimp only recognises ascii STL when "solid" comes first on the first line.
  while (!text.empty() && (is_blank(text[0]) || text[0] == '\r' || text[0] == '\n')) text.remove_prefix(1);
  const bool starts_with_solid = text.starts_with("solid");
  if (starts_with_solid && std::memchr(bytes.data(), 0, bytes.size()) == nullptr) {
    const uint64_t facets = check_ascii_stl(path, text);
    if (facets == 0) fail(path, "contains no triangles (an ASCII STL solid without facets)");
    return {false, facets, text};
  }

  if (size < 84) {
    fail(path,
         "is neither an ASCII STL (it does not start with 'solid') nor a binary STL (shorter than the "
         "84-byte header)");
  }
  uint32_t declared = 0;
  std::memcpy(&declared, bytes.data() + 80, sizeof declared);
  fail(path, std::string("is not an ASCII STL (") +
                 (starts_with_solid ? "it starts with 'solid' but holds binary zeros"
                                    : "it does not start with 'solid'") +
                 "), and as a binary STL its header declares " + std::to_string(declared) +
                 " triangles, which need " + std::to_string(84 + 50 * uint64_t{declared}) +
                 " bytes, but the file has " + std::to_string(size) + " bytes: it is truncated or corrupt");
}

// ---------------------------------------------------------------------------------------------
// OBJ

// What Assimp gets instead of the OBJ file: its vertex and polygon statements only, with
// absolute vertex indices. Assimp 5.2's OBJ reader crashes on some material statements (a
// "map_Kd" line after an "mtllib" it cannot open writes through a null pointer), and nothing but
// positions and faces matters here.
struct ObjGeometry {
  std::string text;
  uint64_t used_records = 0;  // vertex records the polygons use: Assimp gives every corner its own
                              // vertex, so the weld count is measured against these
};

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
        const auto [end, error] =
            std::from_chars(index_text.data(), index_text.data() + index_text.size(), index);
        if (index_text.empty() || error != std::errc{} || end != index_text.data() + index_text.size()) {
          fail_at(path, lines.number(),
                  quote(token) + " is not a face corner (vertex index, optionally /texture/normal)");
        }
        if (index == 0)
          fail_at(path, lines.number(), "face index 0 is invalid: OBJ vertex indices start at 1");
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

// ---------------------------------------------------------------------------------------------
// OFF. The accepted layout is the one Assimp parses faithfully: the header keyword, the three
// counts on one line, then one vertex per line and one face per line, empty lines allowed
// between them but not comments.

void check_off(const fs::path& path, std::string_view text) {
  check_text(path, text, "OFF");
  Lines lines(text);
  std::string_view line, token;

  // Header tokens until a '#' comment; returns false at the end of the line.
  Tokens tokens{{}};
  const auto next_in_line = [&]() { return tokens.next(token) && !token.starts_with('#'); };
  const auto next_header_line = [&]() {
    while (lines.next(line)) {
      tokens = Tokens(line);
      Tokens probe(line);
      std::string_view first;
      if (probe.next(first) && !first.starts_with('#')) return true;
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
  for (char prefix : {'C', 'N', '4', 'n'}) {
    if (keyword.starts_with(prefix)) {
      keyword.remove_prefix(1);
      has_dimension = has_dimension || prefix == 'n';
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
      fail_at(path, lines.number(),
              "expected the vertex, face and edge counts, found " + quote(count_text[k]));
    }
    counts[k] = *count;
  }
  const std::size_t header_line = lines.number();
  const uint64_t vertex_count = counts[0], face_count = counts[1];
  if (vertex_count >= (uint64_t{1} << 31) || face_count >= (uint64_t{1} << 31)) {
    fail_at(path, header_line,
            "the header declares " + std::to_string(vertex_count) + " vertices and " +
                std::to_string(face_count) + " faces, more than the file can hold");
  }
  if (face_count == 0) fail(path, "contains no triangles (the OFF header declares 0 faces)");
  if (vertex_count == 0) fail(path, "contains no vertices (the OFF header declares 0 vertices)");

  // Before the first vertex Assimp skips blank and comment lines as part of the header; after
  // it only empty lines, so there a comment or a line of spaces would be taken for a vertex or
  // face.
  bool first_body_line = true;
  const auto next_body_line = [&](const char* what, uint64_t index, uint64_t count) {
    std::string_view first;
    for (;;) {
      if (!lines.next(line)) {
        fail(path, "the file ends after " + std::to_string(index) + " of the " + std::to_string(count) + " " +
                       what + " its header declares (one per line is expected)");
      }
      if (line.empty()) continue;
      const bool has_token = Tokens(line).next(first);
      if (first_body_line && (!has_token || first.starts_with('#'))) continue;
      if (!has_token)
        fail_at(path, lines.number(),
                std::string("expected one of the ") + what + ", found a line of spaces");
      if (first.starts_with('#'))
        fail_at(path, lines.number(), std::string("comments between the ") + what + " are not supported");
      break;
    }
    first_body_line = false;
    if (line.size() > kMaxOffLine)
      fail_at(path, lines.number(), "line is longer than " + std::to_string(kMaxOffLine) + " characters");
    return Tokens(line);
  };

  for (uint64_t v = 0; v < vertex_count; ++v) {
    Tokens tokens = next_body_line("vertices", v, vertex_count);
    for (int k = 0; k < 3; ++k) {
      if (!tokens.next(token) || token.starts_with('#'))
        fail_at(path, lines.number(), "a vertex needs three coordinates");
      parse_coordinate(path, lines.number(), token);
    }
    // The values the header keyword adds (normal, colour, ...) must be numbers too, or Assimp
    // fails on them with a message that quotes the rest of the file.
    std::size_t values = 3;
    for (; tokens.next(token) && !token.starts_with('#'); ++values) {
      if (!parse_number(token)) fail_at(path, lines.number(), quote(token) + " is not a number");
    }
    if (values < vertex_values) {
      fail_at(path, lines.number(),
              "the header keyword asks for " + std::to_string(vertex_values) + " values per vertex, found " +
                  std::to_string(values));
    }
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
    for (uint64_t k = 0; k < *corners; ++k) {
      if (!tokens.next(token) || token.starts_with('#')) {
        fail_at(path, lines.number(),
                "face has fewer indices than its corner count " + std::to_string(*corners));
      }
      const auto index = parse_count(token);
      if (!index) fail_at(path, lines.number(), quote(token) + " is not a vertex index");
      if (*index >= vertex_count) {
        fail_at(path, lines.number(),
                "face refers to vertex " + std::to_string(*index) + ", but the file has only " +
                    std::to_string(vertex_count) + " vertices (indices start at 0)");
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// PLY: the header is parsed the way Assimp parses it, and the data walked once, element by
// element, so that a truncated file or a corrupt count is reported before Assimp allocates for
// it or reads past the end. Assimp 5.2 writes past a buffer when an element name repeats, and
// its ascii reader accepts short, merged or blank lines by filling in zeros; here each element
// is exactly one line with exactly its properties' values. Indices and coordinates are checked
// on the parsed scene.

struct PlyType {
  std::size_t size = 0;  // 0: unknown type
  bool is_signed = false;
  bool is_float = false;
};

PlyType ply_type(std::string_view name) {
  if (name == "char" || name == "int8") return {1, true, false};
  if (name == "uchar" || name == "uint8") return {1, false, false};
  if (name == "short" || name == "int16") return {2, true, false};
  if (name == "ushort" || name == "uint16") return {2, false, false};
  if (name == "int" || name == "int32") return {4, true, false};
  if (name == "uint" || name == "uint32") return {4, false, false};
  if (name == "float" || name == "float32") return {4, true, true};
  if (name == "double" || name == "float64") return {8, true, true};
  return {};
}

struct PlyProperty {
  bool list = false;
  PlyType count;  // lists only
  PlyType value;
  std::string_view name;
};

struct PlyElement {
  std::string_view name;
  uint64_t count = 0;
  std::size_t line = 0;
  std::vector<PlyProperty> properties;
};

// A binary list length; nullopt when negative.
std::optional<uint64_t> read_ply_count(const char* data, PlyType type, bool big_endian) {
  uint64_t raw = 0;
  for (std::size_t i = 0; i < type.size; ++i) {
    const auto byte = static_cast<unsigned char>(data[big_endian ? i : type.size - 1 - i]);
    raw = (raw << 8) | byte;
  }
  if (type.is_signed && (raw >> (8 * type.size - 1)) != 0) return std::nullopt;
  return raw;
}

// An ascii value of an integer property: Assimp reads digits and stops, so "1.5" would become
// two values.
bool is_ply_integer(std::string_view token, bool is_signed) {
  if (is_signed && token.starts_with('-')) token.remove_prefix(1);
  return !token.empty() && token.size() <= 10 &&
         token.find_first_not_of("0123456789") == std::string_view::npos;
}

// Where the parts of a checked PLY file start, for the padding read_surface adds.
struct PlyLayout {
  bool binary = false;
  std::size_t header_body = 0;  // just after the format line
  std::size_t data = 0;         // just after the end_header line
};

// Assimp 5.2 skips a line feed at the start of binary PLY data, so a file whose first data
// byte is 0x0a (one in 256 of them) is read one byte out of step. A one-byte element placed
// first in the data, with a letter as its value, keeps the real data where it belongs. It must
// be an element Assimp knows ("edge", which it reads and ignores): it takes the count of any
// other element for 0.
std::string pad_binary_ply(std::string_view bytes, const PlyLayout& layout) {
  std::string out;
  out.reserve(bytes.size() + 64);
  out.append(bytes.substr(0, layout.header_body));
  out.append("element edge 1\nproperty uchar mchex_padding\n");
  out.append(bytes.substr(layout.header_body, layout.data - layout.header_body));
  out.push_back('P');
  out.append(bytes.substr(layout.data));
  return out;
}

PlyLayout check_ply(const fs::path& path, std::string_view bytes) {
  Lines lines(bytes);
  std::string_view line, token;
  const auto trimmed = [](std::string_view s) {
    while (!s.empty() && is_blank(s.back())) s.remove_suffix(1);
    return s;
  };
  if (!lines.next(line) || (trimmed(line) != "ply" && trimmed(line) != "PLY")) {
    fail(path, "does not start with 'ply', so it is not a PLY file");
  }

  // Assimp reads the format from the second line only.
  enum { ascii, little, big } format = ascii;
  lines.next(line);
  PlyLayout layout;
  layout.header_body = lines.position();
  {
    Tokens tokens(line);
    if (!tokens.next(token) || token != "format")
      fail_at(path, lines.number(), "the second line of a PLY file must be 'format ...'");
    tokens.next(token);
    if (token == "ascii") {
      format = ascii;
    } else if (token == "binary_little_endian") {
      format = little;
    } else if (token == "binary_big_endian") {
      format = big;
    } else {
      fail_at(path, lines.number(), "unknown PLY format " + quote(token));
    }
  }

  std::vector<PlyElement> elements;
  bool ended = false, in_element = false;
  while (!ended && lines.next(line)) {
    Tokens tokens(line);
    const std::size_t n = lines.number();
    if (!tokens.next(token)) {
      in_element = false;  // Assimp ends an element's property list at any other line
      continue;
    }
    if (token == "comment") continue;
    if (token == "end_header") {
      ended = true;
    } else if (token == "element") {
      PlyElement element;
      element.line = n;
      std::string_view count_text;
      if (!tokens.next(element.name) || !tokens.next(count_text))
        fail_at(path, n, "an element needs a name and a count");
      const auto count = parse_count(count_text);
      if (!count) fail_at(path, n, quote(count_text) + " is not an element count");
      element.count = *count;
      // Assimp 5.2 reads the count of an element it does not know as 0 and then parses the
      // following data as if that element were absent.
      if (element.name != "vertex" && element.name != "face" && element.name != "edge" &&
          element.name != "material") {
        fail_at(path, n,
                "the element " + quote(element.name) +
                    " is not supported (only vertex, face, edge and material elements are read)");
      }
      for (const PlyElement& other : elements) {
        if (other.name == element.name)
          fail_at(path, n, "the element " + quote(element.name) + " is declared twice");
      }
      elements.push_back(element);
      in_element = true;
    } else if (token == "property") {
      if (!in_element) fail_at(path, n, "a property line that does not follow an element or its properties");
      PlyProperty property;
      std::string_view type;
      tokens.next(type);
      if (type == "list") {
        property.list = true;
        tokens.next(type);
        property.count = ply_type(type);
        if (property.count.size == 0 || property.count.is_float)
          fail_at(path, n, "a list length needs an integer type, found " + quote(type));
        tokens.next(type);
      }
      property.value = ply_type(type);
      if (property.value.size == 0) fail_at(path, n, "unknown PLY property type " + quote(type));
      tokens.next(property.name);
      elements.back().properties.push_back(property);
    } else {
      // Ignored, as Assimp ignores it (Blender once wrote comments without 'comment').
      in_element = false;
    }
  }
  if (!ended) fail(path, "has no 'end_header' line: the PLY header is incomplete");
  layout.data = lines.position();
  layout.binary = format != ascii;
  // Assimp's PLY reader looks for the line feed after a carriage return, past the line if need be.
  const auto has_bare_carriage_return = [](std::string_view text) {
    for (std::size_t at = text.find('\r'); at != std::string_view::npos; at = text.find('\r', at + 1)) {
      if (at + 1 == text.size() || text[at + 1] != '\n') return true;
    }
    return false;
  };
  if (has_bare_carriage_return(bytes.substr(0, layout.data))) {
    fail(path, "ends PLY header lines with a bare carriage return; save it with LF or CRLF line ends");
  }
  // Without positions Assimp fails with "Unable to extract mesh data".
  const auto vertex =
      std::find_if(elements.begin(), elements.end(), [](const PlyElement& e) { return e.name == "vertex"; });
  const auto has_axis = [&](std::string_view axis) {
    return vertex != elements.end() &&
           std::any_of(vertex->properties.begin(), vertex->properties.end(),
                       [&](const PlyProperty& p) { return !p.list && p.name == axis; });
  };
  if (!has_axis("x") || !has_axis("y") || !has_axis("z")) {
    fail(path, "has no 'vertex' element with x, y and z properties, so it holds no positions");
  }
  if (vertex->count == 0) fail(path, "contains no triangles (the PLY header declares 0 vertices)");

  // Every element instance takes at least a byte (or a line), so this bounds the walk below by
  // the file size even when a count is absurd.
  const uint64_t data_bytes = bytes.size() - lines.position();
  for (const PlyElement& element : elements) {
    uint64_t smallest = 0;
    for (const PlyProperty& property : element.properties)
      smallest += format == ascii ? 2 : (property.list ? property.count.size : property.value.size);
    if (element.count > (data_bytes + 1) / std::max<uint64_t>(smallest, 1)) {
      fail_at(path, element.line,
              "the header declares " + std::to_string(element.count) + " " + quote(element.name) +
                  " elements, but only " + std::to_string(data_bytes) +
                  " bytes of data follow the header: the file is truncated or corrupt");
    }
  }
  const auto truncated = [&](const PlyElement& element, uint64_t i) {
    fail(path, "the data ends inside " + quote(element.name) + " element " + std::to_string(i + 1) + " of " +
                   std::to_string(element.count) + ": the file is truncated or corrupt");
  };

  if (layout.binary) {
    std::size_t at = lines.position();
    for (const PlyElement& element : elements) {
      for (uint64_t i = 0; i < element.count; ++i) {
        for (const PlyProperty& property : element.properties) {
          std::size_t items = 1;
          if (property.list) {
            if (bytes.size() - at < property.count.size) truncated(element, i);
            const auto length = read_ply_count(bytes.data() + at, property.count, format == big);
            if (!length) fail(path, "a " + quote(element.name) + " element has a negative list length");
            at += property.count.size;
            if (*length > (bytes.size() - at) / property.value.size) truncated(element, i);
            items = static_cast<std::size_t>(*length);
          }
          if (bytes.size() - at < items * property.value.size) truncated(element, i);
          at += items * property.value.size;
        }
      }
    }
    return layout;
  }

  const std::string_view data = bytes.substr(layout.data);
  check_text(path, data, "PLY");
  if (has_bare_carriage_return(data)) {
    fail(path, "ends PLY data lines with a bare carriage return; save it with LF or CRLF line ends");
  }
  for (const PlyElement& element : elements) {
    for (uint64_t i = 0; i < element.count; ++i) {
      if (!lines.next(line)) truncated(element, i);
      const std::size_t n = lines.number();
      if (trimmed(line).empty())
        fail_at(path, n, "a blank line where a " + quote(element.name) + " element was expected");
      Tokens tokens(line);
      const auto value = [&](PlyType type) {
        if (!tokens.next(token)) fail_at(path, n, "too few values for a " + quote(element.name) + " element");
        const bool ok =
            type.is_float ? parse_number(token).has_value() : is_ply_integer(token, type.is_signed);
        if (!ok) fail_at(path, n, quote(token) + " is not " + (type.is_float ? "a number" : "an integer"));
      };
      for (const PlyProperty& property : element.properties) {
        if (!property.list) {
          value(property.value);
          continue;
        }
        if (!tokens.next(token)) fail_at(path, n, "too few values for a " + quote(element.name) + " element");
        const auto length = parse_count(token);
        if (!length) fail_at(path, n, quote(token) + " is not a list length");
        if (*length > line.size())
          fail_at(path, n, "too few values for a " + quote(element.name) + " element");
        for (uint64_t k = 0; k < *length; ++k) value(property.value);
      }
      if (tokens.next(token)) {
        fail_at(path, n,
                "more values than a " + quote(element.name) +
                    " element has properties (one element per line is expected)");
      }
    }
  }
  return layout;
}

// ---------------------------------------------------------------------------------------------
// Assimp

// Assimp may only see the buffer we hand it: an OBJ's "mtllib" must not make it open (or block
// on) another file.
class NoFileAccess : public Assimp::IOSystem {
 public:
  bool Exists(const char*) const override { return false; }
  char getOsSeparator() const override { return '/'; }
  Assimp::IOStream* Open(const char*, const char*) override { return nullptr; }
  void Close(Assimp::IOStream*) override {}
};

std::string assimp_reason(const Assimp::Importer& importer) {
  std::string reason = importer.GetErrorString();
  // Reading from memory, Assimp names the file "$$$___magic___$$$.<ext>".
  for (std::size_t at; (at = reason.find("$$$___magic___$$$")) != std::string::npos;) {
    std::size_t end = at + 17;
    while (end < reason.size() && reason[end] != ' ' && reason[end] != ',') ++end;
    if (end > at + 17 && reason[end - 1] == '.') --end;
    reason.replace(at, end - at, "the file");
  }
  // Some messages quote the rest of the file; the first line says what went wrong.
  reason = reason.substr(0, reason.find_first_of("\r\n"));
  if (reason.size() > 160) reason = reason.substr(0, 160) + "...";
  return reason.empty() ? "unknown error" : reason;
}

// Checks what Assimp produced before triangulation runs on it. Returns whether any face is a
// polygon (more than three corners).
bool check_scene(const fs::path& path, const aiScene& scene) {
  bool polygons = false;
  for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
    const aiMesh* mesh = scene.mMeshes[m];
    if (mesh == nullptr) fail(path, "the reader returned an empty mesh");
    if (mesh->mNumVertices > 0 && mesh->mVertices == nullptr)
      fail(path, "the reader returned a mesh without positions");
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const aiVector3D& p = mesh->mVertices[v];
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
        char buffer[128];
        std::snprintf(buffer, sizeof buffer, "(%g, %g, %g)", static_cast<double>(p.x),
                      static_cast<double>(p.y), static_cast<double>(p.z));
        fail(path, std::string("has a vertex with a non-finite coordinate ") + buffer +
                       "; NaN and infinity cannot be meshed");
      }
    }
    if (mesh->mNumFaces > 0 && mesh->mFaces == nullptr)
      fail(path, "the reader returned a mesh without faces");
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices == 0 || face.mIndices == nullptr) fail(path, "has a face without vertices");
      for (unsigned k = 0; k < face.mNumIndices; ++k) {
        if (face.mIndices[k] >= mesh->mNumVertices) {
          fail(path, "a face refers to vertex " + std::to_string(face.mIndices[k]) + ", but there are only " +
                         std::to_string(mesh->mNumVertices) + " vertices");
        }
      }
      if (face.mNumIndices > kMaxPolygonCorners) {
        fail(path, "has a face with " + std::to_string(face.mNumIndices) + " corners; at most " +
                       std::to_string(kMaxPolygonCorners) + " are supported (triangulate the model first)");
      }
      polygons = polygons || face.mNumIndices > 3;
    }
  }
  return polygons;
}

struct Collected {
  TriangleSurface surface;
  std::size_t other_primitives = 0;  // points and lines, ignored
};

// Every mesh instance in the node tree, with its node's transform; vertices are kept only if a
// triangle uses them, in order of first use (the weld then keeps that order).
Collected collect_triangles(const fs::path& path, const aiScene& scene) {
  Collected out;
  if (scene.mRootNode == nullptr) return out;
  std::vector<std::pair<const aiNode*, aiMatrix4x4>> stack{
      {scene.mRootNode, scene.mRootNode->mTransformation}};
  std::vector<uint32_t> remap;
  while (!stack.empty()) {
    const auto [node, transform] = stack.back();
    stack.pop_back();
    for (unsigned c = node->mNumChildren; c-- > 0;) {
      if (node->mChildren[c] != nullptr)
        stack.emplace_back(node->mChildren[c], transform * node->mChildren[c]->mTransformation);
    }
    const bool identity = transform.IsIdentity();
    for (unsigned i = 0; i < node->mNumMeshes; ++i) {
      if (node->mMeshes[i] >= scene.mNumMeshes)
        fail(path, "the reader returned a scene that refers to a missing mesh");
      const aiMesh& mesh = *scene.mMeshes[node->mMeshes[i]];
      remap.assign(mesh.mNumVertices, std::numeric_limits<uint32_t>::max());
      for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
        const aiFace& face = mesh.mFaces[f];
        if (face.mNumIndices < 3) {
          ++out.other_primitives;
          continue;
        }
        if (face.mNumIndices > 3) fail(path, "a polygon could not be split into triangles");
        std::array<uint32_t, 3> triangle{};
        for (unsigned k = 0; k < 3; ++k) {
          const unsigned v = face.mIndices[k];
          if (v >= mesh.mNumVertices) fail(path, "a triangle refers to a missing vertex");
          if (remap[v] == std::numeric_limits<uint32_t>::max()) {
            if (out.surface.vertices.size() >= std::numeric_limits<uint32_t>::max())
              fail(path, "has more than 2^32 vertices");
            remap[v] = static_cast<uint32_t>(out.surface.vertices.size());
            aiVector3D p = mesh.mVertices[v];
            if (!identity) p = transform * p;
            out.surface.vertices.push_back(
                {static_cast<double>(p.x), static_cast<double>(p.y), static_cast<double>(p.z)});
            if (!is_finite(out.surface.vertices.back()))
              fail(path, "has a vertex that becomes non-finite when placed in the scene");
          }
          triangle[k] = remap[v];
        }
        out.surface.triangles.push_back(triangle);
      }
    }
  }
  return out;
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
      to_parse = layout.bytes;
      // Assimp converts a file that starts with a byte-order mark to UTF-8 before looking at
      // it, which shortens or scrambles a binary STL whose free-text header happens to start
      // that way. The header means nothing here.
      const auto starts_with = [&](std::string_view mark) { return to_parse.starts_with(mark); };
      using namespace std::string_view_literals;
      if (layout.binary && (starts_with("\xEF\xBB\xBF"sv) || starts_with("\xFE\xFF"sv) ||
                            starts_with("\xFF\xFE"sv) || starts_with("\x00\x00\xFE\xFF"sv))) {
        patched = std::string(to_parse);
        std::fill_n(patched.begin(), 4, '\0');
        to_parse = patched;
      }
      // Assimp takes an ascii file for binary when 84 + 50 n wraps (32 bits) to its size; a
      // trailing newline changes the size and nothing else.
      if (!layout.binary && to_parse.size() >= 84) {
        uint32_t declared = 0;
        std::memcpy(&declared, to_parse.data() + 80, sizeof declared);
        if (static_cast<uint32_t>(84u + 50u * declared) == static_cast<uint32_t>(to_parse.size())) {
          patched = std::string(to_parse) + "\n";
          to_parse = patched;
        }
      }
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
      to_parse = strip_utf8_bom(bytes);
      check_off(path, to_parse);
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

  Assimp::Importer importer;
  importer.SetIOHandler(new NoFileAccess);  // the importer owns it
  const char* hint = format == Format::stl   ? "stl"
                     : format == Format::obj ? "obj"
                     : format == Format::off ? "off"
                                             : "ply";
  const aiScene* scene = nullptr;
  try {
    scene = importer.ReadFileFromMemory(to_parse.data(), to_parse.size(), 0, hint);
    if (scene == nullptr) {
      fail(path, std::string("could not be read as ") + format_name(format) + ": " + assimp_reason(importer));
    }
    if (check_scene(path, *scene)) {
      scene = importer.ApplyPostProcessing(aiProcess_Triangulate);
      if (scene == nullptr)
        fail(path, "its polygons could not be split into triangles: " + assimp_reason(importer));
    }
  } catch (const std::bad_alloc&) {
    fail(path, "ran out of memory while reading");
  }

  Collected collected = collect_triangles(path, *scene);
  TriangleSurface& surface = collected.surface;
  if (surface.triangles.empty()) {
    fail(path, collected.other_primitives > 0 ? "contains no triangles, only points or lines"
                                              : "contains no triangles");
  }
  if (expected_triangles && surface.triangles.size() != *expected_triangles) {
    fail(path, "the STL reader found " + std::to_string(surface.triangles.size()) +
                   " triangles where the file has " + std::to_string(*expected_triangles) + " facets");
  }

  const std::size_t merged = weld_vertices(surface);
  if (welded != nullptr) {
    *welded = !vertex_records
                  ? merged
                  : static_cast<std::size_t>(*vertex_records -
                                             std::min<uint64_t>(*vertex_records, surface.vertices.size()));
  }
  return surface;
}

}  // namespace mchex
