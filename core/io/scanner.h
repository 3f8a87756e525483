// Whitespace-separated tokens of an ascii mesh format (MEDIT, Gmsh, VTU ascii arrays), with the
// line of the last token for messages.
//
// Every failure throws FormatError("line N: reason"), N counted from the start of the file. Counts
// read from a file are checked against the bytes left before a caller allocates for them, so a
// corrupt count fails here and not in a huge allocation.
#pragma once

#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <type_traits>

#include "core/io/format_error.h"
#include "core/io/text_numbers.h"

namespace mchex::io_detail {

class Scanner {
 public:
  // `part` is a piece of `file`; lines are counted from the start of `file`.
  Scanner(std::string_view file, std::string_view part, bool hash_comments)
      : file_begin_(file.data()),
        p_(part.data()),
        end_(part.data() + part.size()),
        last_(p_),
        hash_comments_(hash_comments) {}

  std::string_view next() {
    skip_blank();
    const char* start = p_;
    while (p_ != end_ && !is_blank(*p_)) ++p_;
    last_ = start;
    return {start, static_cast<std::size_t>(p_ - start)};
  }

  std::string_view token(std::string_view what) {
    const std::string_view t = next();
    if (t.empty()) fail_at_end(what);
    return t;
  }

  void expect(std::string_view word) {
    const std::string_view t = next();
    if (t.empty()) fail_at_end("'" + std::string(word) + "'");
    if (t != word) fail("expected '" + std::string(word) + "', found '" + shown(t) + "'");
  }

  template <class Int>
  Int integer(std::string_view what) {
    // Nearly every integer of a mesh file is a short run of digits before a blank; only other
    // tokens take the general path. 18 digits cannot overflow 64 bits.
    skip_blank();
    const bool negative = std::is_signed_v<Int> && p_ != end_ && *p_ == '-';
    const char* q = p_ + (negative ? 1 : 0);
    const char* first_digit = q;
    std::uint64_t magnitude = 0;
    while (q != end_ && static_cast<unsigned char>(*q - '0') < 10 && q - first_digit < 18)
      magnitude = 10 * magnitude + static_cast<unsigned>(*q++ - '0');
    if (q != first_digit && (q == end_ || is_blank(*q)) &&
        magnitude <= static_cast<std::uint64_t>(std::numeric_limits<Int>::max())) {
      last_ = p_;
      p_ = q;
      return negative ? static_cast<Int>(-static_cast<Int>(magnitude)) : static_cast<Int>(magnitude);
    }
    const std::string_view t = token(what);
    Int v{};
    if (parse_int(t, v)) return v;
    const bool digits = t.find_first_not_of("+-0123456789") == std::string_view::npos &&
                        t.find_first_of("0123456789") != std::string_view::npos;
    if (digits) fail(std::string(what) + " " + shown(t) + " is out of range");
    fail("expected " + std::string(what) + " (an integer), found '" + shown(t) + "'");
  }

  double real(std::string_view what) {
    const std::string_view t = token(what);
    double v = 0;
    switch (parse_real(t, v)) {
      case RealParse::kOk: return v;
      case RealParse::kNotFinite: fail(std::string(what) + " '" + shown(t) + "' is not a finite number");
      case RealParse::kMalformed: break;
    }
    fail("expected " + std::string(what) + " (a number), found '" + shown(t) + "'");
  }

  // A count of items of `tokens` tokens each, refused when the rest of the file is too short for
  // it: a corrupt count then fails here instead of in a huge allocation.
  std::uint64_t count(std::string_view what, std::uint64_t tokens) {
    const auto c = integer<std::uint64_t>(std::string(what) + " count");
    const std::uint64_t room = static_cast<std::uint64_t>(end_ - p_) / (2 * tokens) + 1;
    if (c > room)
      fail(std::string(what) + " count " + std::to_string(c) +
           " is more than the rest of the file can hold (truncated or corrupt file?)");
    return c;
  }

  void skip_tokens(std::uint64_t n, std::string_view what) {
    for (std::uint64_t i = 0; i < n; ++i) token(what);
  }

  // Skips the rest of the current line and then `lines` non-empty lines.
  void skip_lines(std::uint64_t lines, std::string_view what) {
    while (p_ != end_ && *p_ != '\n') ++p_;
    for (std::uint64_t i = 0; i < lines; ++i) {
      skip_blank();
      if (p_ == end_) fail_at_end(what);
      last_ = p_;
      while (p_ != end_ && *p_ != '\n') ++p_;
    }
  }

  // Skips tokens up to and including `word`.
  void skip_past(std::string_view word) {
    for (;;) {
      const std::string_view t = next();
      if (t.empty()) fail_at_end("'" + std::string(word) + "'");
      if (t == word) return;
    }
  }

  // Where the next token starts looking, for a format that puts binary data between its tokens
  // (Gmsh 4.1 binary); set_position moves past such data.
  const char* position() const { return p_; }
  const char* end() const { return end_; }
  const char* file_begin() const { return file_begin_; }
  void set_position(const char* p) {
    p_ = p;
    last_ = p;
  }

  [[noreturn]] void fail(const std::string& message) const {
    throw FormatError("line " + std::to_string(1 + std::count(file_begin_, last_, '\n')) + ": " + message);
  }

 private:
  void skip_blank() {
    while (p_ != end_) {
      if (is_blank(*p_)) {
        ++p_;
      } else if (hash_comments_ && *p_ == '#') {
        while (p_ != end_ && *p_ != '\n') ++p_;
      } else {
        break;
      }
    }
  }

  [[noreturn]] void fail_at_end(std::string_view what) {
    last_ = p_;
    fail("unexpected end of file where " + std::string(what) + " was expected (truncated file?)");
  }

  const char* file_begin_;
  const char* p_;
  const char* end_;
  const char* last_;
  bool hash_comments_;
};

// A region label as HexMesh holds it (32 bits), or a failure at the scanner's line.
inline int32_t to_region(std::int64_t v, const Scanner& in) {
  if (v < std::numeric_limits<int32_t>::min() || v > std::numeric_limits<int32_t>::max())
    in.fail("region label " + std::to_string(v) + " does not fit in 32 bits");
  return static_cast<int32_t>(v);
}

}  // namespace mchex::io_detail
