// Numbers as the ascii mesh formats (MEDIT, Gmsh, VTU ascii arrays) write and read them.
//
// Writing: std::to_chars, which gives the shortest decimal string that parses back to the same
// double, so a write followed by a read returns bit-identical coordinates (mesh_io.h promises it).
// Reading: std::from_chars on one whole token, so that "1.5x", "3.1+e2" or an integer too large for
// its type is refused rather than read in part; a leading '+' is allowed, as strtod allows it.
// Writing into a buffer (put_decimal, put_real): the same characters as std::to_chars; integers
// eight digits at a time in one 64-bit register (the digits8 below), which std::to_chars's two
// digits a step take about twice as long for (5 against 8 ns per 7-digit index, measured); doubles
// of the magnitudes meshes have by exact integer arithmetic (put_real below), about twice as fast
// as std::to_chars's Ryu (30 against 57 ns per coordinate, measured), the rest by std::to_chars.
// Quoting: a token from a file shown in a one-line message is shortened and made printable.
#pragma once

#include <algorithm>
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
// there past its end (whole 8-byte words, and a real's digits moved as 24-byte blocks): a buffer
// holds kNumberRoom bytes past the start of its last number, and what is written next overwrites
// the rest.
inline constexpr std::size_t kNumberRoom = 48;

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

namespace number_detail {

// GCC's and Clang's 128-bit integer for the one 64 x 64 -> 128-bit product a real needs
// (__extension__: an extension -Wpedantic would flag).
__extension__ using Uint128 = unsigned __int128;

// c < 10^17 as 24 digits with leading zeros at d.
inline void digits24(char* d, std::uint64_t c) {
  const std::uint64_t first = c / kPow10[16];  // one digit
  const std::uint64_t rest = c - first * kPow10[16];
  const std::uint64_t middle = rest / kPow10[8];
  store8(d, 0x3030303030303030ull | (first << 56));
  store8(d + 8, digits8(static_cast<std::uint32_t>(middle)));
  store8(d + 16, digits8(static_cast<std::uint32_t>(rest - middle * kPow10[8])));
}

// The shortest decimal of a double v with about 0.001 < |v| < 2^50, in std::to_chars's layout, or
// nullptr where v is outside that range.
//
// v = m 2^e with a 53-bit m and -62 <= e <= -1. At the scale 10^k, k = 16 - est, where est is
// floor(log10 2^(e+52)) and 2 <= k <= 19 (so 10^k fits 64 bits and a quarter of it is whole),
// v 10^k = m 10^k / 2^s (s = -e) lies in [10^16, 10^18): its integer part q and fraction f / 2^s
// come exactly from the 117-bit product m 10^k. The doubles that read back as v are those within
// half a gap of it (the gap below is half as wide when m is a power of two; the ends belong to v
// when m is even, as parsing rounds ties to even): at this scale the integers lo..hi, never none,
// as half a gap, 10^k / 2^(s+1), is at least 0.55. The shortest decimal strips the most trailing
// digits j such that a multiple of 10^j lies in lo..hi, and of those takes the one nearest v (ties
// to even): the multiple nearest v, clamped into lo..hi for the one-sided interval of a power of
// two. (In this range an end of lo..hi is never a decimal of 17 digits or fewer, and no power of
// two needs the clamp, so neither changes a result; both stay so that the construction is right
// without that enumeration.) This is std::to_chars's result by its definition, and the choice
// between fixed and scientific below is its rule too (the shorter, fixed on a tie); the test
// compares the two on every exponent and on millions of values.
inline char* put_real_exact(char* p, double v) {
  std::uint64_t bits;
  std::memcpy(&bits, &v, 8);
  const int biased = static_cast<int>((bits >> 52) & 0x7FF);
  const int e = biased - 1075;
  if (biased == 0 || e >= 0 || e < -62) return nullptr;
  const int est = ((e + 52) * 78913) >> 18;  // floor((e + 52) log10 2): 78913 / 2^18 = 0.30102997
  const int k = 16 - est;
  if (k < 2 || k > 19) return nullptr;
  const std::uint64_t fraction = bits & ((std::uint64_t{1} << 52) - 1);
  const std::uint64_t m = fraction | (std::uint64_t{1} << 52);
  const int s = -e;
  const std::uint64_t pk = kPow10[k];
  const Uint128 x = static_cast<Uint128>(m) * pk;
  const auto x_high = static_cast<std::uint64_t>(x >> 64), x_low = static_cast<std::uint64_t>(x);
  const std::uint64_t mask = (std::uint64_t{1} << s) - 1;
  std::uint64_t q = (x_high << (64 - s)) | (x_low >> s);
  const std::uint64_t f = x_low & mask;
  // The gap is pk in units of 2^-s; f + pk / 2 < 2^62 + 2^63.
  const bool ends_are_v = (m & 1) == 0;
  const std::uint64_t above = f + pk / 2;
  std::uint64_t hi = q + (above >> s);
  if (!ends_are_v && (above & mask) == 0) --hi;
  const std::int64_t below =
      static_cast<std::int64_t>(f) - static_cast<std::int64_t>(fraction == 0 && biased > 1 ? pk / 4 : pk / 2);
  std::uint64_t lo = q + static_cast<std::uint64_t>((below + static_cast<std::int64_t>(mask)) >> s);  // ceil
  if (!ends_are_v && (below & static_cast<std::int64_t>(mask)) == 0) ++lo;
  // Most doubles need 16 or 17 digits, 0 to 2 stripped here: those are tested side by side.
  const std::uint64_t q_all = q;
  int j;
  if ((lo + 999) / 1000 <= hi / 1000) {
    j = 3;
    hi /= 1000;
    lo = (lo + 999) / 1000;
    q /= 1000;
    while ((lo + 9) / 10 <= hi / 10) {
      hi /= 10;
      lo = (lo + 9) / 10;
      q /= 10;
      ++j;
    }
  } else {
    const bool two = (lo + 99) / 100 <= hi / 100, one = (lo + 9) / 10 <= hi / 10;
    j = two ? 2 : (one ? 1 : 0);
    hi = two ? hi / 100 : (one ? hi / 10 : hi);
    lo = two ? (lo + 99) / 100 : (one ? (lo + 9) / 10 : lo);
    q = two ? q / 100 : (one ? q / 10 : q);
  }
  // Round v's digits to the nearest multiple of 10^j, ties to even.
  std::uint64_t c;
  if (j == 0) {
    const std::uint64_t half = std::uint64_t{1} << (s - 1);
    c = q + (f > half || (f == half && (q & 1)));
  } else {
    const std::uint64_t pj = kPow10[j];
    const std::uint64_t twice_rest = 2 * (q_all - q * pj);
    c = q + (twice_rest != pj ? twice_rest > pj : (f != 0 || (q & 1)));
  }
  c = std::clamp(c, lo, hi);
  // 17 digits always tell doubles apart, so c < 10^17.
  const int n = decimal_length(c);
  char digits[48];  // the digits, then room for the 24-byte moves below
  digits24(digits, c);
  std::memset(digits + 24, '0', 24);
  const char* d = digits + 24 - n;
  const int exponent = n - 1 + j - k;  // of the first digit
  const int magnitude = exponent < 0 ? -exponent : exponent;
  const int scientific = n + (n > 1) + 2 + (magnitude >= 100 ? 3 : 2);
  *p = '-';
  p += bits >> 63;
  if (exponent >= 0) {
    if (n <= exponent + 1) {
      if (exponent + 1 <= scientific) {  // "dd00"
        std::memcpy(p, d, 24);
        std::memset(p + n, '0', static_cast<std::size_t>(exponent + 1 - n));
        return p + exponent + 1;
      }
    } else if (n + 1 <= scientific) {  // "dd.dd": at most 42 bytes stored, the sign included
      std::memcpy(p, d, 24);
      p[exponent + 1] = '.';
      std::memcpy(p + exponent + 2, d + exponent + 1, 24);
      return p + n + 1;
    }
  } else if (n + 1 - exponent <= scientific) {  // "0.00dd", at most 3 zeros after the point
    std::memcpy(p, "0.000000", 8);
    std::memcpy(p + 1 - exponent, d, 24);
    return p + n + 1 - exponent;
  }
  p[0] = d[0];  // "d.dde-05"
  p[1] = '.';
  std::memcpy(p + 2, d + 1, 24);
  p += n + (n > 1);
  *p++ = 'e';
  *p++ = exponent < 0 ? '-' : '+';
  if (magnitude >= 100) *p++ = static_cast<char>('0' + magnitude / 100);
  *p++ = static_cast<char>('0' + magnitude / 10 % 10);
  *p++ = static_cast<char>('0' + magnitude % 10);
  return p;
}

}  // namespace number_detail

// The shortest decimal that parses back to v, as std::to_chars gives it.
inline char* put_real(char* p, double v) {
  if (char* const end = number_detail::put_real_exact(p, v)) return end;
  return std::to_chars(p, p + kNumberRoom, v).ptr;
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
