// STL, ascii and binary: the precheck of read_surface (surface_io.cpp says why there is one).
//
// Binary is recognised by its size (84 + 50 n bytes for the n triangles its header declares),
// ascii by "solid" first and no NUL byte, the test Assimp applies; anything else is refused with
// what each reading would need. Ascii is walked facet by facet the way Assimp reads it (normal and
// vertex numbers on their own lines), and a facet must have exactly three vertices, since Assimp
// drops the rest. The facet count is returned so that read_surface can check that the reader
// found every facet.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

#include "core/io/surface_formats.h"
#include "core/io/surface_text.h"

namespace mchex::io_detail {
namespace {

namespace fs = std::filesystem;

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
          if (!tokens.next_in_line(token)) fail_at(path, tokens.line(), "a vertex needs three coordinates on its line");
          parse_coordinate(path, tokens.line(), token);
        }
        ++corners;
      }
      if (token != "endloop") fail_at(path, tokens.line(), "expected 'vertex' or 'endloop', found " + quote(token));
      if (corners != 3) {
        fail_at(path, facet_line, "facet has " + std::to_string(corners) + " vertices; STL facets must be triangles");
      }
      expect("endfacet", "after 'endloop'");
      ++facets;
    } else {
      fail_at(path, tokens.line(),
              std::string(in_solid ? "expected 'facet' or 'endsolid'" : "expected 'solid' or the end of the file") +
                  ", found " + quote(token));
    }
  }
  return facets;
}

}  // namespace

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
  while (!text.empty() && (is_space_or_tab(text[0]) || text[0] == '\r' || text[0] == '\n')) text.remove_prefix(1);
  const bool starts_with_solid = text.starts_with("solid");
  if (starts_with_solid && std::memchr(bytes.data(), 0, bytes.size()) == nullptr) {
    const uint64_t facets = check_ascii_stl(path, text);
    if (facets == 0) fail(path, "contains no triangles (an ASCII STL solid without facets)");
    return {false, facets, text};
  }

  if (size < 84) {
    fail(path, "is neither an ASCII STL (it does not start with 'solid') nor a binary STL (shorter than the "
               "84-byte header)");
  }
  uint32_t declared = 0;
  std::memcpy(&declared, bytes.data() + 80, sizeof declared);
  fail(path,
       std::string("is not an ASCII STL (") +
           (starts_with_solid ? "it starts with 'solid' but holds binary zeros" : "it does not start with 'solid'") +
           "), and as a binary STL its header declares " + std::to_string(declared) + " triangles, which need " +
           std::to_string(84 + 50 * uint64_t{declared}) + " bytes, but the file has " + std::to_string(size) +
           " bytes: it is truncated or corrupt");
}

std::string_view stl_assimp_input(const StlLayout& layout, std::string& patched) {
  std::string_view to_parse = layout.bytes;
  // Assimp converts a file that starts with a byte-order mark to UTF-8 before looking at
  // it, which shortens or scrambles a binary STL whose free-text header happens to start
  // that way. The header means nothing here.
  const auto starts_with = [&](std::string_view mark) { return to_parse.starts_with(mark); };
  using namespace std::string_view_literals;
  if (layout.binary && (starts_with("\xEF\xBB\xBF"sv) || starts_with("\xFE\xFF"sv) || starts_with("\xFF\xFE"sv) ||
                        starts_with("\x00\x00\xFE\xFF"sv))) {
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
  return to_parse;
}

}  // namespace mchex::io_detail
