// Gmsh .msh, version 4.1, ascii or binary; mesh_io.h states the contract.
//
// Binary (file-type 1, as `gmsh -bin` writes): the same sections, with $Entities, $Nodes and
// $Elements holding native little-endian data (int 4 bytes, size_t 8 bytes, double 8 bytes), the
// $MeshFormat line followed by the int 1 to tell the byte order; docs/formats.md has the layout.
//
// Written: one volume entity per region value, the region as its physical tag (meshio's
// "gmsh:physical"), element blocks along runs of equal regions so that every reader keeps the hex
// order, nodes and elements tagged 1..n in order. Read: the sections in any order the format
// allows, unknown sections skipped as the format asks; nodes and hexes are put in ascending tag
// order (the order the tags define, whatever the block order), elements of dimension < 3 are
// skipped and any other 3D element is an error. Every count is checked against the rest of the
// file before anything is allocated for it.
#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <cstring>
#include <functional>
#include <iterator>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "core/io/format_error.h"
#include "core/io/mesh_formats.h"
#include "core/io/record_writer.h"
#include "core/io/scanner.h"
#include "core/io/text_numbers.h"

namespace mchex::io_detail {
namespace {

// The binary writer copies points and indices from memory as the little-endian data it declares.
static_assert(std::endian::native == std::endian::little, "the binary .msh writer assumes a little-endian host");
static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 must be three packed doubles");

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

// Nodes per element of the Gmsh element types a binary file may hold beside hexahedra (a binary
// element block cannot be skipped by lines); 0 for a type this reader does not know.
std::size_t gmsh_nodes_per_element(std::int64_t type) {
  constexpr std::size_t kNodes[] = {0, 2, 3, 4, 4, 8, 6, 5, 3, 6, 9, 10, 27, 18, 14, 1, 8, 20, 15, 13};
  return type >= 0 && type < static_cast<std::int64_t>(std::size(kNodes)) ? kNodes[type] : 0;
}

template <class T>
void put_binary(std::string& s, T v) {
  char b[sizeof v];
  std::memcpy(b, &v, sizeof v);
  s.append(b, sizeof v);
}

// The binary data between the tokens of a binary file, bounds-checked.
class Bytes {
 public:
  Bytes(const char* file_begin, const char* p, const char* end) : begin_(file_begin), p_(p), end_(end) {}
  template <class T>
  T get(std::string_view what) {
    need(sizeof(T), what);
    T v;
    std::memcpy(&v, p_, sizeof v);
    p_ += sizeof v;
    return v;
  }
  // A count of records of `bytes` each, refused when the rest of the file cannot hold it.
  std::uint64_t count(std::string_view what, std::size_t bytes) {
    const auto c = get<std::uint64_t>(what);
    if (c > static_cast<std::uint64_t>(end_ - p_) / bytes)
      fail(std::string(what) + " " + std::to_string(c) +
           " is more than the rest of the file can hold (truncated or "
           "corrupt file?)");
    return c;
  }
  void skip(std::uint64_t bytes, std::string_view what) {
    need(bytes, what);
    p_ += bytes;
  }
  const char* position() const { return p_; }
  [[noreturn]] void fail(const std::string& message) const {
    throw FormatError("byte " + std::to_string(p_ - begin_) + ": " + message);
  }

 private:
  void need(std::uint64_t bytes, std::string_view what) const {
    if (static_cast<std::uint64_t>(end_ - p_) < bytes)
      fail("unexpected end of file where " + std::string(what) + " was expected (truncated file?)");
  }
  const char* begin_;
  const char* p_;
  const char* end_;
};

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
    if (type != "0" && type != "1") in_.fail("file type " + shown(type) + " is neither 0 (ascii) nor 1 (binary)");
    binary_ = type == "1";
    const auto data_size = in_.integer<std::uint64_t>("the data size");
    if (binary_) {
      if (data_size != 8)
        in_.fail("binary data size " + std::to_string(data_size) + ": only 8-byte size_t is supported");
      // The int 1 follows the line end, in the writer's byte order.
      const char* p = in_.position();
      if (p != in_.end() && *p == '\r') ++p;
      if (p == in_.end() || *p != '\n') in_.fail("no line end before the binary byte-order int");
      Bytes b = bytes(p + 1);
      const auto one = b.get<int32_t>("the byte-order int");
      if (one != 1) b.fail("the byte-order int is not 1: a big-endian or corrupt binary file");
      in_.set_position(b.position());
    }
    in_.expect("$EndMeshFormat");
  }

  Bytes bytes(const char* from) const { return Bytes(in_.file_begin(), from, in_.end()); }
  // Binary data starts after the line end that ends the section header.
  Bytes section_bytes() {
    const char* p = in_.position();
    if (p != in_.end() && *p == '\r') ++p;
    if (p == in_.end() || *p != '\n') in_.fail("no line end after the section header");
    return bytes(p + 1);
  }

  void read_entities_binary() {
    Bytes b = section_bytes();
    std::array<std::uint64_t, 4> counts{};
    for (int d = 0; d < 4; ++d) counts[d] = b.count("an entity count", d == 0 ? 36 : 68);
    for (int d = 0; d < 4; ++d) {
      for (std::uint64_t i = 0; i < counts[d]; ++i) {
        const auto tag = b.get<int32_t>("an entity tag");
        b.skip(d == 0 ? 24 : 48, "an entity box");
        const std::uint64_t physicals = b.count("a physical tag count", 4);
        for (std::uint64_t k = 0; k < physicals; ++k) {
          const auto physical = b.get<int32_t>("a physical tag");
          if (k == 0 && d == 3) volume_physical_[tag] = physical;
        }
        if (d > 0) b.skip(4 * b.count("a bounding entity count", 4), "bounding entity tags");
      }
    }
    in_.set_position(b.position());
    in_.expect("$EndEntities");
  }

  void read_nodes_binary() {
    Bytes b = section_bytes();
    const std::uint64_t blocks = b.count("the node block count", 20);
    const std::uint64_t total = b.count("the node count", 32);
    if (total > kMaxPoints) b.fail(std::to_string(total) + " nodes are more than 32-bit indices can address");
    b.skip(16, "the node tag range");
    std::vector<std::uint64_t> tags;
    tags.reserve(total);
    mesh_.points.reserve(total);
    for (std::uint64_t k = 0; k < blocks; ++k) {
      const auto dim = b.get<int32_t>("an entity dimension");
      b.get<int32_t>("an entity tag");
      const auto parametric = b.get<int32_t>("the parametric flag");
      if (dim < 0 || dim > 3) b.fail("entity dimension " + std::to_string(dim) + " is not 0..3");
      if (parametric != 0 && parametric != 1)
        b.fail("parametric flag " + std::to_string(parametric) + " is not 0 or 1");
      const std::size_t per = 8 * (3 + (parametric != 0 ? static_cast<std::size_t>(dim) : 0));
      const std::uint64_t n = b.count("a node block size", 8 + per);
      if (n > total - tags.size())
        b.fail("the node blocks hold more than the " + std::to_string(total) + " nodes announced");
      for (std::uint64_t i = 0; i < n; ++i) {
        tags.push_back(b.get<std::uint64_t>("a node tag"));
        if (tags.back() == 0) b.fail("node tag 0 (tags start at 1)");
      }
      for (std::uint64_t i = 0; i < n; ++i) {
        Vec3 p;
        for (int a = 0; a < 3; ++a) p[a] = b.get<double>("a node coordinate");
        if (!is_finite(p)) b.fail("node " + std::to_string(tags[tags.size() - n + i]) + " has a non-finite coordinate");
        b.skip(per - 24, "parametric coordinates");
        mesh_.points.push_back(p);
      }
    }
    if (tags.size() != total)
      b.fail("the node blocks hold " + std::to_string(tags.size()) + " nodes, not the " + std::to_string(total) +
             " announced");
    in_.set_position(b.position());
    in_.expect("$EndNodes");
    number_nodes(std::move(tags));
  }

  void read_elements_binary() {
    Bytes b = section_bytes();
    const std::uint64_t blocks = b.count("the element block count", 20);
    const std::uint64_t total = b.count("the element count", 16);
    b.skip(16, "the element tag range");
    std::vector<std::uint64_t> tags;
    tags.reserve(total);
    std::uint64_t seen = 0;
    for (std::uint64_t k = 0; k < blocks; ++k) {
      const auto dim = b.get<int32_t>("an entity dimension");
      const auto entity = b.get<int32_t>("an entity tag");
      const auto type = b.get<int32_t>("an element type");
      const std::size_t nodes = gmsh_nodes_per_element(type);
      if (nodes == 0) b.fail("element type " + std::to_string(type) + " is not known to this reader");
      const std::uint64_t n = b.count("an element block size", 8 * (1 + nodes));
      if (n > total - seen)
        b.fail("the element blocks hold more than the " + std::to_string(total) + " elements announced");
      seen += n;
      if (dim < 0 || dim > 3) b.fail("entity dimension " + std::to_string(dim) + " is not 0..3");
      if (dim < 3) {
        b.skip(n * 8 * (1 + nodes), "an element");
        continue;
      }
      constexpr int32_t kHexahedron8 = 5;
      if (type != kHexahedron8)
        b.fail("volume entity " + std::to_string(entity) + " holds elements of type " + std::to_string(type) +
               ": only 8-node hexahedra (type 5) can be read");
      const auto physical = volume_physical_.find(entity);
      const int32_t region = physical != volume_physical_.end() ? physical->second : entity;
      for (std::uint64_t i = 0; i < n; ++i) {
        tags.push_back(b.get<std::uint64_t>("an element tag"));
        Hex hex;
        for (uint32_t& v : hex) {
          const auto tag = b.get<std::uint64_t>("a node tag");
          const std::optional<uint32_t> index = nodes_.index(tag);
          if (!index)
            b.fail("element " + std::to_string(tags.back()) + " uses node " + std::to_string(tag) +
                   ", which $Nodes does not define");
          v = *index;
        }
        mesh_.hexes.push_back(hex);
        mesh_.region.push_back(region);
      }
    }
    if (seen != total)
      b.fail("the element blocks hold " + std::to_string(seen) + " elements, not the " + std::to_string(total) +
             " announced");
    in_.set_position(b.position());
    in_.expect("$EndElements");
    order_elements(tags);
  }

  void number_nodes(std::vector<std::uint64_t> tags) {
    const std::vector<std::size_t> order = tag_order(tags, "node");
    if (!order.empty()) {
      permute(tags, order);
      permute(mesh_.points, order);
    }
    nodes_ = NodeNumbering(std::move(tags));
  }

  void order_elements(const std::vector<std::uint64_t>& tags) {
    const std::vector<std::size_t> order = tag_order(tags, "element");
    if (!order.empty()) {
      permute(mesh_.hexes, order);
      permute(mesh_.region, order);
    }
  }

  void read_entities() {
    if (binary_) return read_entities_binary();
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
    if (binary_) return read_nodes_binary();
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
      if (parametric != 0 && parametric != 1)
        in_.fail("parametric flag " + std::to_string(parametric) + " is not 0 or 1");
      const std::uint64_t k = in_.count("node", 4);
      if (k > total - tags.size())
        in_.fail("the node blocks hold more than the " + std::to_string(total) + " nodes announced");
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
    number_nodes(std::move(tags));
  }

  void read_elements() {
    if (!have_nodes_) in_.fail("$Elements before $Nodes");
    if (have_elements_) in_.fail("a second $Elements section");
    have_elements_ = true;
    if (binary_) return read_elements_binary();
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
      if (k > total - seen)
        in_.fail("the element blocks hold more than the " + std::to_string(total) + " elements announced");
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
          if (!index)
            in_.fail("element " + std::to_string(tags.back()) + " uses node " + std::to_string(tag) +
                     ", which $Nodes does not define");
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
    order_elements(tags);
  }

  Scanner in_;
  HexMesh mesh_;
  NodeNumbering nodes_;
  std::map<std::int64_t, int32_t> volume_physical_;
  bool have_format_ = false;
  bool have_nodes_ = false;
  bool have_elements_ = false;
  bool binary_ = false;
};

}  // namespace

void write_gmsh(const HexMesh& mesh, AtomicFile& out, bool binary) {
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

  std::string s = binary ? "$MeshFormat\n4.1 1 8\n" : "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n";
  if (binary) {
    put_binary<int32_t>(s, 1);  // tells the reader the byte order
    s += "\n$EndMeshFormat\n";
  }
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
  const std::size_t n = mesh.points.size();
  const std::size_t m = mesh.hexes.size();
  // The first run at or before hex `begin`, for a chunk of element records.
  auto run_at = [&](std::size_t begin) {
    return static_cast<std::size_t>(
        std::upper_bound(runs.begin(), runs.end(), begin, [](std::size_t h, const Run& run) { return h < run.begin; }) -
        runs.begin() - 1);
  };
  if (binary) {
    s += "$Entities\n";
    for (const std::uint64_t c : {std::uint64_t{0}, std::uint64_t{0}, std::uint64_t{0}, std::uint64_t{boxes.size()}})
      put_binary(s, c);
    for (std::size_t k = 0; k < boxes.size(); ++k) {
      put_binary<int32_t>(s, static_cast<int32_t>(bare_nodes ? int64_t{1} : entity_of(values[k])));
      for (const Vec3& corner : {boxes[k].lo, boxes[k].hi})
        for (int a = 0; a < 3; ++a) put_binary(s, corner[a]);
      put_binary<std::uint64_t>(s, bare_nodes ? 0 : 1);
      if (!bare_nodes) put_binary<int32_t>(s, values[k]);
      put_binary<std::uint64_t>(s, 0);  // no bounding surfaces
    }
    s += "\n$EndEntities\n$Nodes\n";
    const std::uint64_t any_node = n == 0 ? 0 : 1;
    for (const std::uint64_t c : {any_node, std::uint64_t{n}, any_node, std::uint64_t{n}}) put_binary(s, c);
    if (n != 0) {
      put_binary<int32_t>(s, 3);
      put_binary<int32_t>(s, static_cast<int32_t>(bare_nodes ? int64_t{1} : entity_of(values.front())));
      put_binary<int32_t>(s, 0);
      put_binary<std::uint64_t>(s, n);
    }
    out.write(s);
    write_records(out, n, 8, [](std::size_t begin, std::size_t end, char* p) {
      for (std::size_t i = begin; i < end; ++i, p += 8) {
        const std::uint64_t tag = i + 1;
        std::memcpy(p, &tag, 8);
      }
      return p;
    });
    out.write(mesh.points.data(), n * sizeof(Vec3));
    s = "\n$EndNodes\n$Elements\n";
    const std::uint64_t any_hex = m == 0 ? 0 : 1;
    for (const std::uint64_t c : {std::uint64_t{runs.size()}, std::uint64_t{m}, any_hex, std::uint64_t{m}})
      put_binary(s, c);
    out.write(s);
    // A record: the element tag and 8 node tags; a block's first record has its 20-byte header.
    write_records(out, m, 20 + 72, [&](std::size_t begin, std::size_t end, char* p) {
      std::size_t r = run_at(begin);
      for (std::size_t h = begin; h < end; ++h) {
        if (h == runs[r].end) ++r;
        if (h == runs[r].begin) {
          const int32_t header[3] = {3, static_cast<int32_t>(entity_of(runs[r].region)), 5};
          const std::uint64_t size = runs[r].end - runs[r].begin;
          std::memcpy(p, header, 12);
          std::memcpy(p + 12, &size, 8);
          p += 20;
        }
        std::uint64_t record[9];
        record[0] = h + 1;
        for (int c = 0; c < 8; ++c) record[c + 1] = std::uint64_t{mesh.hexes[h][c]} + 1;
        std::memcpy(p, record, sizeof record);
        p += sizeof record;
      }
      return p;
    });
    out.write("\n$EndElements\n");
    return;
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
  const std::size_t any_node = n == 0 ? 0 : 1;
  put_line(s, {any_node, n, any_node, n});
  if (n != 0)
    put_line<int64_t>(s, {3, bare_nodes ? int64_t{1} : entity_of(values.front()), 0, static_cast<int64_t>(n)});
  out.write(s);
  write_records(out, n, 21, [](std::size_t begin, std::size_t end, char* p) {
    for (std::size_t i = begin; i < end; ++i) {
      p = put_decimal(p, i + 1);
      *p++ = '\n';
    }
    return p;
  });
  write_points_text(out, mesh.points, "\n");

  s = "$EndNodes\n$Elements\n";
  put_line(s, {runs.size(), m, m == 0 ? std::size_t{0} : std::size_t{1}, m});
  out.write(s);
  // A record: 9 tags (at most 20 digits); a block's first record has its header line too.
  write_records(out, m, 38 + 9 * 21, [&](std::size_t begin, std::size_t end, char* p) {
    std::size_t r = run_at(begin);
    for (std::size_t h = begin; h < end; ++h) {
      if (h == runs[r].end) ++r;
      if (h == runs[r].begin) {
        std::memcpy(p, "3 ", 2);
        p = put_decimal(p + 2, entity_of(runs[r].region));
        std::memcpy(p, " 5 ", 3);
        p = put_decimal(p + 3, runs[r].end - runs[r].begin);
        *p++ = '\n';
      }
      p = put_decimal(p, h + 1);
      for (const uint32_t v : mesh.hexes[h]) {
        *p++ = ' ';
        p = put_decimal(p, std::uint64_t{v} + 1);
      }
      *p++ = '\n';
    }
    return p;
  });
  out.write("$EndElements\n");
}

HexMesh read_gmsh(std::string_view text) { return GmshReader(text).read(); }

}  // namespace mchex::io_detail
