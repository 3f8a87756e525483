// Exodus II .exo through libexodusii (netCDF underneath); mesh_io.h states the contract.
//
// Written (exodus_writer.cpp): the coordinates in double precision, one element block of type HEX8
// per region value (ascending, block id = the region when all regions are positive, else 1..k;
// every block named "region_R" so that the region itself survives either way), the element number
// map giving each element its hex number (1-based, HexMesh order) so that a reader restores the
// hex order, a node set "boundary" of every node on a face that only one hex has (the boundary of
// the whole mesh), and per pair of regions a < b that share faces a side set "interface_a_b" of
// those faces, each as (element of region a, its Exodus side number). HEX8's node order is
// VTK_HEXAHEDRON's; its side numbering is the Exodus II manual's (docs/formats.md). 32-bit
// integers in the file (the classic netCDF model every Exodus reader takes) and at most 2^32 - 4
// bytes per variable (CDF-2), so a mesh over 536870911 points, 357913941 hexes (six faces each
// numbered in 32 bits) or 134217727 hexes in one region is refused.
// Read: every element block of a HEX type with 8 nodes per element (blocks of 2D or 1D elements
// skipped, other 3D elements an error), the region from the block name "region_R" else the block
// id, the hexes put in the order of the element number map when it is a permutation of 1..m.
// A netCDF classic file (what libexodusii writes) is read here through netcdf_classic.h, every
// size checked against the file, because the netCDF library crashes on corrupted headers; a
// netCDF-4 (HDF5) file from another tool is read by libexodusii.
#include <exodusII.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "core/io/exodus_library.h"
#include "core/io/format_error.h"
#include "core/io/mesh_formats.h"
#include "core/io/netcdf_classic.h"
#include "core/io/text_numbers.h"

namespace mchex::io_detail {
namespace {

using exodus_library::check;
using exodus_library::Database;
using exodus_library::message;

constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();  // no element yet

// What the two readers below take from a file, checked and assembled by assemble().
struct Block {
  std::int64_t id = 0;
  std::string name, type;
  std::int64_t nodes_per_element = 0;
  std::vector<std::int64_t> connectivity;  // 1-based node numbers
};
struct Content {
  std::vector<Vec3> points;
  std::vector<Block> blocks;
  std::vector<std::int64_t> numbers;  // the element number map, empty when the file has none
  std::uint64_t elements = 0;         // the header's element count
};

HexMesh assemble(Content&& c) {
  HexMesh mesh;
  mesh.points = std::move(c.points);
  for (std::size_t i = 0; i < mesh.points.size(); ++i)
    if (!is_finite(mesh.points[i])) throw FormatError("node " + std::to_string(i + 1) + " has a non-finite coordinate");
  std::uint64_t seen = 0;
  bool skipped = false;
  for (const Block& b : c.blocks) {
    std::string type = b.type;
    for (char& ch : type) ch = static_cast<char>(ch >= 'a' && ch <= 'z' ? ch - 'a' + 'A' : ch);
    const std::uint64_t count =
        b.nodes_per_element > 0 ? b.connectivity.size() / static_cast<std::uint64_t>(b.nodes_per_element) : 0;
    seen += count;
    if (seen > c.elements)
      throw FormatError("the element blocks hold more elements than the header's " + std::to_string(c.elements));
    if (count == 0) continue;
    const bool hex = type.rfind("HEX", 0) == 0 && b.nodes_per_element == 8;
    if (!hex) {
      if (type.rfind("HEX", 0) == 0 || type.rfind("TET", 0) == 0 || type.rfind("WEDGE", 0) == 0 ||
          type.rfind("PYRAMID", 0) == 0)
        throw FormatError("element block " + std::to_string(b.id) + " holds " + shown(b.type) + " elements with " +
                          std::to_string(b.nodes_per_element) + " nodes: only 8-node hexahedra can be read");
      skipped = true;  // faces, edges, points: not part of the hex mesh
      continue;
    }
    int32_t region = 0;
    std::int64_t named = 0;
    if (b.name.rfind("region_", 0) == 0 && parse_int(std::string_view(b.name).substr(7), named) &&
        named >= std::numeric_limits<int32_t>::min() && named <= std::numeric_limits<int32_t>::max()) {
      region = static_cast<int32_t>(named);
    } else if (b.id >= std::numeric_limits<int32_t>::min() && b.id <= std::numeric_limits<int32_t>::max()) {
      region = static_cast<int32_t>(b.id);
    } else {
      throw FormatError("element block id " + std::to_string(b.id) + " does not fit a 32-bit region");
    }
    for (std::uint64_t e = 0; e < count; ++e) {
      Hex h;
      for (int k = 0; k < 8; ++k) {
        const std::int64_t v = b.connectivity[8 * e + k];
        if (v < 1 || static_cast<std::uint64_t>(v) > mesh.points.size())
          throw FormatError("element " + std::to_string(mesh.hexes.size() + 1) + " uses node " + std::to_string(v) +
                            ", which the file does not define");
        h[k] = static_cast<uint32_t>(v - 1);
      }
      mesh.hexes.push_back(h);
      mesh.region.push_back(region);
    }
  }
  // The element number map, when it is a permutation of 1..m over hex blocks only, gives the order.
  if (!skipped && !c.numbers.empty() && c.numbers.size() == mesh.hexes.size()) {
    std::vector<std::size_t> slot(c.numbers.size(), kNone);
    bool permutation = true;
    for (std::size_t e = 0; e < c.numbers.size() && permutation; ++e) {
      const std::int64_t k = c.numbers[e];
      permutation = k >= 1 && static_cast<std::uint64_t>(k) <= c.numbers.size() && slot[k - 1] == kNone;
      if (permutation) slot[k - 1] = e;
    }
    if (permutation) {
      std::vector<Hex> hexes(mesh.hexes.size());
      std::vector<int32_t> region(mesh.hexes.size());
      for (std::size_t k = 0; k < slot.size(); ++k) {
        hexes[k] = mesh.hexes[slot[k]];
        region[k] = mesh.region[slot[k]];
      }
      mesh.hexes.swap(hexes);
      mesh.region.swap(region);
    }
  }
  return mesh;
}

// The Exodus II names on netCDF (the Exodus II manual, its appendix on the netCDF implementation):
// dimensions num_dim, num_nodes, num_elem, num_el_blk; variables coordx/coordy/coordz (or coord),
// eb_prop1 (block ids), eb_names, connect<k> with attribute elem_type, elem_num_map.
Content read_classic(std::string_view bytes) {
  const NetcdfClassic nc(bytes);
  Content c;
  const std::uint64_t dim = nc.dimension("num_dim").value_or(0);
  if (dim != 3) throw FormatError("dimension " + std::to_string(dim) + ": only 3D meshes are supported");
  const std::uint64_t nodes = nc.dimension("num_nodes").value_or(0);
  if (nodes > kMaxPoints) throw FormatError(std::to_string(nodes) + " nodes are more than 32-bit indices can address");
  auto expect_shape = [&](std::string_view name, const std::vector<std::uint64_t>& shape) {
    if (nc.shape(name) != shape) throw FormatError("netCDF variable '" + std::string(name) + "' has the wrong shape");
  };
  if (nodes > 0) {
    // The shapes are checked before any allocation: a variable's data lies inside the file.
    if (nc.has_variable("coordx")) {
      const char* names[] = {"coordx", "coordy", "coordz"};
      for (const char* name : names) expect_shape(name, {nodes});
      c.points.resize(nodes);
      for (int a = 0; a < 3; ++a) {
        const std::vector<double> x = nc.reals(names[a]);
        for (std::size_t i = 0; i < nodes; ++i) c.points[i][a] = x[i];
      }
    } else {
      expect_shape("coord", {3, nodes});
      c.points.resize(nodes);
      const std::vector<double> x = nc.reals("coord");
      for (std::size_t i = 0; i < nodes; ++i)
        for (int a = 0; a < 3; ++a) c.points[i][a] = x[a * nodes + i];
    }
  }
  c.elements = nc.dimension("num_elem").value_or(0);
  const std::uint64_t blocks = nc.dimension("num_el_blk").value_or(0);
  if (blocks == 0) return c;
  expect_shape("eb_prop1", {blocks});
  const std::vector<std::int64_t> ids = nc.integers("eb_prop1");
  std::string names;
  std::uint64_t name_length = 0;
  if (nc.has_variable("eb_names")) {
    const std::vector<std::uint64_t> shape = nc.shape("eb_names");
    if (shape.size() != 2 || shape[0] != blocks) throw FormatError("netCDF variable 'eb_names' has the wrong shape");
    name_length = shape[1];
    names = nc.chars("eb_names");
  }
  for (std::uint64_t k = 0; k < blocks; ++k) {
    Block b;
    b.id = ids[k];
    if (name_length > 0) {
      b.name = names.substr(k * name_length, name_length);
      b.name.erase(std::find(b.name.begin(), b.name.end(), '\0'), b.name.end());
    }
    const std::string connect = "connect" + std::to_string(k + 1);
    if (nc.has_variable(connect)) {
      const std::vector<std::uint64_t> shape = nc.shape(connect);
      if (shape.size() != 2) throw FormatError("netCDF variable '" + connect + "' has the wrong shape");
      b.nodes_per_element = static_cast<std::int64_t>(shape[1]);
      b.type = nc.text_attribute(connect, "elem_type");
      b.connectivity = nc.integers(connect);
    }
    c.blocks.push_back(std::move(b));
  }
  if (nc.has_variable("elem_num_map")) {
    expect_shape("elem_num_map", {c.elements});
    c.numbers = nc.integers("elem_num_map");
  }
  return c;
}

// Files in the netCDF-4 (HDF5) layout, as other tools write them: read by libexodusii.
Content read_library(const std::filesystem::path& path) {
  ex_opts(0);
  int comp_ws = 8, io_ws = 0;
  float version = 0;
  const int id = ex_open(path.c_str(), EX_READ, &comp_ws, &io_ws, &version);
  if (id < 0) throw FormatError(message("not an Exodus II file", id));
  Database db(id);
  char title[MAX_LINE_LENGTH + 1] = {};
  int dim = 0, nodes = 0, elements = 0, blocks = 0, node_sets = 0, side_sets = 0;
  check(ex_get_init(id, title, &dim, &nodes, &elements, &blocks, &node_sets, &side_sets), "the Exodus header");
  if (dim != 3) throw FormatError("dimension " + std::to_string(dim) + ": only 3D meshes are supported");
  if (nodes < 0 || elements < 0 || blocks < 0) throw FormatError("negative counts in the Exodus header");
  Content c;
  c.elements = static_cast<std::uint64_t>(elements);
  c.points.resize(static_cast<std::size_t>(nodes));
  if (nodes > 0) {
    std::vector<double> x(c.points.size()), y(x.size()), z(x.size());
    check(ex_get_coord(id, x.data(), y.data(), z.data()), "the coordinates");
    for (std::size_t i = 0; i < x.size(); ++i) c.points[i] = {x[i], y[i], z[i]};
  }
  std::vector<int> ids(static_cast<std::size_t>(blocks));
  if (blocks > 0) check(ex_get_ids(id, EX_ELEM_BLOCK, ids.data()), "the element block ids");
  std::vector<std::vector<char>> name_storage(ids.size(), std::vector<char>(MAX_STR_LENGTH + 1, '\0'));
  std::vector<char*> names;
  for (auto& s : name_storage) names.push_back(s.data());
  if (blocks > 0) check(ex_get_names(id, EX_ELEM_BLOCK, names.data()), "the element block names");
  for (std::size_t b = 0; b < ids.size(); ++b) {
    char type[MAX_STR_LENGTH + 1] = {};
    int count = 0, per = 0, edges = 0, faces = 0, attributes = 0;
    check(ex_get_block(id, EX_ELEM_BLOCK, ids[b], type, &count, &per, &edges, &faces, &attributes),
          "element block " + std::to_string(ids[b]));
    if (count < 0 || per < 0) throw FormatError("element block " + std::to_string(ids[b]) + " has negative counts");
    Block block;
    block.id = ids[b];
    block.name = names[b];
    block.type = type;
    block.nodes_per_element = per;
    std::vector<int> connectivity(static_cast<std::size_t>(count) * static_cast<std::size_t>(per));
    if (!connectivity.empty())
      check(ex_get_conn(id, EX_ELEM_BLOCK, ids[b], connectivity.data(), nullptr, nullptr),
            "the connectivity of block " + std::to_string(ids[b]));
    block.connectivity.assign(connectivity.begin(), connectivity.end());
    c.blocks.push_back(std::move(block));
  }
  if (elements > 0) {
    std::vector<int> numbers(static_cast<std::size_t>(elements));
    check(ex_get_id_map(id, EX_ELEM_MAP, numbers.data()), "the element number map");
    c.numbers.assign(numbers.begin(), numbers.end());
  }
  db.close("closing the Exodus database");
  return c;
}

}  // namespace

HexMesh read_exodus(const std::filesystem::path& path, std::string_view bytes) {
  // What libexodusii writes (and most tools) is netCDF classic, read here; netCDF-4 goes to the
  // library.
  constexpr std::string_view kHdf5 = "\x89HDF\r\n\x1a\n";
  if (bytes.substr(0, kHdf5.size()) == kHdf5) return assemble(read_library(path));
  if (bytes.substr(0, 3) != "CDF") throw FormatError("not an Exodus II file (neither netCDF classic nor netCDF-4)");
  return assemble(read_classic(bytes));
}

}  // namespace mchex::io_detail
