// Numbers as the ascii mesh formats (MEDIT, Gmsh, VTU ascii arrays) write and read them.
//
// Writing: std::to_chars, which gives the shortest decimal string that parses back to the same
// double, so a write followed by a read returns bit-identical coordinates (mesh_io.h promises it).
// Reading: std::from_chars on one whole token, so that "1.5x", "3.1+e2" or an integer too large for
// its type is refused rather than read in part; a leading '+' is allowed, as strtod allows it.
// Quoting: a token from a file shown in a one-line message is shortened and made printable.
#pragma once

#include <charconv>
#include <cmath>
#include <cstddef>
#include <initializer_list>
#include <string>
#include <string_view>
#include <system_error>

namespace mchex::io_detail {

// A piece of file content as it may appear in a one-line message: short and printable.
inline std::string shown(std::string_view s) {
  constexpr std::size_t kMax = 40;
  std::string out;
  for (const char c : s.substr(0, kMax)) out += (c >= 32 && c < 127) ? c : '?';
  if (s.size() > kMax) out += "...";
  return out;
}

inline bool is_blank(char c) { return c == ' ' || c == '\n' || c == '\r' || c == '\t' || c == '\v' || c == '\f'; }

template <class Int>
bool parse_int(std::string_view t, Int& v) {
  if (t.size() > 1 && t[0] == '+' && t[1] >= '0' && t[1] <= '9') t.remove_prefix(1);
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  return r.ec == std::errc() && r.ptr == t.data() + t.size();
}

enum class RealParse { kOk, kMalformed, kNotFinite };

inline RealParse parse_real(std::string_view t, double& v) {
  if (t.size() > 1 && t[0] == '+' && ((t[1] >= '0' && t[1] <= '9') || t[1] == '.')) t.remove_prefix(1);
  v = 0;
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  if (r.ptr != t.data() + t.size()) return RealParse::kMalformed;
  if (r.ec == std::errc::result_out_of_range) {
    // from_chars reports underflow like overflow; a value below the smallest subnormal is a
    // legitimate zero (strtod gives 0 too), one above the largest double is not representable.
    const auto e = t.find_first_of("eE");
    if (e == std::string_view::npos || e + 1 >= t.size() || t[e + 1] != '-') return RealParse::kNotFinite;
    v = t[0] == '-' ? -0.0 : 0.0;
    return RealParse::kOk;
  }
  if (r.ec != std::errc()) return RealParse::kMalformed;
  return std::isfinite(v) ? RealParse::kOk : RealParse::kNotFinite;
}

template <class T>
void put_number(std::string& s, T v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);  // doubles: shortest exact round trip
  s.append(buf, r.ptr);
}

template <class T>
void put_line(std::string& s, std::initializer_list<T> values) {
  for (const T v : values) {
    put_number(s, v);
    s += ' ';
  }
  s.back() = '\n';
}

}  // namespace mchex::io_detail
