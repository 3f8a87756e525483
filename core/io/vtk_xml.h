// Just enough XML for VTK files: elements, attributes, text; comments, declarations and
// processing instructions are skipped. Parsing stops at <AppendedData>, whose raw content is not
// XML; the arrays there are located by their offsets and sizes (vtu.cpp).
//
// The document refers into the text it was parsed from (string_views), so the text must outlive
// it. Malformed or truncated XML throws FormatError("XML: reason").
#pragma once

#include <cstddef>
#include <limits>
#include <optional>
#include <string_view>
#include <utility>
#include <vector>

namespace mchex::io_detail {

struct XmlElement {
  std::string_view name;
  std::vector<std::pair<std::string_view, std::string_view>> attributes;
  std::size_t parent = 0;
  std::string_view content;

  std::optional<std::string_view> attribute(std::string_view key) const {
    for (const auto& [k, v] : attributes)
      if (k == key) return v;
    return std::nullopt;
  }
};

inline constexpr std::size_t kNoParent = std::numeric_limits<std::size_t>::max();

struct XmlDocument {
  std::vector<XmlElement> elements;  // in document order, elements[0] the root
  std::size_t appended = kNoParent;  // the AppendedData element, if any
  std::size_t appended_begin = 0;    // offset of the byte after its '_'
};

XmlDocument parse_vtk_xml(std::string_view text);

}  // namespace mchex::io_detail
