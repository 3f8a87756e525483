// MEDIT, VTU and Gmsh 4.1 files for HexMesh; mesh_io.h states the contract.
//
// Writers format large tables chunk by chunk on all threads (ordered_pipeline) and write the
// chunks in order, so memory stays bounded and a 5M-hex mesh takes seconds. Readers map the whole
// file and parse it in place; every count read from a file is checked against the bytes that are
// left before anything is allocated for it.
#include "core/io/mesh_io.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <initializer_list>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/base/error.h"
#include "core/base/parallel.h"
#include "core/io/atomic_file.h"

namespace mchex {
namespace {

namespace fs = std::filesystem;

// The VTU writer copies points and labels from memory into a file that declares LittleEndian.
static_assert(std::endian::native == std::endian::little, "the VTU writer assumes a little-endian host");
static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 must be three packed doubles");

constexpr std::uint64_t kMaxPoints = std::uint64_t{std::numeric_limits<uint32_t>::max()} + 1;

// The reason only; the public functions put the path in front.
struct FormatError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

std::string errno_message(int e) {
  return e != 0 ? std::generic_category().message(e) : std::string("I/O error");
}

// A piece of file content as it may appear in a one-line message: short and printable.
std::string shown(std::string_view s) {
  constexpr std::size_t kMax = 40;
  std::string out;
  for (const char c : s.substr(0, kMax)) out += (c >= 32 && c < 127) ? c : '?';
  if (s.size() > kMax) out += "...";
  return out;
}

bool is_blank(char c) { return c == ' ' || c == '\n' || c == '\r' || c == '\t' || c == '\v' || c == '\f'; }

template <class Int>
bool parse_int(std::string_view t, Int& v) {
  if (t.size() > 1 && t[0] == '+' && t[1] >= '0' && t[1] <= '9') t.remove_prefix(1);
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  return r.ec == std::errc() && r.ptr == t.data() + t.size();
}

enum class RealParse { kOk, kMalformed, kNotFinite };

RealParse parse_real(std::string_view t, double& v) {
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

// =============================================================================================
// Output

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

// Formats records [0, count) in chunks on all threads and writes the chunks in order; the tokens
// in flight bound the memory to a few chunks per thread.
template <class Format>
void write_records(AtomicFile& out, std::size_t count, const Format& format) {
  constexpr std::size_t kChunk = std::size_t{1} << 14;
  if (count == 0) return;
  const std::size_t chunks = (count + kChunk - 1) / kChunk;
  ordered_pipeline(
      chunks,
      [&](std::size_t c) {
        std::string text;
        format(c * kChunk, std::min(count, (c + 1) * kChunk), text);
        return text;
      },
      [&](const std::string& text) { out.write(text); });
}

// Every format can represent only a consistent mesh, and a reader of ours must accept what the
// writer wrote, so inconsistencies are refused before the first byte.
void check_writable(const HexMesh& mesh) {
  if (mesh.region.size() != mesh.hexes.size())
    throw FormatError("the mesh has " + std::to_string(mesh.hexes.size()) + " hexes but " +
                      std::to_string(mesh.region.size()) + " region labels");
  if (mesh.points.size() > kMaxPoints)
    throw FormatError(std::to_string(mesh.points.size()) + " points are more than 32-bit indices can address");
  for (std::size_t i = 0; i < mesh.points.size(); ++i)
    if (!is_finite(mesh.points[i]))
      throw FormatError("point " + std::to_string(i) + " has a non-finite coordinate");
  const std::size_t n = mesh.points.size();
  for (std::size_t h = 0; h < mesh.hexes.size(); ++h)
    for (const uint32_t v : mesh.hexes[h])
      if (v >= n)
        throw FormatError("hex " + std::to_string(h) + " refers to point " + std::to_string(v) + " but the mesh has " +
                          std::to_string(n) + " points");
}

void write_points_text(AtomicFile& out, const std::vector<Vec3>& points, std::string_view line_end) {
  write_records(out, points.size(), [&](std::size_t begin, std::size_t end, std::string& s) {
    s.reserve((end - begin) * 64);
    for (std::size_t i = begin; i < end; ++i) {
      put_number(s, points[i].x);
      s += ' ';
      put_number(s, points[i].y);
      s += ' ';
      put_number(s, points[i].z);
      s += line_end;
    }
  });
}

void write_medit(const HexMesh& mesh, AtomicFile& out) {
  std::string head = "MeshVersionFormatted 2\n\nDimension 3\n\nVertices\n";
  put_number(head, mesh.points.size());
  head += '\n';
  out.write(head);
  write_points_text(out, mesh.points, " 0\n");
  if (!mesh.hexes.empty()) {
    std::string section = "\nHexahedra\n";
    put_number(section, mesh.hexes.size());
    section += '\n';
    out.write(section);
    write_records(out, mesh.hexes.size(), [&](std::size_t begin, std::size_t end, std::string& s) {
      s.reserve((end - begin) * 80);
      for (std::size_t h = begin; h < end; ++h) {
        for (const uint32_t v : mesh.hexes[h]) {
          put_number(s, std::uint64_t{v} + 1);
          s += ' ';
        }
        put_number(s, mesh.region[h]);
        s += '\n';
      }
    });
  }
  out.write("\nEnd\n");
}

void write_vtu(const HexMesh& mesh, AtomicFile& out) {
  const std::uint64_t n = mesh.points.size();
  const std::uint64_t m = mesh.hexes.size();
  constexpr std::uint8_t kVtkHexahedron = 12;
  const std::array<std::uint64_t, 5> bytes = {n * sizeof(Vec3), m * 8 * sizeof(int64_t), m * sizeof(int64_t), m,
                                              m * sizeof(int32_t)};
  std::array<std::uint64_t, 5> offset{};
  for (std::size_t i = 1; i < offset.size(); ++i) offset[i] = offset[i - 1] + sizeof(std::uint64_t) + bytes[i - 1];
  auto off = [&](std::size_t i) { return std::to_string(offset[i]); };

  std::string xml =
      "<?xml version=\"1.0\"?>\n"
      "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n"
      "  <UnstructuredGrid>\n"
      "    <Piece NumberOfPoints=\"" + std::to_string(n) + "\" NumberOfCells=\"" + std::to_string(m) + "\">\n"
      "      <Points>\n"
      "        <DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" format=\"appended\" offset=\"" +
      off(0) + "\"/>\n"
      "      </Points>\n"
      "      <Cells>\n"
      "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"appended\" offset=\"" + off(1) + "\"/>\n"
      "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"appended\" offset=\"" + off(2) + "\"/>\n"
      "        <DataArray type=\"UInt8\" Name=\"types\" format=\"appended\" offset=\"" + off(3) + "\"/>\n"
      "      </Cells>\n"
      "      <CellData Scalars=\"region\">\n"
      "        <DataArray type=\"Int32\" Name=\"region\" format=\"appended\" offset=\"" + off(4) + "\"/>\n"
      "      </CellData>\n"
      "    </Piece>\n"
      "  </UnstructuredGrid>\n"
      // meshio finds the raw bytes between the '_' and the last newline before </AppendedData>.
      "  <AppendedData encoding=\"raw\">\n"
      "   _";
  out.write(xml);

  auto block_header = [&](std::uint64_t size) { out.write(&size, sizeof size); };
  constexpr std::size_t kChunk = std::size_t{1} << 16;
  std::vector<int64_t> buffer;

  block_header(bytes[0]);
  out.write(mesh.points.data(), bytes[0]);

  block_header(bytes[1]);
  for (std::size_t begin = 0; begin < m; begin += kChunk) {
    const std::size_t end = std::min<std::size_t>(m, begin + kChunk);
    buffer.clear();
    for (std::size_t h = begin; h < end; ++h)
      for (const uint32_t v : mesh.hexes[h]) buffer.push_back(v);
    out.write(buffer.data(), buffer.size() * sizeof(int64_t));
  }

  block_header(bytes[2]);
  for (std::size_t begin = 0; begin < m; begin += kChunk) {
    const std::size_t end = std::min<std::size_t>(m, begin + kChunk);
    buffer.clear();
    for (std::size_t h = begin; h < end; ++h) buffer.push_back(static_cast<int64_t>(8 * (h + 1)));
    out.write(buffer.data(), buffer.size() * sizeof(int64_t));
  }

  block_header(bytes[3]);
  const std::vector<std::uint8_t> types(std::min<std::size_t>(m, kChunk), kVtkHexahedron);
  for (std::size_t begin = 0; begin < m; begin += kChunk) out.write(types.data(), std::min<std::size_t>(m - begin, kChunk));

  block_header(bytes[4]);
  out.write(mesh.region.data(), bytes[4]);

  out.write("\n  </AppendedData>\n</VTKFile>\n");
}

void write_gmsh(const HexMesh& mesh, AtomicFile& out) {
  // Element blocks follow runs of equal regions: one block per region would reorder the hexes
  // for every reader but ours, and Gmsh accepts several blocks of one entity.
  struct Run {
    std::size_t begin, end;
    int32_t region;
  };
  std::vector<Run> runs;
  for (std::size_t h = 0; h < mesh.hexes.size();) {
    std::size_t e = h + 1;
    while (e < mesh.hexes.size() && mesh.region[e] == mesh.region[h]) ++e;
    runs.push_back({h, e, mesh.region[h]});
    h = e;
  }
  std::vector<int32_t> values;
  for (const Run& r : runs) values.push_back(r.region);
  std::sort(values.begin(), values.end());
  values.erase(std::unique(values.begin(), values.end()), values.end());
  auto value_index = [&](int32_t region) {
    return static_cast<std::size_t>(std::lower_bound(values.begin(), values.end(), region) - values.begin());
  };
  // Gmsh entity tags must be positive; the region itself stays exact as the physical tag.
  const bool tags_are_regions = values.empty() || values.front() > 0;
  auto entity_of = [&](int32_t region) -> int64_t {
    return tags_are_regions ? region : static_cast<int64_t>(value_index(region)) + 1;
  };

  std::vector<Box> boxes(values.size());
  for (const Run& r : runs) {
    Box& box = boxes[value_index(r.region)];
    for (std::size_t h = r.begin; h < r.end; ++h)
      for (const uint32_t v : mesh.hexes[h]) box.extend(mesh.points[v]);
  }
  // Nodes must sit on an entity; without hexes there is no region entity to hold them.
  const bool bare_nodes = values.empty() && !mesh.points.empty();
  if (bare_nodes) {
    boxes.emplace_back();
    for (const Vec3& p : mesh.points) boxes.back().extend(p);
  }

  std::string s = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n";
  if (!values.empty()) {
    s += "$PhysicalNames\n";
    put_number(s, values.size());
    s += '\n';
    for (const int32_t r : values) {
      s += "3 ";
      put_number(s, r);
      s += " \"region_";
      put_number(s, r);
      s += "\"\n";
    }
    s += "$EndPhysicalNames\n";
  }
  s += "$Entities\n0 0 0 ";
  put_number(s, boxes.size());
  s += '\n';
  for (std::size_t k = 0; k < boxes.size(); ++k) {
    put_number(s, bare_nodes ? int64_t{1} : entity_of(values[k]));
    for (const Vec3& corner : {boxes[k].lo, boxes[k].hi})
      for (int a = 0; a < 3; ++a) {
        s += ' ';
        put_number(s, corner[a]);
      }
    if (bare_nodes) {
      s += " 0 0\n";
    } else {
      s += " 1 ";
      put_number(s, values[k]);
      s += " 0\n";
    }
  }
  s += "$EndEntities\n$Nodes\n";
  const std::size_t n = mesh.points.size();
  const std::size_t any_node = n == 0 ? 0 : 1;
  put_line(s, {any_node, n, any_node, n});
  if (n != 0) put_line<int64_t>(s, {3, bare_nodes ? int64_t{1} : entity_of(values.front()), 0, static_cast<int64_t>(n)});
  out.write(s);
  write_records(out, n, [](std::size_t begin, std::size_t end, std::string& text) {
    text.reserve((end - begin) * 12);
    for (std::size_t i = begin; i < end; ++i) {
      put_number(text, i + 1);
      text += '\n';
    }
  });
  write_points_text(out, mesh.points, "\n");

  s = "$EndNodes\n$Elements\n";
  const std::size_t m = mesh.hexes.size();
  put_line(s, {runs.size(), m, m == 0 ? std::size_t{0} : std::size_t{1}, m});
  out.write(s);
  write_records(out, m, [&](std::size_t begin, std::size_t end, std::string& text) {
    text.reserve((end - begin) * 90);
    std::size_t r = static_cast<std::size_t>(
        std::upper_bound(runs.begin(), runs.end(), begin, [](std::size_t h, const Run& run) { return h < run.begin; }) -
        runs.begin() - 1);
    for (std::size_t h = begin; h < end; ++h) {
      if (h == runs[r].end) ++r;
      if (h == runs[r].begin) {
        text += "3 ";
        put_number(text, entity_of(runs[r].region));
        text += " 5 ";
        put_number(text, runs[r].end - runs[r].begin);
        text += '\n';
      }
      put_number(text, h + 1);
      for (const uint32_t v : mesh.hexes[h]) {
        text += ' ';
        put_number(text, std::uint64_t{v} + 1);
      }
      text += '\n';
    }
  });
  out.write("$EndElements\n");
}

// =============================================================================================
// Input

// The bytes of a file, mapped rather than copied: a copy needs as much fresh memory as the file,
// and zeroing that memory was most of the time of reading a large binary mesh.
class MappedFile {
 public:
  explicit MappedFile(const fs::path& path) : fd_(::open(path.c_str(), O_RDONLY | O_CLOEXEC)) {
    if (fd_ < 0) throw FormatError("cannot open: " + errno_message(errno));
    try {
      map();
    } catch (...) {
      ::close(fd_);
      throw;
    }
  }
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  ~MappedFile() {
    if (data_ != nullptr) ::munmap(data_, size_);
    ::close(fd_);
  }

  std::string_view text() const { return data_ != nullptr ? std::string_view(static_cast<const char*>(data_), size_) : ""; }

 private:
  void map() {
    struct stat st {};
    if (::fstat(fd_, &st) != 0) throw FormatError("cannot open: " + errno_message(errno));
    // A directory, a device or a pipe has no size to bound the parse by, and may never end.
    if (!S_ISREG(st.st_mode)) throw FormatError("not a regular file");
    size_ = static_cast<std::size_t>(st.st_size);
    if (size_ == 0) return;
#ifdef MAP_POPULATE
    constexpr int kFlags = MAP_PRIVATE | MAP_POPULATE;  // the parse reads every page, in order
#else
    constexpr int kFlags = MAP_PRIVATE;
#endif
    void* p = ::mmap(nullptr, size_, PROT_READ, kFlags, fd_, 0);
    if (p == MAP_FAILED) throw FormatError("cannot read: " + errno_message(errno));
    data_ = p;
  }

  int fd_;
  void* data_ = nullptr;
  std::size_t size_ = 0;
};

// Whitespace-separated tokens of an ascii format, with the line of the last token for messages.
class Scanner {
 public:
  // `part` is a piece of `file`; lines are counted from the start of `file`.
  Scanner(std::string_view file, std::string_view part, bool hash_comments)
      : file_begin_(file.data()), p_(part.data()), end_(part.data() + part.size()), last_(p_),
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
      case RealParse::kOk:
        return v;
      case RealParse::kNotFinite:
        fail(std::string(what) + " '" + shown(t) + "' is not a finite number");
      case RealParse::kMalformed:
        break;
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

int32_t to_region(std::int64_t v, const Scanner& in) {
  if (v < std::numeric_limits<int32_t>::min() || v > std::numeric_limits<int32_t>::max())
    in.fail("region label " + std::to_string(v) + " does not fit in 32 bits");
  return static_cast<int32_t>(v);
}

// ---------------------------------------------------------------------------------------------
// MEDIT

// Sections that may sit beside the hexahedra. Record sizes are those of libMeshb's keyword table
// (tokens per record in ascii: fixed ones plus per_dim per space dimension).
struct MeditSection {
  std::string_view name;
  int fixed;
  int per_dim;
  bool volume;    // another kind of volume element: the file is not an all-hex mesh
  bool counted;   // the section starts with its number of records
};
constexpr MeditSection kMeditSections[] = {
    {"Edges", 3, 0, false, true},
    {"Triangles", 4, 0, false, true},
    {"Quadrilaterals", 5, 0, false, true},
    {"EdgesP2", 4, 0, false, true},
    {"TrianglesP2", 7, 0, false, true},
    {"QuadrilateralsQ2", 10, 0, false, true},
    {"Corners", 1, 0, false, true},
    {"Ridges", 1, 0, false, true},
    {"RequiredVertices", 1, 0, false, true},
    {"RequiredEdges", 1, 0, false, true},
    {"RequiredTriangles", 1, 0, false, true},
    {"RequiredQuadrilaterals", 1, 0, false, true},
    {"TangentAtEdgeVertices", 3, 0, false, true},
    {"NormalAtVertices", 2, 0, false, true},
    {"NormalAtTriangleVertices", 3, 0, false, true},
    {"NormalAtQuadrilateralVertices", 4, 0, false, true},
    {"TangentAtVertices", 2, 0, false, true},
    {"Normals", 0, 1, false, true},
    {"Tangents", 0, 1, false, true},
    {"SubDomainFromGeom", 3, 0, false, true},
    {"BoundingBox", 0, 2, false, false},
    {"Tetrahedra", 5, 0, true, true},
    {"TetrahedraP2", 11, 0, true, true},
    {"Prisms", 7, 0, true, true},
    {"Pentahedra", 7, 0, true, true},
    {"Pyramids", 6, 0, true, true},
    {"HexahedraQ2", 28, 0, true, true},
};

HexMesh read_medit(std::string_view text) {
  Scanner in(text, text, /*hash_comments=*/true);
  HexMesh mesh;
  std::int64_t dim = 0;
  bool have_vertices = false;
  for (;;) {
    const std::string_view word = in.next();
    if (word.empty()) in.fail("no End keyword (truncated file?)");
    if (word == "End") break;
    if (word == "MeshVersionFormatted") {
      const auto version = in.integer<std::int64_t>("the MeshVersionFormatted value");
      if (version < 1 || version > 4) in.fail("unknown MeshVersionFormatted " + std::to_string(version));
    } else if (word == "Dimension") {
      dim = in.integer<std::int64_t>("the Dimension value");
      if (dim != 3) in.fail("Dimension " + std::to_string(dim) + ": only 3D meshes are supported");
    } else if (word == "Vertices") {
      if (dim != 3) in.fail("Vertices before 'Dimension 3'");
      if (have_vertices) in.fail("a second Vertices section");
      have_vertices = true;
      const std::uint64_t n = in.count("Vertices", 4);
      if (n > kMaxPoints) in.fail(std::to_string(n) + " vertices are more than 32-bit indices can address");
      mesh.points.resize(n);
      for (Vec3& p : mesh.points) {
        p.x = in.real("a vertex coordinate");
        p.y = in.real("a vertex coordinate");
        p.z = in.real("a vertex coordinate");
        in.integer<std::int64_t>("a vertex reference");
      }
    } else if (word == "Hexahedra" || word == "Hexaedra") {
      const std::uint64_t n = in.count(word, 9);
      const std::size_t first = mesh.hexes.size();
      mesh.hexes.resize(first + n);
      mesh.region.resize(first + n);
      for (std::size_t h = first; h < mesh.hexes.size(); ++h) {
        for (uint32_t& v : mesh.hexes[h]) {
          const auto index = in.integer<std::uint64_t>("a hexahedron vertex index");
          // Vertices normally come first; otherwise the range is checked at the end.
          if (index == 0 || index > (have_vertices ? mesh.points.size() : kMaxPoints))
            in.fail("hexahedron vertex index " + std::to_string(index) + " is out of range" +
                    (have_vertices ? " 1.." + std::to_string(mesh.points.size()) : std::string()));
          v = static_cast<uint32_t>(index - 1);
        }
        mesh.region[h] = to_region(in.integer<std::int64_t>("a hexahedron reference"), in);
      }
    } else {
      const auto* section = std::find_if(std::begin(kMeditSections), std::end(kMeditSections),
                                         [&](const MeditSection& s) { return s.name == word; });
      if (section == std::end(kMeditSections)) in.fail("unknown MEDIT keyword '" + shown(word) + "'");
      if (section->per_dim != 0 && dim == 0) in.fail(std::string(word) + " before Dimension");
      const std::uint64_t tokens = static_cast<std::uint64_t>(section->fixed + section->per_dim * dim);
      const std::uint64_t n = section->counted ? in.count(word, tokens) : 1;
      if (section->volume && n > 0)
        in.fail(std::to_string(n) + " " + std::string(word) + ": only all-hex meshes can be read");
      in.skip_tokens(n * tokens, std::string("a value of ") + std::string(word));
    }
  }
  for (std::size_t h = 0; h < mesh.hexes.size(); ++h)
    for (const uint32_t v : mesh.hexes[h])
      if (v >= mesh.points.size())
        throw FormatError("hexahedron " + std::to_string(h + 1) + " refers to vertex " + std::to_string(v + 1ull) +
                          " but the file has " + std::to_string(mesh.points.size()) + " vertices");
  return mesh;
}

// ---------------------------------------------------------------------------------------------
// Gmsh 4.1

// Puts elements or nodes in ascending tag order: `tags` in file order; returns the permutation
// (empty when the file order is already ascending). Tags must be unique.
std::vector<std::size_t> tag_order(const std::vector<std::uint64_t>& tags, std::string_view what) {
  std::vector<std::size_t> order;
  if (std::adjacent_find(tags.begin(), tags.end(), std::greater_equal<>()) == tags.end()) return order;
  order.resize(tags.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return tags[a] < tags[b]; });
  for (std::size_t i = 1; i < order.size(); ++i)
    if (tags[order[i]] == tags[order[i - 1]])
      throw FormatError(std::string(what) + " tag " + std::to_string(tags[order[i]]) + " is used twice");
  return order;
}

template <class T>
void permute(std::vector<T>& v, const std::vector<std::size_t>& order) {
  std::vector<T> out(v.size());
  for (std::size_t i = 0; i < order.size(); ++i) out[i] = v[order[i]];
  v.swap(out);
}

// Node tag -> point index, the points being numbered by ascending tag.
class NodeNumbering {
 public:
  NodeNumbering() = default;
  explicit NodeNumbering(std::vector<std::uint64_t> sorted_tags) : sorted_(std::move(sorted_tags)) {
    const std::size_t n = sorted_.size();
    identity_ = n == 0 || sorted_.back() == n;  // unique ascending tags ending at n are exactly 1..n
    if (!identity_ && sorted_.back() <= 4 * n + 1024) {
      dense_.assign(sorted_.back() + 1, kNone);
      for (std::size_t i = 0; i < n; ++i) dense_[sorted_[i]] = static_cast<uint32_t>(i);
    }
  }

  std::optional<uint32_t> index(std::uint64_t tag) const {
    if (identity_) {
      if (tag >= 1 && tag <= sorted_.size()) return static_cast<uint32_t>(tag - 1);
      return std::nullopt;
    }
    if (!dense_.empty()) {
      if (tag < dense_.size() && dense_[tag] != kNone) return dense_[tag];
      return std::nullopt;
    }
    const auto it = std::lower_bound(sorted_.begin(), sorted_.end(), tag);
    if (it == sorted_.end() || *it != tag) return std::nullopt;
    return static_cast<uint32_t>(it - sorted_.begin());
  }

 private:
  static constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();
  std::vector<std::uint64_t> sorted_;
  std::vector<uint32_t> dense_;
  bool identity_ = true;
};

class GmshReader {
 public:
  explicit GmshReader(std::string_view text) : in_(text, text, /*hash_comments=*/false) {}

  HexMesh read() {
    for (;;) {
      const std::string_view word = in_.next();
      if (word.empty()) break;
      if (word.size() < 2 || word[0] != '$')
        in_.fail("expected a section header such as $Nodes, found '" + shown(word) + "'");
      const std::string_view name = word.substr(1);
      if (!have_format_ && name != "MeshFormat" && name != "Comments")
        in_.fail("the file does not start with $MeshFormat: not a Gmsh file?");
      if (name == "MeshFormat") {
        read_format();
      } else if (name == "Entities") {
        read_entities();
      } else if (name == "Nodes") {
        read_nodes();
      } else if (name == "Elements") {
        read_elements();
      } else if (name.starts_with("End")) {
        in_.fail("'" + shown(word) + "' without its opening section");
      } else {
        // The format says that sections with unknown names are to be ignored.
        in_.skip_past("$End" + std::string(name));
      }
    }
    if (!have_format_) throw FormatError("empty file");
    if (!have_nodes_) throw FormatError("no $Nodes section");
    if (!have_elements_) throw FormatError("no $Elements section");
    return std::move(mesh_);
  }

 private:
  void read_format() {
    if (have_format_) in_.fail("a second $MeshFormat section");
    have_format_ = true;
    const std::string_view version = in_.token("the format version");
    if (version != "4.1")
      in_.fail("Gmsh format version " + shown(version) + " is not supported: save as version 4.1 ASCII");
    const std::string_view type = in_.token("the file type");
    if (type != "0") in_.fail("binary Gmsh files are not supported: save as version 4.1 ASCII");
    in_.integer<std::uint64_t>("the data size");
    in_.expect("$EndMeshFormat");
  }

  void read_entities() {
    std::array<std::uint64_t, 4> counts{};
    for (int d = 0; d < 4; ++d) counts[d] = in_.count("entity", d == 0 ? 5 : 9);
    for (int d = 0; d < 4; ++d) {
      for (std::uint64_t i = 0; i < counts[d]; ++i) {
        const auto tag = in_.integer<std::int64_t>("an entity tag");
        in_.skip_tokens(d == 0 ? 3 : 6, "an entity coordinate");
        const std::uint64_t physicals = in_.count("physical tag", 1);
        if (physicals > 0) {
          const auto first = in_.integer<std::int64_t>("a physical tag");
          if (d == 3) volume_physical_[tag] = to_region(first, in_);
          in_.skip_tokens(physicals - 1, "a physical tag");
        }
        if (d > 0) in_.skip_tokens(in_.count("bounding entity", 1), "a bounding entity tag");
      }
    }
    in_.expect("$EndEntities");
  }

  void read_nodes() {
    if (have_nodes_) in_.fail("a second $Nodes section");
    have_nodes_ = true;
    const std::uint64_t blocks = in_.count("node block", 4);
    const std::uint64_t total = in_.count("node", 4);
    if (total > kMaxPoints) in_.fail(std::to_string(total) + " nodes are more than 32-bit indices can address");
    in_.integer<std::uint64_t>("the smallest node tag");
    in_.integer<std::uint64_t>("the largest node tag");
    std::vector<std::uint64_t> tags;
    tags.reserve(total);
    mesh_.points.reserve(total);
    for (std::uint64_t b = 0; b < blocks; ++b) {
      const auto dim = in_.integer<std::int64_t>("an entity dimension");
      if (dim < 0 || dim > 3) in_.fail("entity dimension " + std::to_string(dim) + " is not 0..3");
      in_.integer<std::int64_t>("an entity tag");
      const auto parametric = in_.integer<std::int64_t>("the parametric flag");
      if (parametric != 0 && parametric != 1) in_.fail("parametric flag " + std::to_string(parametric) + " is not 0 or 1");
      const std::uint64_t k = in_.count("node", 4);
      if (k > total - tags.size()) in_.fail("the node blocks hold more than the " + std::to_string(total) + " nodes announced");
      for (std::uint64_t i = 0; i < k; ++i) {
        tags.push_back(in_.integer<std::uint64_t>("a node tag"));
        if (tags.back() == 0) in_.fail("node tag 0 (tags start at 1)");
      }
      const std::uint64_t extra = parametric != 0 ? static_cast<std::uint64_t>(dim) : 0;
      for (std::uint64_t i = 0; i < k; ++i) {
        Vec3 p;
        p.x = in_.real("a node coordinate");
        p.y = in_.real("a node coordinate");
        p.z = in_.real("a node coordinate");
        in_.skip_tokens(extra, "a parametric coordinate");
        mesh_.points.push_back(p);
      }
    }
    if (tags.size() != total)
      in_.fail("the node blocks hold " + std::to_string(tags.size()) + " nodes, not the " + std::to_string(total) +
               " announced");
    in_.expect("$EndNodes");
    const std::vector<std::size_t> order = tag_order(tags, "node");
    if (!order.empty()) {
      permute(tags, order);
      permute(mesh_.points, order);
    }
    nodes_ = NodeNumbering(std::move(tags));
  }

  void read_elements() {
    if (!have_nodes_) in_.fail("$Elements before $Nodes");
    if (have_elements_) in_.fail("a second $Elements section");
    have_elements_ = true;
    const std::uint64_t blocks = in_.count("element block", 4);
    const std::uint64_t total = in_.count("element", 2);
    in_.integer<std::uint64_t>("the smallest element tag");
    in_.integer<std::uint64_t>("the largest element tag");
    std::vector<std::uint64_t> tags;
    tags.reserve(total);
    mesh_.hexes.reserve(total);
    mesh_.region.reserve(total);
    std::uint64_t seen = 0;
    for (std::uint64_t b = 0; b < blocks; ++b) {
      const auto dim = in_.integer<std::int64_t>("an entity dimension");
      const auto entity = in_.integer<std::int64_t>("an entity tag");
      const auto type = in_.integer<std::int64_t>("an element type");
      const std::uint64_t k = in_.count("element", 2);
      if (k > total - seen) in_.fail("the element blocks hold more than the " + std::to_string(total) + " elements announced");
      seen += k;
      if (dim < 0 || dim > 3) in_.fail("entity dimension " + std::to_string(dim) + " is not 0..3");
      if (dim < 3) {
        // Boundary and lower-dimension elements; one element per line, so any type can be skipped.
        in_.skip_lines(k, "an element");
        continue;
      }
      constexpr std::int64_t kHexahedron8 = 5;
      if (type != kHexahedron8)
        in_.fail("volume entity " + std::to_string(entity) + " holds elements of type " + std::to_string(type) +
                 ": only 8-node hexahedra (type 5) can be read");
      const auto physical = volume_physical_.find(entity);
      const int32_t region = physical != volume_physical_.end() ? physical->second : to_region(entity, in_);
      for (std::uint64_t i = 0; i < k; ++i) {
        tags.push_back(in_.integer<std::uint64_t>("an element tag"));
        Hex hex;
        for (uint32_t& v : hex) {
          const auto tag = in_.integer<std::uint64_t>("a node tag");
          const std::optional<uint32_t> index = nodes_.index(tag);
          if (!index) in_.fail("element " + std::to_string(tags.back()) + " uses node " + std::to_string(tag) + ", which $Nodes does not define");
          v = *index;
        }
        mesh_.hexes.push_back(hex);
        mesh_.region.push_back(region);
      }
    }
    if (seen != total)
      in_.fail("the element blocks hold " + std::to_string(seen) + " elements, not the " + std::to_string(total) +
               " announced");
    in_.expect("$EndElements");
    const std::vector<std::size_t> order = tag_order(tags, "element");
    if (!order.empty()) {
      permute(mesh_.hexes, order);
      permute(mesh_.region, order);
    }
  }

  Scanner in_;
  HexMesh mesh_;
  NodeNumbering nodes_;
  std::map<std::int64_t, int32_t> volume_physical_;
  bool have_format_ = false;
  bool have_nodes_ = false;
  bool have_elements_ = false;
};

// ---------------------------------------------------------------------------------------------
// VTU

// Just enough XML for VTK files: elements, attributes, text; comments, declarations and
// processing instructions are skipped. Parsing stops at <AppendedData>, whose raw content is not
// XML; the arrays there are located by their offsets and sizes.
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

constexpr std::size_t kNoParent = std::numeric_limits<std::size_t>::max();

struct XmlDocument {
  std::vector<XmlElement> elements;   // in document order, elements[0] the root
  std::size_t appended = kNoParent;   // the AppendedData element, if any
  std::size_t appended_begin = 0;     // offset of the byte after its '_'
};

bool is_name_char(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == ':' ||
         c == '-' || c == '.';
}

[[noreturn]] void xml_fail(const std::string& message) { throw FormatError("XML: " + message); }

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
      if (e == std::string_view::npos) xml_fail("unterminated '" + std::string(text.substr(lt, 4)) + "' (truncated file?)");
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
      if (key.empty() || i >= text.size() || text[i] != '=') xml_fail("malformed attribute in <" + shown(element.name) + ">");
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
      const std::uint32_t bits = (static_cast<std::uint32_t>(group[0]) << 18) | (static_cast<std::uint32_t>(group[1]) << 12) |
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

enum class Scalar { kInt8, kUInt8, kInt16, kUInt16, kInt32, kUInt32, kInt64, kUInt64, kFloat32, kFloat64 };

std::optional<Scalar> scalar_type(std::string_view name) {
  static constexpr std::pair<std::string_view, Scalar> kTypes[] = {
      {"Int8", Scalar::kInt8},     {"UInt8", Scalar::kUInt8},     {"Int16", Scalar::kInt16},
      {"UInt16", Scalar::kUInt16}, {"Int32", Scalar::kInt32},     {"UInt32", Scalar::kUInt32},
      {"Int64", Scalar::kInt64},   {"UInt64", Scalar::kUInt64},   {"Float32", Scalar::kFloat32},
      {"Float64", Scalar::kFloat64}};
  for (const auto& [n, s] : kTypes)
    if (n == name) return s;
  return std::nullopt;
}

std::size_t scalar_size(Scalar s) {
  switch (s) {
    case Scalar::kInt8:
    case Scalar::kUInt8:
      return 1;
    case Scalar::kInt16:
    case Scalar::kUInt16:
      return 2;
    case Scalar::kInt32:
    case Scalar::kUInt32:
    case Scalar::kFloat32:
      return 4;
    default:
      return 8;
  }
}

template <class Src>
Src load(const unsigned char* p, bool swap) {
  std::array<unsigned char, sizeof(Src)> b;
  std::memcpy(b.data(), p, sizeof(Src));
  if (swap) std::reverse(b.begin(), b.end());
  Src v;
  std::memcpy(&v, b.data(), sizeof(Src));
  return v;
}

// Converts `count` packed values of type Src; false if a value does not fit T.
template <class Src, class T>
bool convert_all(const unsigned char* bytes, std::size_t count, bool swap, std::vector<T>& out) {
  out.resize(count);
  for (std::size_t i = 0; i < count; ++i) {
    const Src v = load<Src>(bytes + i * sizeof(Src), swap);
    if constexpr (std::is_same_v<Src, std::uint64_t> && std::is_integral_v<T>) {
      if (v > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) return false;
    }
    out[i] = static_cast<T>(v);
  }
  return true;
}

class VtuReader {
 public:
  explicit VtuReader(std::string_view text) : text_(text), doc_(parse_vtk_xml(text)) {}

  HexMesh read() {
    const XmlElement& root = doc_.elements.front();
    if (root.name != "VTKFile") fail("not a VTK XML file (the root element is <" + shown(root.name) + ">)");
    const auto type = root.attribute("type");
    if (type != "UnstructuredGrid")
      fail("VTK file type '" + shown(type.value_or("")) + "' is not supported, only UnstructuredGrid");
    if (const auto compressor = root.attribute("compressor"))
      fail("compressed data (" + shown(*compressor) + ") is not supported: write the file uncompressed");
    const auto order = root.attribute("byte_order").value_or("LittleEndian");
    if (order != "LittleEndian" && order != "BigEndian") fail("unknown byte_order '" + shown(order) + "'");
    swap_ = order == "BigEndian";
    const auto header = root.attribute("header_type").value_or("UInt32");
    if (header != "UInt32" && header != "UInt64") fail("unknown header_type '" + shown(header) + "'");
    header_size_ = header == "UInt64" ? 8 : 4;
    if (doc_.appended != kNoParent) {
      const auto encoding = doc_.elements[doc_.appended].attribute("encoding");
      if (encoding != "raw" && encoding != "base64")
        fail("unknown AppendedData encoding '" + shown(encoding.value_or("")) + "'");
      raw_ = encoding == "raw";
    }

    const std::size_t grid = only_child(0, "UnstructuredGrid");
    const std::size_t piece = only_child(grid, "Piece");
    const XmlElement& p = doc_.elements[piece];
    const std::uint64_t n = size_attribute(p, "NumberOfPoints");
    const std::uint64_t m = size_attribute(p, "NumberOfCells");
    if (n > kMaxPoints) fail(std::to_string(n) + " points are more than 32-bit indices can address");

    HexMesh mesh;
    if (n > 0) {
      const XmlElement& da = doc_.elements[only_child(only_child(piece, "Points"), "DataArray")];
      if (da.attribute("NumberOfComponents").value_or("1") != "3") fail("Points do not have 3 components");
      const std::vector<double> xyz = array<double>(da, 3 * n, "Points");
      mesh.points.resize(n);
      for (std::size_t i = 0; i < n; ++i) {
        mesh.points[i] = {xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]};
        if (!is_finite(mesh.points[i])) fail("point " + std::to_string(i) + " has a non-finite coordinate");
      }
    }
    if (m > 0) {
      const std::size_t cells = only_child(piece, "Cells");
      const std::vector<std::int64_t> offsets = array<std::int64_t>(named_array(cells, "offsets"), m, "offsets");
      const std::vector<std::int64_t> types = array<std::int64_t>(named_array(cells, "types"), m, "types");
      std::int64_t previous = 0;
      for (std::size_t c = 0; c < m; ++c) {
        if (offsets[c] < previous) fail("offsets decrease at cell " + std::to_string(c));
        previous = offsets[c];
      }
      const std::vector<std::int64_t> connectivity =
          array<std::int64_t>(named_array(cells, "connectivity"), static_cast<std::uint64_t>(previous), "connectivity");
      std::vector<std::int64_t> labels(m, 0);
      if (const XmlElement* da = region_array(piece)) labels = array<std::int64_t>(*da, m, "region");

      constexpr std::int64_t kVtkHexahedron = 12;
      constexpr std::int64_t kLastLowerDimension = 9;  // VTK_QUAD; 1..9 are vertices, lines, faces
      for (std::size_t c = 0; c < m; ++c) {
        const std::int64_t begin = c == 0 ? 0 : offsets[c - 1];
        if (types[c] >= 1 && types[c] <= kLastLowerDimension) continue;
        if (types[c] != kVtkHexahedron)
          fail("cell " + std::to_string(c) + " has VTK type " + std::to_string(types[c]) +
               ": only hexahedra (12) and cells of dimension < 3 can be read");
        if (offsets[c] - begin != 8)
          fail("hexahedron " + std::to_string(c) + " has " + std::to_string(offsets[c] - begin) + " points, not 8");
        Hex hex;
        for (int k = 0; k < 8; ++k) {
          const std::int64_t v = connectivity[static_cast<std::size_t>(begin + k)];
          if (v < 0 || static_cast<std::uint64_t>(v) >= n)
            fail("cell " + std::to_string(c) + " refers to point " + std::to_string(v) + " but there are " +
                 std::to_string(n) + " points");
          hex[k] = static_cast<uint32_t>(v);
        }
        if (labels[c] < std::numeric_limits<int32_t>::min() || labels[c] > std::numeric_limits<int32_t>::max())
          fail("region label " + std::to_string(labels[c]) + " of cell " + std::to_string(c) + " does not fit in 32 bits");
        mesh.hexes.push_back(hex);
        mesh.region.push_back(static_cast<int32_t>(labels[c]));
      }
    }
    if (doc_.appended != kNoParent) {
      // The XML parse stopped at the appended data: make sure the file goes on to its end.
      const std::size_t close = text_.find("</AppendedData>", appended_end_);
      if (close == std::string_view::npos || text_.find("</VTKFile>", close) == std::string_view::npos)
        fail("the file ends inside <AppendedData> (truncated file?)");
    }
    return mesh;
  }

 private:
  [[noreturn]] static void fail(const std::string& message) { throw FormatError("VTU: " + message); }

  std::size_t only_child(std::size_t parent, std::string_view name) const {
    std::size_t found = kNoParent;
    for (std::size_t i = 0; i < doc_.elements.size(); ++i) {
      if (doc_.elements[i].parent != parent || doc_.elements[i].name != name) continue;
      if (found != kNoParent)
        fail("more than one <" + std::string(name) + ">" + (name == "Piece" ? ": only single-piece files can be read" : ""));
      found = i;
    }
    if (found == kNoParent) fail("no <" + std::string(name) + "> in <" + shown(doc_.elements[parent].name) + ">");
    return found;
  }

  const XmlElement* find_array(std::size_t parent, std::string_view name) const {
    for (const XmlElement& e : doc_.elements)
      if (e.name == "DataArray" && e.parent == parent && e.attribute("Name") == name) return &e;
    return nullptr;
  }

  const XmlElement& named_array(std::size_t parent, std::string_view name) const {
    const XmlElement* e = find_array(parent, name);
    if (e == nullptr) fail("no DataArray '" + std::string(name) + "' in <Cells>");
    return *e;
  }

  const XmlElement* region_array(std::size_t piece) const {
    for (std::size_t i = 0; i < doc_.elements.size(); ++i) {
      if (doc_.elements[i].parent != piece || doc_.elements[i].name != "CellData") continue;
      for (const std::string_view name : {"region", "medit:ref", "gmsh:physical"})
        if (const XmlElement* e = find_array(i, name)) return e;
    }
    return nullptr;
  }

  static std::uint64_t size_attribute(const XmlElement& e, std::string_view key) {
    std::uint64_t v = 0;
    if (!parse_int(e.attribute(key).value_or(""), v)) fail("<" + shown(e.name) + "> has no valid " + std::string(key));
    return v;
  }

  template <class T>
  std::vector<T> array(const XmlElement& da, std::uint64_t count, std::string_view name) {
    const std::string what = "DataArray '" + std::string(name) + "'";
    const std::optional<Scalar> type = scalar_type(da.attribute("type").value_or(""));
    if (!type) fail(what + " has unknown type '" + shown(da.attribute("type").value_or("")) + "'");
    if (std::is_integral_v<T> && (*type == Scalar::kFloat32 || *type == Scalar::kFloat64))
      fail(what + " holds floating-point values where integers are expected");
    // Any encoding needs at least one byte per value: larger counts are corrupt, and refusing
    // them keeps the byte counts below from overflowing.
    if (count > text_.size()) fail(what + ": " + std::to_string(count) + " values cannot fit in this file");
    const std::string_view format = da.attribute("format").value_or("ascii");
    if (format == "ascii") return ascii_array<T>(da, count, what);

    const std::uint64_t expected = count * scalar_size(*type);
    std::vector<unsigned char> bytes;
    std::size_t data_begin = 0;
    if (format == "binary" || (format == "appended" && !raw_)) {
      std::string_view encoded = da.content;
      if (format == "appended") {
        if (doc_.appended == kNoParent) fail(what + " is appended but the file has no <AppendedData>");
        const std::string_view rest = text_.substr(doc_.appended_begin);
        encoded = rest.substr(0, rest.find('<'));
        const std::uint64_t offset = size_attribute(da, "offset");
        if (offset > encoded.size()) fail(what + ": offset " + std::to_string(offset) + " is past the end of the data");
        encoded.remove_prefix(offset);
        appended_end_ = std::max(appended_end_, doc_.appended_begin + offset + encoded.size());
      }
      Base64Reader reader(encoded);
      if (!reader.read(bytes, header_size_)) fail(what + ": the data ends inside its header (truncated file?)");
      check_block_size(what, block_size(bytes.data()), expected);
      if (!reader.read(bytes, header_size_ + expected)) fail(what + ": the data is shorter than its header says (truncated file?)");
      data_begin = header_size_;
    } else if (format == "appended") {
      if (doc_.appended == kNoParent) fail(what + " is appended but the file has no <AppendedData>");
      const std::uint64_t offset = size_attribute(da, "offset");
      const std::uint64_t begin = doc_.appended_begin;
      if (offset > text_.size() - begin || text_.size() - begin - offset < header_size_)
        fail(what + ": offset " + std::to_string(offset) + " is past the end of the file (truncated file?)");
      const auto* header = reinterpret_cast<const unsigned char*>(text_.data() + begin + offset);
      check_block_size(what, block_size(header), expected);
      if (text_.size() - begin - offset - header_size_ < expected)
        fail(what + ": the file ends inside its data (truncated file?)");
      appended_end_ = std::max<std::size_t>(appended_end_, begin + offset + header_size_ + expected);
      return convert<T>(header + header_size_, count, *type, what);
    } else {
      fail(what + " has unknown format '" + shown(format) + "'");
    }
    return convert<T>(bytes.data() + data_begin, count, *type, what);
  }

  std::uint64_t block_size(const unsigned char* p) const {
    return header_size_ == 8 ? load<std::uint64_t>(p, swap_) : load<std::uint32_t>(p, swap_);
  }

  static void check_block_size(const std::string& what, std::uint64_t got, std::uint64_t expected) {
    if (got != expected)
      fail(what + " holds " + std::to_string(got) + " bytes where " + std::to_string(expected) + " are expected");
  }

  template <class T>
  std::vector<T> convert(const unsigned char* bytes, std::size_t count, Scalar type, const std::string& what) const {
    std::vector<T> out;
    bool ok = true;
    switch (type) {
      case Scalar::kInt8: ok = convert_all<std::int8_t>(bytes, count, swap_, out); break;
      case Scalar::kUInt8: ok = convert_all<std::uint8_t>(bytes, count, swap_, out); break;
      case Scalar::kInt16: ok = convert_all<std::int16_t>(bytes, count, swap_, out); break;
      case Scalar::kUInt16: ok = convert_all<std::uint16_t>(bytes, count, swap_, out); break;
      case Scalar::kInt32: ok = convert_all<std::int32_t>(bytes, count, swap_, out); break;
      case Scalar::kUInt32: ok = convert_all<std::uint32_t>(bytes, count, swap_, out); break;
      case Scalar::kInt64: ok = convert_all<std::int64_t>(bytes, count, swap_, out); break;
      case Scalar::kUInt64: ok = convert_all<std::uint64_t>(bytes, count, swap_, out); break;
      case Scalar::kFloat32:
        if constexpr (std::is_floating_point_v<T>) ok = convert_all<float>(bytes, count, swap_, out);
        break;
      case Scalar::kFloat64:
        if constexpr (std::is_floating_point_v<T>) ok = convert_all<double>(bytes, count, swap_, out);
        break;
    }
    if (!ok) fail(what + " holds a value that does not fit in 64 bits");
    return out;
  }

  template <class T>
  std::vector<T> ascii_array(const XmlElement& da, std::uint64_t count, const std::string& what) const {
    Scanner in(text_, da.content, /*hash_comments=*/false);
    if (count > da.content.size() / 2 + 1)
      fail(what + ": " + std::to_string(count) + " values cannot fit in its text (truncated or corrupt file?)");
    const std::string item = "a value of " + what;
    std::vector<T> out(count);
    for (T& v : out) {
      if constexpr (std::is_floating_point_v<T>) {
        v = in.real(item);
      } else {
        v = in.integer<std::int64_t>(item);
      }
    }
    if (!in.next().empty()) in.fail(what + " holds more than the " + std::to_string(count) + " values expected");
    return out;
  }

  std::string_view text_;
  XmlDocument doc_;
  bool swap_ = false;
  bool raw_ = false;
  std::size_t header_size_ = 4;
  std::size_t appended_end_ = 0;
};

}  // namespace

MeshFormat mesh_format(const std::filesystem::path& path) {
  const std::string extension = path.extension().string();
  std::string lower = extension;
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](char c) { return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c; });
  if (lower == ".mesh") return MeshFormat::kMedit;
  if (lower == ".vtu") return MeshFormat::kVtu;
  if (lower == ".msh") return MeshFormat::kGmsh;
  if (extension.empty())
    throw InputError(path.string() + ": no file extension to tell the mesh format (use .mesh, .vtu or .msh)");
  throw InputError(path.string() + ": unknown mesh format '" + extension + "' (use .mesh, .vtu or .msh)");
}

void write_hex_mesh(const HexMesh& mesh, const std::filesystem::path& path) {
  const MeshFormat format = mesh_format(path);
  try {
    check_writable(mesh);
    AtomicFile out(path);
    switch (format) {
      case MeshFormat::kMedit: write_medit(mesh, out); break;
      case MeshFormat::kVtu: write_vtu(mesh, out); break;
      case MeshFormat::kGmsh: write_gmsh(mesh, out); break;
    }
    out.commit();
  } catch (const FormatError& e) {
    throw InputError(path.string() + ": " + e.what());
  }
}

HexMesh read_hex_mesh(const std::filesystem::path& path) {
  const MeshFormat format = mesh_format(path);
  try {
    const MappedFile file(path);
    const std::string_view text = file.text();
    switch (format) {
      case MeshFormat::kMedit: return read_medit(text);
      case MeshFormat::kVtu: return VtuReader(text).read();
      case MeshFormat::kGmsh: return GmshReader(text).read();
    }
    throw FormatError("unknown format");
  } catch (const FormatError& e) {
    throw InputError(path.string() + ": " + e.what());
  }
}

}  // namespace mchex
