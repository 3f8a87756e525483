#include "core/io/surface_text.h"

#include <cfloat>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <system_error>

#include "core/base/error.h"

namespace mchex::io_detail {

namespace fs = std::filesystem;

std::string one_line(std::string_view text) {
  std::string out;
  for (std::size_t i = 0; i < text.size();) {
    const auto c = static_cast<unsigned char>(text[i]);
    // The length of the UTF-8 sequence c starts (0: not a lead byte), its continuation bytes
    // checked below.
    const std::size_t n = c < 0x80                 ? 1
                          : c >= 0xc2 && c <= 0xdf ? 2
                          : c >= 0xe0 && c <= 0xef ? 3
                          : c >= 0xf0 && c <= 0xf4 ? 4
                                                   : 0;
    bool whole = n > 0 && i + n <= text.size();
    for (std::size_t k = 1; whole && k < n; ++k) whole = (static_cast<unsigned char>(text[i + k]) & 0xc0) == 0x80;
    if (!whole || c < 0x20 || c == 0x7f) {
      out += hex_byte(c);
      ++i;
      continue;
    }
    out.append(text.substr(i, n));
    i += n;
  }
  return out;
}

std::string hex_byte(unsigned char c) {
  char buffer[8];
  std::snprintf(buffer, sizeof buffer, "\\x%02x", c);
  return buffer;
}

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

[[noreturn]] void fail(const fs::path& path, std::string_view reason) {
  throw InputError(one_line(path.string()) + ": " + one_line(reason));
}

[[noreturn]] void fail_at(const fs::path& path, std::size_t line, std::string_view reason) {
  fail(path, "line " + std::to_string(line) + ": " + std::string(reason));
}

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
    value = std::fabs(wide) > DBL_MAX ? std::copysign(HUGE_VAL, static_cast<double>(wide)) : static_cast<double>(wide);
  }
  if (result.ec != std::errc{} || result.ptr != last) return std::nullopt;
  return value;
}

double parse_coordinate(const std::filesystem::path& path, std::size_t line, std::string_view token) {
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

}  // namespace mchex::io_detail
