// Numbers as the ascii mesh formats (MEDIT, Gmsh, VTU ascii arrays) write and read them.
//
// Writing: std::to_chars, which gives the shortest decimal string that parses back to the same
// double, so a write followed by a read returns bit-identical coordinates (mesh_io.h promises it).
// Reading: std::from_chars on one whole token, so that "1.5x", "3.1+e2" or an integer too large for
// its type is refused rather than read in part; a leading '+' is allowed, as strtod allows it.
// Writing into a buffer (put_decimal, put_real): the same characters as std::to_chars; integers
// eight digits at a time in one 64-bit register (the digits8 below), which std::to_chars's two
// digits a step take about twice as long for (5 against 8 ns per 7-digit index, measured).
// Quoting: a token from a file shown in a one-line message is shortened and made printable.
#pragma once

#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>

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

// A number written at p ends before p + kNumberRoom, but the writers below may store bytes up to
// there past its end (whole 8-byte words): a buffer holds kNumberRoom bytes past the start of its
// last number, and what is written next overwrites the rest.
inline constexpr std::size_t kNumberRoom = 32;

namespace number_detail {

// 10^k for k < 20 (10^19 is the largest power of ten in 64 bits).
inline constexpr auto kPow10 = [] {
  std::array<std::uint64_t, 20> p{};
  p[0] = 1;
  for (std::size_t k = 1; k < p.size(); ++k) p[k] = p[k - 1] * 10;
  return p;
}();

inline int decimal_length(std::uint64_t v) {
  const int t = (std::bit_width(v | 1) * 1233) >> 12;  // floor(log10(2) * bits), low by at most 1
  return t + ((v | 1) >= kPow10[t]);
}

// x < 10^8 as 8 ascii digits with leading zeros, the first digit in the lowest byte: the 32-bit
// halves take x / 10^4 and x % 10^4, then the 16-bit quarters / 100 and % 100, then the bytes / 10
// and % 10 (multiply-shift divisions that stay inside each lane for these ranges).
inline std::uint64_t digits8(std::uint32_t x) {
  const std::uint64_t q = x / 10000;
  std::uint64_t v = q | ((x - q * 10000) << 32);
  const std::uint64_t h = ((v * 10486) >> 20) & 0x0000007F0000007Full;
  v = h | ((v - 100 * h) << 16);
  const std::uint64_t t = ((v * 103) >> 10) & 0x000F000F000F000Full;
  v = t | ((v - 10 * t) << 8);
  return v | 0x3030303030303030ull;
}

inline void store8(char* p, std::uint64_t w) { std::memcpy(p, &w, 8); }

static_assert(std::endian::native == std::endian::little, "digits8 puts the first digit in the lowest byte");

inline char* put_unsigned(char* p, std::uint64_t v) {
  if (v >= kPow10[16]) return std::to_chars(p, p + kNumberRoom, v).ptr;
  const int n = decimal_length(v);
  if (n <= 8) {
    store8(p, digits8(static_cast<std::uint32_t>(v)) >> (8 * (8 - n)));
  } else {
    const std::uint64_t high = v / kPow10[8];
    store8(p, digits8(static_cast<std::uint32_t>(high)) >> (8 * (16 - n)));
    store8(p + n - 8, digits8(static_cast<std::uint32_t>(v - high * kPow10[8])));
  }
  return p + n;
}

}  // namespace number_detail

// v in decimal at p; returns the end.
template <class Int>
char* put_decimal(char* p, Int v) {
  static_assert(std::is_integral_v<Int>);
  if constexpr (std::is_signed_v<Int>) {
    *p = '-';
    // The magnitude in unsigned arithmetic: -v overflows for the smallest value.
    const auto u = static_cast<std::uint64_t>(static_cast<std::int64_t>(v));
    return number_detail::put_unsigned(p + (v < 0), v < 0 ? 0 - u : u);
  } else {
    return number_detail::put_unsigned(p, v);
  }
}

// The shortest decimal that parses back to v, as std::to_chars gives it.
inline char* put_real(char* p, double v) { return std::to_chars(p, p + kNumberRoom, v).ptr; }

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
