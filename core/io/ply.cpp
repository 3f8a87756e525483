// PLY, ascii and binary: the precheck of read_surface (surface_io.cpp says why there is one).
//
// The header is parsed the way Assimp parses it, and the data walked once, element by
// element, so that a truncated file or a corrupt count is reported before Assimp allocates for
// it or reads past the end. Assimp 5.2 writes past a buffer when an element name repeats, and
// its ascii reader accepts short, merged or blank lines by filling in zeros; here each element
// is exactly one line with exactly its properties' values. Indices and coordinates are checked
// on the parsed scene.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/io/surface_formats.h"
#include "core/io/surface_text.h"

namespace mchex::io_detail {
namespace {

namespace fs = std::filesystem;

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
  return !token.empty() && token.size() <= 10 && token.find_first_not_of("0123456789") == std::string_view::npos;
}

}  // namespace

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
    while (!s.empty() && is_space_or_tab(s.back())) s.remove_suffix(1);
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
      if (element.name != "vertex" && element.name != "face" && element.name != "edge" && element.name != "material") {
        fail_at(path, n,
                "the element " + quote(element.name) +
                    " is not supported (only vertex, face, edge and material elements are read)");
      }
      for (const PlyElement& other : elements) {
        if (other.name == element.name) fail_at(path, n, "the element " + quote(element.name) + " is declared twice");
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
    return vertex != elements.end() && std::any_of(vertex->properties.begin(), vertex->properties.end(),
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
        const bool ok = type.is_float ? parse_number(token).has_value() : is_ply_integer(token, type.is_signed);
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
        if (*length > line.size()) fail_at(path, n, "too few values for a " + quote(element.name) + " element");
        for (uint64_t k = 0; k < *length; ++k) value(property.value);
      }
      if (tokens.next(token)) {
        fail_at(
            path, n,
            "more values than a " + quote(element.name) + " element has properties (one element per line is expected)");
      }
    }
  }
  return layout;
}

}  // namespace mchex::io_detail
