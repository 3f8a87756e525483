// Base64 as VTK writes it for "binary" and base64-appended DataArrays (RFC 4648 alphabet, '='
// padding, blanks ignored). An invalid character throws FormatError("invalid base64 data").
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

#include "core/io/format_error.h"
#include "core/io/text_numbers.h"

namespace mchex::io_detail {

// Decodes base64 in groups of four characters; a '=' ends a group early, which covers both VTK's
// separately encoded block header and one continuous encoding of header and data.
class Base64Reader {
 public:
  explicit Base64Reader(std::string_view text) : text_(text) {}

  // Appends decoded bytes to `out` until it holds `want` bytes; false if the text ends first.
  bool read(std::vector<unsigned char>& out, std::size_t want) {
    while (out.size() < want) {
      std::array<int, 4> group{};
      int have = 0;
      int padding = 0;
      while (have < 4) {
        while (pos_ < text_.size() && is_blank(text_[pos_])) ++pos_;
        if (pos_ == text_.size()) return false;
        const char c = text_[pos_++];
        int value = -1;
        if (c >= 'A' && c <= 'Z') value = c - 'A';
        else if (c >= 'a' && c <= 'z') value = c - 'a' + 26;
        else if (c >= '0' && c <= '9') value = c - '0' + 52;
        else if (c == '+') value = 62;
        else if (c == '/') value = 63;
        else if (c == '=' && have >= 2) value = 0;
        if (c == '=') ++padding;
        if (value < 0 || (padding > 0 && c != '=')) throw FormatError("invalid base64 data");
        group[have++] = value;
      }
      const std::uint32_t bits = (static_cast<std::uint32_t>(group[0]) << 18) |
                                 (static_cast<std::uint32_t>(group[1]) << 12) |
                                 (static_cast<std::uint32_t>(group[2]) << 6) | static_cast<std::uint32_t>(group[3]);
      out.push_back(static_cast<unsigned char>(bits >> 16));
      if (padding < 2) out.push_back(static_cast<unsigned char>(bits >> 8));
      if (padding < 1) out.push_back(static_cast<unsigned char>(bits));
    }
    return true;
  }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
};

}  // namespace mchex::io_detail
