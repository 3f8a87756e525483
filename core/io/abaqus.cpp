// Abaqus / CalculiX input deck .inp, the mesh part; mesh_io.h states the contract.
//
// Written: a *HEADING, one *NODE block (node n is point n - 1), one *ELEMENT, TYPE=C3D8 block
// (element e is hex e - 1, so that the hex order survives every reader) and an *ELSET REGIONr
// (REGION_Mr for a negative r) per region value. C3D8's corner order is VTK_HEXAHEDRON's
// (docs/formats.md). CalculiX reads each field from its first 20 characters (an integer from its
// first 10) and a line of at most 132, so every coordinate is written in at most 20 characters:
// the shortest exact form when it fits (almost every coordinate a mesher makes), else the closest
// value of 13 to 16 significant digits that fits (a relative change below 5e-13; only exponents of
// three digits with a sign need it).
// Read: keywords case-insensitive, "**" comments, data lines comma-separated (a trailing comma
// continues an element on the next line); *NODE, *ELEMENT of 8-node bricks (C3D8, C3D8R,
// C3D8I, ...), *ELSET, ELSET=REGIONr [, GENERATE] and ELSET=REGIONr on *ELEMENT give region r
// (0 for a hex in no such set); elements that are not solids (shells, beams) are skipped, other
// solids are an error; any other keyword is skipped with its data lines. Nodes and hexes are put
// in ascending id order.
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numeric>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "core/io/format_error.h"
#include "core/io/mesh_formats.h"
#include "core/io/record_writer.h"
#include "core/io/region_groups.h"
#include "core/io/text_numbers.h"

namespace mchex::io_detail {
namespace {

constexpr std::size_t kField = 20;  // CalculiX reads a real from the first 20 characters of its field

std::string upper(std::string_view s) {
  std::string u(s);
  for (char& c : u) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return u;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_blank(s.back())) s.remove_suffix(1);
  return s;
}

std::string elset_name(int32_t region) {
  return region < 0 ? "REGION_M" + std::to_string(-std::int64_t{region}) : "REGION" + std::to_string(region);
}

// The region an ELSET name stands for, or false when it is none of ours.
bool region_of_elset(std::string_view name, int32_t& region) {
  std::string u = upper(trim(name));
  if (u.rfind("REGION", 0) != 0) return false;
  std::string_view digits = std::string_view(u).substr(6);
  const bool negative = digits.rfind("_M", 0) == 0;
  if (negative) digits.remove_prefix(2);
  std::int64_t v = 0;
  if (digits.empty() || !parse_int(digits, v) || digits[0] == '+' || digits[0] == '-') return false;
  if (negative) v = -v;
  if (v < std::numeric_limits<int32_t>::min() || v > std::numeric_limits<int32_t>::max()) return false;
  region = static_cast<int32_t>(v);
  return true;
}

// A coordinate in at most kField characters (see the file comment).
char* put_coordinate(char* p, double v) {
  char* const end = put_real(p, v);
  if (static_cast<std::size_t>(end - p) <= kField) return end;
  char buf[32];
  std::to_chars_result r{buf + sizeof buf, std::errc()};
  for (int digits = 16; static_cast<std::size_t>(r.ptr - buf) > kField && digits > 0; --digits) {
    r = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, digits);
    double back = 0;
    // Rounding up the largest doubles would overflow: take fewer digits then.
    if (static_cast<std::size_t>(r.ptr - buf) <= kField &&
        parse_real({buf, static_cast<std::size_t>(r.ptr - buf)}, back) != RealParse::kOk)
      r.ptr = buf + sizeof buf;
  }
  std::memcpy(p, buf, static_cast<std::size_t>(r.ptr - buf));
  return p + (r.ptr - buf);
}

class AbaqusReader {
 public:
  explicit AbaqusReader(std::string_view text) : text_(text) {}

  HexMesh read() {
    std::string_view line;
    bool have_line = next_line(line);
    while (have_line) {
      if (line.empty() || line[0] != '*') fail("expected a keyword line starting with '*'");
      const std::vector<std::string_view> parts = split(line.substr(1));
      const std::string keyword = upper(trim(parts[0]));
      if (keyword == "NODE") {
        have_line = read_nodes(line);
      } else if (keyword == "ELEMENT") {
        have_line = read_elements(parts, line);
      } else if (keyword == "ELSET") {
        have_line = read_elset(parts, line);
      } else {
        have_line = skip_data(line);
      }
    }
    return finish();
  }

 private:
  [[noreturn]] void fail(const std::string& message) const {
    throw FormatError("line " + std::to_string(line_number_) + ": " + message);
  }

  // The next line that is not blank and not a "**" comment, without its line end.
  bool next_line(std::string_view& line) {
    while (pos_ < text_.size()) {
      const std::size_t end = std::min(text_.find('\n', pos_), text_.size());
      line = trim(text_.substr(pos_, end - pos_));
      pos_ = end + 1;
      ++line_number_;
      if (line.empty() || line.starts_with("**")) continue;
      return true;
    }
    return false;
  }

  static std::vector<std::string_view> split(std::string_view line) {
    std::vector<std::string_view> parts;
    for (;;) {
      const std::size_t comma = line.find(',');
      parts.push_back(trim(line.substr(0, comma)));
      if (comma == std::string_view::npos) return parts;
      line.remove_prefix(comma + 1);
    }
  }

  std::string parameter(const std::vector<std::string_view>& parts, std::string_view name) const {
    for (std::size_t i = 1; i < parts.size(); ++i) {
      const std::size_t eq = parts[i].find('=');
      if (eq != std::string_view::npos && upper(trim(parts[i].substr(0, eq))) == name)
        return std::string(trim(parts[i].substr(eq + 1)));
    }
    return {};
  }

  template <class Int>
  Int integer(std::string_view field, std::string_view what) const {
    Int v{};
    if (!parse_int(field, v)) fail("expected " + std::string(what) + " (an integer), found '" + shown(field) + "'");
    return v;
  }

  double real(std::string_view field) const {
    double v = 0;
    switch (parse_real(field, v)) {
      case RealParse::kOk: return v;
      case RealParse::kNotFinite: fail("coordinate '" + shown(field) + "' is not a finite number");
      case RealParse::kMalformed: break;
    }
    fail("expected a coordinate (a number), found '" + shown(field) + "'");
  }

  bool read_nodes(std::string_view& line) {
    while (next_line(line)) {
      if (line[0] == '*') return true;
      const std::vector<std::string_view> f = split(line);
      if (f.size() < 2 || f.size() > 4) fail("a *NODE line holds a node number and 1 to 3 coordinates");
      node_ids_.push_back(integer<std::int64_t>(f[0], "a node number"));
      Vec3 p{0, 0, 0};
      for (std::size_t a = 1; a < f.size(); ++a) p[static_cast<int>(a - 1)] = real(f[a]);
      points_.push_back(p);
      if (points_.size() > kMaxPoints) fail("more nodes than 32-bit indices can address");
    }
    return false;
  }

  bool read_elements(const std::vector<std::string_view>& parts, std::string_view& line) {
    const std::string type = upper(parameter(parts, "TYPE"));
    if (type.empty()) fail("*ELEMENT without TYPE=");
    const bool brick = type.rfind("C3D8", 0) == 0 && (type.size() == 4 || !std::isdigit(type[4]));
    const bool other_solid = !brick && type.rfind("C3D", 0) == 0;
    if (other_solid) fail("elements of type " + shown(type) + ": only 8-node hexahedra (C3D8) can be read");
    int32_t set_region = 0;
    const std::string elset = parameter(parts, "ELSET");
    const bool in_region = region_of_elset(elset, set_region);
    std::vector<std::int64_t> values;
    while (next_line(line)) {
      if (line[0] == '*') {
        if (!values.empty()) fail("an element line ends with ',' but no data line follows");
        return true;
      }
      if (!brick) continue;  // shells, beams, springs: not part of the hex mesh
      const bool continued = line.back() == ',';
      for (const std::string_view f : split(continued ? line.substr(0, line.size() - 1) : line))
        values.push_back(integer<std::int64_t>(f, "an element or node number"));
      if (continued && values.size() < 9) continue;
      if (values.size() != 9) fail("a C3D8 element needs its number and 8 node numbers");
      element_ids_.push_back(values[0]);
      hex_nodes_.insert(hex_nodes_.end(), values.begin() + 1, values.end());
      element_region_.push_back(in_region ? set_region : 0);
      values.clear();
    }
    if (!values.empty()) fail("the file ends inside an element");
    return false;
  }

  bool read_elset(const std::vector<std::string_view>& parts, std::string_view& line) {
    int32_t region = 0;
    const bool ours = region_of_elset(parameter(parts, "ELSET"), region);
    bool generate = false;
    for (std::size_t i = 1; i < parts.size(); ++i) generate = generate || upper(parts[i]) == "GENERATE";
    while (next_line(line)) {
      if (line[0] == '*') return true;
      if (!ours) continue;
      std::string_view data = line;
      if (data.back() == ',') data.remove_suffix(1);
      const std::vector<std::string_view> f = split(data);
      if (generate) {
        if (f.size() < 2 || f.size() > 3) fail("a GENERATE line holds first, last[, step]");
        const auto first = integer<std::int64_t>(f[0], "an element number");
        const auto last = integer<std::int64_t>(f[1], "an element number");
        const auto step = f.size() == 3 ? integer<std::int64_t>(f[2], "a step") : 1;
        if (step <= 0 || last < first) fail("a GENERATE range needs first <= last and a positive step");
        // Bounded by the elements a file of this size can hold, so a corrupt range cannot hang.
        if ((last - first) / step > static_cast<std::int64_t>(text_.size()))
          fail("a GENERATE range longer than the file has elements");
        for (std::int64_t e = first; e <= last; e += step) set_regions_.push_back({e, region});
      } else {
        for (const std::string_view field : f)
          set_regions_.push_back({integer<std::int64_t>(field, "an element number"), region});
      }
    }
    return false;
  }

  bool skip_data(std::string_view& line) {
    while (next_line(line))
      if (line[0] == '*') return true;
    return false;
  }

  // Sorts by id; fails on a repeated id.
  std::vector<std::size_t> id_order(const std::vector<std::int64_t>& ids, std::string_view what) const {
    std::vector<std::size_t> order(ids.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    if (!std::is_sorted(ids.begin(), ids.end()))
      std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return ids[a] < ids[b]; });
    for (std::size_t i = 1; i < order.size(); ++i)
      if (ids[order[i]] == ids[order[i - 1]])
        throw FormatError(std::string(what) + " number " + std::to_string(ids[order[i]]) + " is defined twice");
    return order;
  }

  HexMesh finish() {
    HexMesh mesh;
    const std::vector<std::size_t> node_order = id_order(node_ids_, "node");
    mesh.points.resize(points_.size());
    std::unordered_map<std::int64_t, uint32_t> index;
    const bool identity = std::is_sorted(node_ids_.begin(), node_ids_.end()) &&
                          (node_ids_.empty() ||
                           (node_ids_.front() == 1 && node_ids_.back() == static_cast<std::int64_t>(node_ids_.size())));
    for (std::size_t i = 0; i < node_order.size(); ++i) {
      mesh.points[i] = points_[node_order[i]];
      if (!identity) index[node_ids_[node_order[i]]] = static_cast<uint32_t>(i);
    }
    const std::vector<std::size_t> order = id_order(element_ids_, "element");
    std::unordered_map<std::int64_t, std::size_t> element_index;
    if (!set_regions_.empty())
      for (std::size_t i = 0; i < order.size(); ++i) element_index[element_ids_[order[i]]] = i;
    mesh.hexes.resize(order.size());
    mesh.region.resize(order.size());
    for (std::size_t i = 0; i < order.size(); ++i) {
      const std::size_t e = order[i];
      for (int c = 0; c < 8; ++c) {
        const std::int64_t node = hex_nodes_[8 * e + c];
        if (identity) {
          if (node < 1 || node > static_cast<std::int64_t>(points_.size()))
            throw FormatError("element " + std::to_string(element_ids_[e]) + " uses node " + std::to_string(node) +
                              ", which *NODE does not define");
          mesh.hexes[i][c] = static_cast<uint32_t>(node - 1);
        } else {
          const auto it = index.find(node);
          if (it == index.end())
            throw FormatError("element " + std::to_string(element_ids_[e]) + " uses node " + std::to_string(node) +
                              ", which *NODE does not define");
          mesh.hexes[i][c] = it->second;
        }
      }
      mesh.region[i] = element_region_[e];
    }
    for (const auto& [element, region] : set_regions_) {
      const auto it = element_index.find(element);
      if (it == element_index.end())
        throw FormatError("set " + elset_name(region) + " names element " + std::to_string(element) +
                          ", which is no C3D8 element of the file");
      mesh.region[it->second] = region;
    }
    return mesh;
  }

  struct SetRegion {
    std::int64_t element;
    int32_t region;
  };

  std::string_view text_;
  std::size_t pos_ = 0;
  std::size_t line_number_ = 0;
  std::vector<std::int64_t> node_ids_;
  std::vector<Vec3> points_;
  std::vector<std::int64_t> element_ids_;
  std::vector<std::int64_t> hex_nodes_;
  std::vector<int32_t> element_region_;
  std::vector<SetRegion> set_regions_;
};

}  // namespace

namespace {

// A hex number in an element set and its separator.
constexpr std::size_t kElsetNumberBytes = 21;

// The element sets of a mesh with more region values than region_groups lists: the hexes sorted
// by (region, hex), which is unique, so the order is the same on every library.
void write_elsets_sorted(const HexMesh& mesh, AtomicFile& out) {
  std::vector<std::size_t> order(mesh.hexes.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  parallel_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return mesh.region[a] != mesh.region[b] ? mesh.region[a] < mesh.region[b] : a < b;
  });
  std::string text;
  for (std::size_t g = 0; g < order.size();) {
    std::size_t e = g + 1;
    while (e < order.size() && mesh.region[order[e]] == mesh.region[order[g]]) ++e;
    text += "*ELSET, ELSET=" + elset_name(mesh.region[order[g]]);
    if (order[e - 1] - order[g] == e - 1 - g) {
      text += ", GENERATE\n" + std::to_string(order[g] + 1) + "," + std::to_string(order[e - 1] + 1) + ",1\n";
    } else {
      text += '\n';
      for (std::size_t k = g; k < e; ++k) {
        put_number(text, order[k] + 1);
        text += (k + 1 - g) % 10 == 0 || k + 1 == e ? '\n' : ',';
      }
    }
    if (text.size() > (std::size_t{1} << 20)) {
      out.write(text);
      text.clear();
    }
    g = e;
  }
  out.write(text);
}

}  // namespace

void write_abaqus(const HexMesh& mesh, AtomicFile& out) {
  std::string s = "*HEADING\nmchex-gpu all-hex mesh: C3D8 elements, one ELSET per region\n";
  if (!mesh.points.empty()) s += "*NODE\n";
  out.write(s);
  // A node: its number (at most 10 digits) and three fields of at most kField characters.
  write_records(out, mesh.points.size(), 11 + 3 * (kField + 1), [&](std::size_t begin, std::size_t end, char* p) {
    for (std::size_t i = begin; i < end; ++i) {
      p = put_decimal(p, i + 1);
      for (int a = 0; a < 3; ++a) {
        *p++ = ',';
        p = put_coordinate(p, mesh.points[i][a]);
      }
      *p++ = '\n';
    }
    return p;
  });
  // One *ELEMENT block of every hex in order, then one *ELSET per region: a GENERATE range when
  // its hexes are consecutive, else their numbers, 10 to a line (a 132-character line holds 10
  // of CalculiX's 10-digit integers; meshio reads one GENERATE line and whole lists).
  if (mesh.hexes.empty()) return;
  out.write("*ELEMENT, TYPE=C3D8\n");
  write_records(out, mesh.hexes.size(), 9 * 21, [&](std::size_t begin, std::size_t end, char* p) {
    for (std::size_t k = begin; k < end; ++k) {
      p = put_decimal(p, k + 1);
      for (const uint32_t v : mesh.hexes[k]) {
        *p++ = ',';
        p = put_decimal(p, std::uint64_t{v} + 1);
      }
      *p++ = '\n';
    }
    return p;
  });
  const RegionGroups regions = region_groups(mesh.region);
  if (regions.many) {
    write_elsets_sorted(mesh, out);
    return;
  }
  for (const RegionGroup& g : regions.groups) {
    std::string head = "*ELSET, ELSET=" + elset_name(g.region);
    if (g.last - g.first + 1 == g.count) {
      out.write(head + ", GENERATE\n" + std::to_string(g.first + 1) + "," + std::to_string(g.last + 1) + ",1\n");
      continue;
    }
    out.write(head + "\n");
    // The group's hexes are numbered in hex order; chunk c starts at the group's before[c]-th.
    const std::size_t span = g.last - g.first + 1;
    const std::size_t per_chunk = records_per_chunk(kElsetNumberBytes);
    std::vector<std::size_t> before((span + per_chunk - 1) / per_chunk + 1, 0);
    parallel_for(before.size() - 1, [&](std::size_t c) {
      const std::size_t b = g.first + c * per_chunk, e = std::min(g.last + 1, b + per_chunk);
      before[c + 1] = static_cast<std::size_t>(std::count(mesh.region.begin() + b, mesh.region.begin() + e, g.region));
    });
    std::partial_sum(before.begin(), before.end(), before.begin());
    write_records(out, span, kElsetNumberBytes, [&](std::size_t begin, std::size_t end, char* p) {
      std::size_t k = before[begin / per_chunk];
      for (std::size_t h = g.first + begin; h < g.first + end; ++h) {
        if (mesh.region[h] != g.region) continue;
        p = put_decimal(p, h + 1);
        ++k;
        *p++ = k % 10 == 0 || k == g.count ? '\n' : ',';
      }
      return p;
    });
  }
}

HexMesh read_abaqus(std::string_view text) { return AbaqusReader(text).read(); }

}  // namespace mchex::io_detail
