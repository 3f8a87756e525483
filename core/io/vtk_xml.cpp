#include "core/io/vtk_xml.h"

#include <string>

#include "core/io/format_error.h"
#include "core/io/text_numbers.h"

namespace mchex::io_detail {
namespace {

bool is_name_char(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == ':' ||
         c == '-' || c == '.';
}

[[noreturn]] void xml_fail(const std::string& message) { throw FormatError("XML: " + message); }

}  // namespace

XmlDocument parse_vtk_xml(std::string_view text) {
  XmlDocument doc;
  std::vector<std::size_t> open;           // element indices
  std::vector<std::size_t> content_start;  // per open element
  std::size_t pos = 0;
  for (;;) {
    const std::size_t lt = text.find('<', pos);
    if (lt == std::string_view::npos) break;
    auto skip_to = [&](std::string_view end_marker) {
      const std::size_t e = text.find(end_marker, lt + 2);
      if (e == std::string_view::npos) xml_fail("unterminated '" + shown(text.substr(lt, 4)) + "' (truncated file?)");
      pos = e + end_marker.size();
    };
    if (text.compare(lt, 4, "<!--") == 0) {
      skip_to("-->");
      continue;
    }
    if (text.compare(lt, 2, "<?") == 0) {
      skip_to("?>");
      continue;
    }
    if (text.compare(lt, 2, "<!") == 0) {
      skip_to(">");
      continue;
    }
    if (text.compare(lt, 2, "</") == 0) {
      const std::size_t gt = text.find('>', lt);
      if (gt == std::string_view::npos) xml_fail("unterminated end tag (truncated file?)");
      std::string_view name = text.substr(lt + 2, gt - lt - 2);
      while (!name.empty() && is_blank(name.back())) name.remove_suffix(1);
      if (open.empty() || doc.elements[open.back()].name != name) xml_fail("unexpected </" + shown(name) + ">");
      doc.elements[open.back()].content = text.substr(content_start.back(), lt - content_start.back());
      open.pop_back();
      content_start.pop_back();
      pos = gt + 1;
      if (open.empty()) return doc;
      continue;
    }
    std::size_t i = lt + 1;
    while (i < text.size() && is_name_char(text[i])) ++i;
    XmlElement element;
    element.name = text.substr(lt + 1, i - lt - 1);
    if (element.name.empty()) xml_fail("malformed tag");
    if (open.empty() && !doc.elements.empty()) xml_fail("more than one root element");
    element.parent = open.empty() ? kNoParent : open.back();
    bool self_closing = false;
    for (;;) {
      while (i < text.size() && is_blank(text[i])) ++i;
      if (i >= text.size()) xml_fail("unterminated <" + shown(element.name) + "> (truncated file?)");
      if (text[i] == '>') {
        ++i;
        break;
      }
      if (text.compare(i, 2, "/>") == 0) {
        i += 2;
        self_closing = true;
        break;
      }
      const std::size_t key_begin = i;
      while (i < text.size() && is_name_char(text[i])) ++i;
      const std::string_view key = text.substr(key_begin, i - key_begin);
      while (i < text.size() && is_blank(text[i])) ++i;
      if (key.empty() || i >= text.size() || text[i] != '=')
        xml_fail("malformed attribute in <" + shown(element.name) + ">");
      ++i;
      while (i < text.size() && is_blank(text[i])) ++i;
      if (i >= text.size() || (text[i] != '"' && text[i] != '\'')) xml_fail("unquoted attribute '" + shown(key) + "'");
      const std::size_t close = text.find(text[i], i + 1);
      if (close == std::string_view::npos) xml_fail("unterminated attribute '" + shown(key) + "' (truncated file?)");
      element.attributes.emplace_back(key, text.substr(i + 1, close - i - 1));
      i = close + 1;
    }
    doc.elements.push_back(std::move(element));
    const std::size_t index = doc.elements.size() - 1;
    if (doc.elements[index].name == "AppendedData") {
      if (self_closing) xml_fail("empty <AppendedData/>");
      if (open.size() != 1) xml_fail("<AppendedData> is not a child of the root element");
      const std::size_t mark = text.find_first_not_of(" \t\r\n", i);
      if (mark == std::string_view::npos || text[mark] != '_')
        xml_fail("<AppendedData> does not start with '_' (truncated file?)");
      doc.appended = index;
      doc.appended_begin = mark + 1;
      return doc;
    }
    if (!self_closing) {
      open.push_back(index);
      content_start.push_back(i);
    } else if (open.empty()) {
      return doc;
    }
    pos = i;
  }
  xml_fail(doc.elements.empty() ? "no XML element found" : "unexpected end of file (truncated file?)");
}

}  // namespace mchex::io_detail
