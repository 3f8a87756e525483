// VTK XML UnstructuredGrid .vtu; mesh_io.h states the contract.
//
// Written: Float64 points, Int64 connectivity and offsets, UInt8 types (VTK_HEXAHEDRON, 12), an
// Int32 CellData "region" and a Float64 CellData "scaled_jacobian" (each hex's minimum over the 9
// points, core/mesh/quality.h, so that ParaView can colour by it without a filter of its own;
// computed here unless the caller passes the values, MeshWriteOptions), as raw appended
// little-endian data with UInt64 block headers, so that the large arrays go from memory to the
// file without formatting. Read: one Piece, ascii, base64 "binary" or appended (raw
// or base64) DataArrays, uncompressed, either byte order, UInt32 or UInt64 headers, any integer
// type for indices, other cell arrays ignored; every offset and block size is checked against the
// file before it is used, so a truncated or corrupt file is an error and never a read past its
// end.
#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/base/parallel.h"
#include "core/io/base64.h"
#include "core/io/format_error.h"
#include "core/io/mesh_formats.h"
#include "core/io/record_writer.h"
#include "core/io/scanner.h"
#include "core/io/text_numbers.h"
#include "core/io/vtk_xml.h"
#include "core/mesh/quality.h"

namespace mchex::io_detail {
namespace {

// The VTU writer copies points and labels from memory into a file that declares LittleEndian.
static_assert(std::endian::native == std::endian::little, "the VTU writer assumes a little-endian host");
static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 must be three packed doubles");

enum class Scalar { kInt8, kUInt8, kInt16, kUInt16, kInt32, kUInt32, kInt64, kUInt64, kFloat32, kFloat64 };

std::optional<Scalar> scalar_type(std::string_view name) {
  static constexpr std::pair<std::string_view, Scalar> kTypes[] = {
      {"Int8", Scalar::kInt8},      {"UInt8", Scalar::kUInt8},   {"Int16", Scalar::kInt16},
      {"UInt16", Scalar::kUInt16},  {"Int32", Scalar::kInt32},   {"UInt32", Scalar::kUInt32},
      {"Int64", Scalar::kInt64},    {"UInt64", Scalar::kUInt64}, {"Float32", Scalar::kFloat32},
      {"Float64", Scalar::kFloat64}};
  for (const auto& [n, s] : kTypes)
    if (n == name) return s;
  return std::nullopt;
}

std::size_t scalar_size(Scalar s) {
  switch (s) {
    case Scalar::kInt8:
    case Scalar::kUInt8: return 1;
    case Scalar::kInt16:
    case Scalar::kUInt16: return 2;
    case Scalar::kInt32:
    case Scalar::kUInt32:
    case Scalar::kFloat32: return 4;
    default: return 8;
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
          fail("region label " + std::to_string(labels[c]) + " of cell " + std::to_string(c) +
               " does not fit in 32 bits");
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
        fail("more than one <" + std::string(name) + ">" +
             (name == "Piece" ? ": only single-piece files can be read" : ""));
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
    // std::string("<"), not "<" + ...: GCC 12's -Wrestrict misreads the inlined insert at the front.
    if (!parse_int(e.attribute(key).value_or(""), v))
      fail(std::string("<") + shown(e.name) + "> has no valid " + std::string(key));
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
      if (!reader.read(bytes, header_size_ + expected))
        fail(what + ": the data is shorter than its header says (truncated file?)");
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

void write_vtu(const HexMesh& mesh, AtomicFile& out, std::span<const double> scaled_jacobians) {
  const std::uint64_t n = mesh.points.size();
  const std::uint64_t m = mesh.hexes.size();
  constexpr std::uint8_t kVtkHexahedron = 12;
  const std::array<std::uint64_t, 6> bytes = {n * sizeof(Vec3),    m * 8 * sizeof(int64_t), m * sizeof(int64_t), m,
                                              m * sizeof(int32_t), m * sizeof(double)};
  std::array<std::uint64_t, 6> offset{};
  for (std::size_t i = 1; i < offset.size(); ++i) offset[i] = offset[i - 1] + sizeof(std::uint64_t) + bytes[i - 1];
  auto off = [&](std::size_t i) { return std::to_string(offset[i]); };

  // One line of the file per line here (clang-format 14 knows only the bare off/on markers).
  // clang-format off
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
      "        <DataArray type=\"Float64\" Name=\"scaled_jacobian\" format=\"appended\" offset=\"" + off(5) + "\"/>\n"
      "      </CellData>\n"
      "    </Piece>\n"
      "  </UnstructuredGrid>\n"
      // meshio finds the raw bytes between the '_' and the last newline before </AppendedData>.
      "  <AppendedData encoding=\"raw\">\n"
      "   _";
  // clang-format on
  out.write(xml);

  auto block_header = [&](std::uint64_t size) { out.write(&size, sizeof size); };

  block_header(bytes[0]);
  out.write(mesh.points.data(), bytes[0]);

  block_header(bytes[1]);
  write_records(out, m, 8 * sizeof(int64_t), [&](std::size_t begin, std::size_t end, char* p) {
    for (std::size_t h = begin; h < end; ++h, p += 8 * sizeof(int64_t)) {
      int64_t record[8];
      for (int c = 0; c < 8; ++c) record[c] = mesh.hexes[h][c];
      std::memcpy(p, record, sizeof record);
    }
    return p;
  });

  block_header(bytes[2]);
  write_records(out, m, sizeof(int64_t), [&](std::size_t begin, std::size_t end, char* p) {
    for (std::size_t h = begin; h < end; ++h, p += sizeof(int64_t)) {
      const auto offset = static_cast<int64_t>(8 * (h + 1));
      std::memcpy(p, &offset, sizeof offset);
    }
    return p;
  });

  block_header(bytes[3]);
  write_records(out, m, 1, [&](std::size_t begin, std::size_t end, char* p) {
    std::memset(p, kVtkHexahedron, end - begin);
    return p + (end - begin);
  });

  block_header(bytes[4]);
  out.write(mesh.region.data(), bytes[4]);

  block_header(bytes[5]);
  if (!scaled_jacobians.empty()) {
    out.write(scaled_jacobians.data(), bytes[5]);
  } else {
    // Computed chunk by chunk on all threads as it is written: no array of m values beside the mesh.
    write_records(out, m, sizeof(double), [&](std::size_t begin, std::size_t end, char* p) {
      for (std::size_t h = begin; h < end; ++h, p += sizeof(double)) {
        const double q = scaled_jacobian(mesh.corners(h));
        std::memcpy(p, &q, sizeof q);
      }
      return p;
    });
  }

  out.write("\n  </AppendedData>\n</VTKFile>\n");
}

HexMesh read_vtu(std::string_view text) { return VtuReader(text).read(); }

}  // namespace mchex::io_detail
