// Text scanning and one-line messages shared by the surface prechecks (stl.cpp, obj.cpp, off.cpp,
// ply.cpp) and the Assimp import (assimp_scene.cpp); surface_io.cpp says why the prechecks exist.
//
// Lines and tokens are split the way Assimp's readers split them (lines at \n, \r\n or a lone \r,
// tokens at spaces and tabs), so that a check and the reader behind it see the same records.
// Every failure is an InputError("PATH: reason") on one line, with "line N: " where there is one.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

namespace mchex::io_detail {

// Assimp triangulates a polygon by ear clipping, quadratic in its corners: a corrupt face with
// a million corners would take hours.
inline constexpr std::size_t kMaxPolygonCorners = 1000;

// "\xNN", for a byte that must not reach a message as it is.
std::string hex_byte(unsigned char c);
// Error messages are one stderr line of valid UTF-8: control characters (a newline in a path, in
// an Assimp message that quotes the rest of the file, or in a section name read from a damaged
// mesh file) and bytes that are not part of a UTF-8 sequence become \xHH escapes; UTF-8 names
// stay readable.
std::string one_line(std::string_view text);

// A token quoted from a file: kept short and printable, because the file may be binary.
std::string quote(std::string_view token);

[[noreturn]] void fail(const std::filesystem::path& path, std::string_view reason);
[[noreturn]] void fail_at(const std::filesystem::path& path, std::size_t line, std::string_view reason);

inline std::string_view strip_utf8_bom(std::string_view text) {
  return text.starts_with("\xEF\xBB\xBF") ? text.substr(3) : text;
}

// Splits at \n, \r\n or a lone \r, numbering lines from 1 as an editor does.
class Lines {
 public:
  explicit Lines(std::string_view text) : text_(text) {}
  bool next(std::string_view& line) {
    if (position_ >= text_.size()) return false;
    const std::size_t end = text_.find_first_of("\r\n", position_);
    ++number_;
    if (end == std::string_view::npos) {
      line = text_.substr(position_);
      position_ = text_.size();
      return true;
    }
    line = text_.substr(position_, end - position_);
    position_ = end + ((text_[end] == '\r' && end + 1 < text_.size() && text_[end + 1] == '\n') ? 2 : 1);
    return true;
  }
  std::size_t number() const { return number_; }
  std::size_t position() const { return position_; }

 private:
  std::string_view text_;
  std::size_t position_ = 0;
  std::size_t number_ = 0;
};

inline bool is_space_or_tab(char c) { return c == ' ' || c == '\t'; }

class Tokens {
 public:
  explicit Tokens(std::string_view line) : rest_(line) {}
  bool next(std::string_view& token) {
    std::size_t begin = 0;
    while (begin < rest_.size() && is_space_or_tab(rest_[begin])) ++begin;
    if (begin == rest_.size()) return false;
    std::size_t end = begin;
    while (end < rest_.size() && !is_space_or_tab(rest_[end])) ++end;
    token = rest_.substr(begin, end - begin);
    rest_ = rest_.substr(end);
    return true;
  }

 private:
  std::string_view rest_;
};

// Text formats must be text: a stray control byte means a binary or damaged file, and Assimp's
// readers treat some of them (\0, \f) as line ends where we would not.
void check_text(const std::filesystem::path& path, std::string_view text, const char* what);

// A whole token as a double; a value beyond double's range is +-inf (or 0 when tiny), not an error.
std::optional<double> parse_number(std::string_view token);

// Coordinates: Assimp stores them as float, so anything beyond float's range would become inf;
// such a value, NaN and infinity fail at `line`.
double parse_coordinate(const std::filesystem::path& path, std::size_t line, std::string_view token);

// A whole token as an unsigned count or index.
std::optional<uint64_t> parse_count(std::string_view token);

}  // namespace mchex::io_detail
