// MEDIT binary .meshb (libMeshb's Gamma Mesh Format, binary flavour); mesh_io.h states the contract.
//
// Layout (docs/formats.md): a 4-byte code 1 (it reads 16777216 in the other byte order), a 4-byte
// version, then keywords. Each keyword is a 4-byte code and the file position of the next keyword;
// a counted keyword (Vertices, Hexahedra, ...) follows with its record count, then its records.
// The version fixes the sizes: 1 float reals, int32 integers, int32 positions; 2 double reals;
// 3 int64 positions; 4 int64 integers and counts as well.
//
// Written: version 3 (double coordinates, 32-bit indices and references, 64-bit positions) while
// every 1-based index and count fits int32, else version 4; Dimension 3, Vertices with reference 0,
// Hexahedra in HexMesh corner order with the region as reference, End. Read: either byte order,
// versions 1 to 4; keywords other than Dimension, Vertices, Hexahedra and End are skipped through
// their next-keyword position, but another volume element (tetrahedra, prisms, pyramids,
// higher-order hexahedra) is an error, not a silent drop. Every count and position is checked
// against the file size before it is used.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>

#include "core/io/format_error.h"
#include "core/io/mesh_formats.h"
#include "core/io/record_writer.h"

namespace mchex::io_detail {
namespace {

static_assert(std::endian::native == std::endian::little, "the .meshb writer assumes a little-endian host");

// libMeshb's keyword codes (its GmfKwdCod enumeration).
enum Keyword : int32_t {
  kDimension = 3,
  kVertices = 4,
  kTetrahedra = 8,
  kPrisms = 9,
  kHexahedra = 10,
  kTetrahedraP2 = 30,
  kHexahedraQ2 = 33,
  kPyramids = 49,
  kEnd = 54,
};

bool other_volume_element(int32_t code) {
  return code == kTetrahedra || code == kPrisms || code == kTetrahedraP2 || code == kHexahedraQ2 || code == kPyramids;
}

class MeshbReader {
 public:
  explicit MeshbReader(std::string_view bytes) : data_(bytes) {}

  HexMesh read() {
    const auto code = static_cast<uint32_t>(u32("the byte-order code"));
    if (code == 0x01000000u) {
      swap_ = true;
    } else if (code != 1) {
      throw FormatError("not a MEDIT binary file (its first 4 bytes are not the code 1)");
    }
    version_ = static_cast<int32_t>(u32("the version"));
    if (version_ < 1 || version_ > 4) fail("unknown .meshb version " + std::to_string(version_));
    HexMesh mesh;
    int32_t dim = 0;
    bool have_vertices = false;
    for (;;) {
      const std::size_t at = pos_;
      const auto keyword = static_cast<int32_t>(u32("a keyword (no End keyword: truncated file?)"));
      const std::uint64_t next = position();  // End has one too (0): a file cut there is truncated
      if (keyword == kEnd) break;
      if (keyword == kDimension) {
        dim = static_cast<int32_t>(u32("the Dimension value"));
        if (dim != 3) fail("Dimension " + std::to_string(dim) + ": only 3D meshes are supported", at);
      } else if (keyword == kVertices) {
        if (dim != 3) fail("Vertices before Dimension 3", at);
        if (have_vertices) fail("a second Vertices section", at);
        have_vertices = true;
        const std::size_t real = version_ == 1 ? 4 : 8;
        const std::uint64_t n = count("Vertices", 3 * real + integer_size());
        if (n > kMaxPoints) fail(std::to_string(n) + " vertices are more than 32-bit indices can address", at);
        mesh.points.resize(n);
        for (Vec3& p : mesh.points) {
          for (int a = 0; a < 3; ++a) p[a] = coordinate();
          pos_ += integer_size();  // the vertex reference
        }
      } else if (keyword == kHexahedra) {
        const std::uint64_t n = count("Hexahedra", 9 * integer_size());
        const std::size_t first = mesh.hexes.size();
        mesh.hexes.resize(first + n);
        mesh.region.resize(first + n);
        for (std::size_t h = first; h < mesh.hexes.size(); ++h) {
          for (uint32_t& v : mesh.hexes[h]) {
            const std::int64_t index = integer();
            // Vertices normally come first; otherwise the range is checked at the end.
            if (index < 1 || static_cast<std::uint64_t>(index) > (have_vertices ? mesh.points.size() : kMaxPoints))
              fail("hexahedron " + std::to_string(h + 1) + " has vertex index " + std::to_string(index) +
                   " out of range" + (have_vertices ? " 1.." + std::to_string(mesh.points.size()) : std::string()));
            v = static_cast<uint32_t>(index - 1);
          }
          const std::int64_t ref = integer();
          if (ref < std::numeric_limits<int32_t>::min() || ref > std::numeric_limits<int32_t>::max())
            fail("region label " + std::to_string(ref) + " does not fit in 32 bits");
          mesh.region[h] = static_cast<int32_t>(ref);
        }
      } else if (other_volume_element(keyword)) {
        fail("keyword " + std::to_string(keyword) +
                 " holds volume elements other than hexahedra: only all-hex "
                 "meshes can be read",
             at);
      } else {
        // Edges, triangles, quadrilaterals, normals, corners, solutions...: skipped by position.
        if (next <= at || next > data_.size())
          fail("keyword " + std::to_string(keyword) + " gives next position " + std::to_string(next) +
                   ", outside the file (truncated or corrupt file?)",
               at);
        pos_ = static_cast<std::size_t>(next);
      }
    }
    for (std::size_t h = 0; h < mesh.hexes.size(); ++h)
      for (const uint32_t v : mesh.hexes[h])
        if (v >= mesh.points.size())
          throw FormatError("hexahedron " + std::to_string(h + 1) + " refers to vertex " + std::to_string(v + 1ull) +
                            " but the file has " + std::to_string(mesh.points.size()) + " vertices");
    return mesh;
  }

 private:
  [[noreturn]] void fail(const std::string& message, std::size_t at) const {
    throw FormatError("byte " + std::to_string(at) + ": " + message);
  }
  [[noreturn]] void fail(const std::string& message) const { fail(message, pos_); }

  void need(std::size_t bytes, std::string_view what) const {
    if (data_.size() - pos_ < bytes)
      fail("unexpected end of file where " + std::string(what) + " was expected (truncated file?)");
  }

  template <class T>
  T load() {
    T v;
    std::memcpy(&v, data_.data() + pos_, sizeof v);
    pos_ += sizeof v;
    if (swap_) {
      if constexpr (sizeof v == 4) {
        v = __builtin_bswap32(v);
      } else {
        v = __builtin_bswap64(v);
      }
    }
    return v;
  }

  uint32_t u32(std::string_view what) {
    need(4, what);
    return load<uint32_t>();
  }
  std::size_t integer_size() const { return version_ >= 4 ? 8 : 4; }
  std::uint64_t position() {
    if (version_ >= 3) {
      need(8, "a keyword position");
      return load<std::uint64_t>();
    }
    need(4, "a keyword position");
    return load<uint32_t>();
  }
  // The caller has checked the bytes (count()).
  std::int64_t integer() {
    if (version_ >= 4) return static_cast<std::int64_t>(load<std::uint64_t>());
    return static_cast<int32_t>(load<uint32_t>());
  }
  double coordinate() {
    double v;
    if (version_ == 1) {
      v = std::bit_cast<float>(load<uint32_t>());
    } else {
      v = std::bit_cast<double>(load<std::uint64_t>());
    }
    if (!std::isfinite(v)) fail("a vertex coordinate is not a finite number", pos_ - (version_ == 1 ? 4 : 8));
    return v;
  }
  // A record count, refused when the rest of the file cannot hold that many records.
  std::uint64_t count(std::string_view what, std::size_t record_bytes) {
    need(integer_size(), std::string(what) + " count");
    const std::int64_t c = integer();
    if (c < 0) fail(std::string(what) + " count " + std::to_string(c) + " is negative");
    if (static_cast<std::uint64_t>(c) > (data_.size() - pos_) / record_bytes)
      fail(std::string(what) + " count " + std::to_string(c) +
           " is more than the rest of the file can hold (truncated or corrupt file?)");
    return static_cast<std::uint64_t>(c);
  }

  std::string_view data_;
  std::size_t pos_ = 0;
  bool swap_ = false;
  int32_t version_ = 0;
};

template <class T>
void put(std::string& s, T v) {
  char b[sizeof v];
  std::memcpy(b, &v, sizeof v);
  s.append(b, sizeof v);
}

}  // namespace

void write_meshb(const HexMesh& mesh, AtomicFile& out) {
  constexpr std::uint64_t kInt32 = std::numeric_limits<int32_t>::max();
  const std::uint64_t n = mesh.points.size();
  const std::uint64_t m = mesh.hexes.size();
  const bool wide = n > kInt32 || m > kInt32;  // version 4: 64-bit indices and counts
  const std::uint64_t int_size = wide ? 8 : 4;
  const std::uint64_t vertex_bytes = 3 * 8 + int_size;
  const std::uint64_t hex_bytes = 9 * int_size;

  // Positions: header (code, version) 8; Dimension: code, position, value; a counted keyword:
  // code, position, count, records; End: code, position 0.
  std::uint64_t at = 8 + 4 + 8 + 4;
  std::string s;
  put<int32_t>(s, 1);
  put<int32_t>(s, wide ? 4 : 3);
  put<int32_t>(s, kDimension);
  put<std::uint64_t>(s, at);
  put<int32_t>(s, 3);
  auto keyword = [&](int32_t code, std::uint64_t records, std::uint64_t record_bytes) {
    at += 4 + 8 + int_size + records * record_bytes;
    put<int32_t>(s, code);
    put<std::uint64_t>(s, at);
    if (wide) {
      put<std::uint64_t>(s, records);
    } else {
      put<uint32_t>(s, static_cast<uint32_t>(records));
    }
  };
  keyword(kVertices, n, vertex_bytes);
  out.write(s);
  write_records(out, n, vertex_bytes, [&](std::size_t begin, std::size_t end, char* p) {
    for (std::size_t i = begin; i < end; ++i) {
      std::memcpy(p, &mesh.points[i], 24);
      std::memset(p + 24, 0, int_size);  // reference 0
      p += vertex_bytes;
    }
    return p;
  });
  if (m != 0) {
    s.clear();
    keyword(kHexahedra, m, hex_bytes);
    out.write(s);
    write_records(out, m, hex_bytes, [&](std::size_t begin, std::size_t end, char* p) {
      auto put_records = [&]<class Int>(Int) {
        for (std::size_t h = begin; h < end; ++h) {
          Int record[9];
          for (int c = 0; c < 8; ++c) record[c] = static_cast<Int>(std::int64_t{mesh.hexes[h][c]} + 1);
          record[8] = mesh.region[h];
          std::memcpy(p, record, sizeof record);
          p += sizeof record;
        }
      };
      if (wide) {
        put_records(std::int64_t{});
      } else {
        put_records(int32_t{});
      }
      return p;
    });
  }
  s.clear();
  put<int32_t>(s, kEnd);
  put<std::uint64_t>(s, 0);
  out.write(s);
}

HexMesh read_meshb(std::string_view bytes) { return MeshbReader(bytes).read(); }

}  // namespace mchex::io_detail
