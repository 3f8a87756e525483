// Exodus II .exo written through libexodusii; mesh_io.h and exodus.cpp state the content (element
// blocks per region, the element number map, the "boundary" node set and the "interface_a_b" side
// sets). The file is netCDF classic with 64-bit offsets (CDF-2), which every Exodus reader takes
// and which exodus.cpp reads through its own checked parser.
//
// The cost of a classic netCDF file is its layout: the header, then every fixed-size variable in
// the order it was defined. libexodusii leaves define mode with nc_enddef after each call that
// defines something (ex_put_init, ex_put_block, ex_put_set_param, the first ex_put_*_id_map), and
// nc_enddef keeps no room after the header: each later definition grows the header past the first
// variable, and netCDF then moves every variable defined before it further down the file, 8 KiB
// at a time, whether it was written yet or not. Definition then data, block by block, moved the
// coordinates and connectivity over and over (2.6 s of the 2.99 M-hex bench_formats block). So,
// all through libexodusii's API and netCDF's:
//  - every definition comes first (ex_put_init, ex_put_block per block, ex_put_set_param for the
//    node set and each side set, the element number map), then the data in file order, in calls
//    of 64 Ki values from reused buffers (no array of the whole mesh is copied);
//  - right after ex_put_init the header is given room for every definition to come (nc__enddef's
//    h_minfree, reserve_header below), so that only the coordinates, not yet written, move once;
//  - the faces come from face_matching.h, element numbers from per-chunk region counts.
// Measured on that block (2 cores): 2.6 s before, 1.0 s so; a netCDF-4 (HDF5) file would take 0.6
// s, but is read through HDF5, which does not survive a corrupted file (docs/formats.md).
#include <dlfcn.h>
#include <exodusII.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <numeric>
#include <string>
#include <vector>

#include "core/base/parallel.h"
#include "core/io/exodus_library.h"
#include "core/io/face_matching.h"
#include "core/io/format_error.h"
#include "core/io/mesh_formats.h"
#include "core/io/region_groups.h"
#include "core/mesh/hex_faces.h"

namespace mchex::io_detail {
namespace {

using exodus_library::check;
using exodus_library::Database;

// Exodus II HEX side s (1..6) as the kHexFaces entry with the same four corners: side 1 is
// corners {0,1,5,4}, 2 {1,2,6,5}, 3 {2,3,7,6}, 4 {0,4,7,3}, 5 {0,3,2,1}, 6 {4,5,6,7} (0-based).
constexpr std::array<int, 6> kExodusSide = {4, 2, 1, 3, 5, 6};  // indexed by kHexFaces face

// Entries per libexodusii call when the data is written: 64 Ki coordinates or map entries, 8 Ki
// hexes' connectivity, so that a slice's buffer stays in the core's cache.
constexpr std::size_t kSlice = std::size_t{1} << 16;

// Gives the header of a database `bytes` of room, so that the definitions that follow grow it
// without moving any variable. netCDF keeps room only when asked at the end of a definition
// (nc__enddef), which libexodusii never does, and only once a variable is defined (it places the
// first variable; before ex_put_init the request is ignored); nc_redef and nc__enddef are taken
// from the netCDF library that libexodusii itself calls (Debian's libexodusii links the MPI build
// of netCDF, whose databases another netCDF library linked here would not know). Where they
// cannot be found the file is the same, only slower to write.
void reserve_header(int id, std::size_t bytes) {
  using Redef = int (*)(int);
  using Enddef = int (*)(int, std::size_t, std::size_t, std::size_t, std::size_t);
  static const std::pair<Redef, Enddef> netcdf = []() -> std::pair<Redef, Enddef> {
    Dl_info info{};
    if (dladdr(reinterpret_cast<void*>(&ex_create_int), &info) == 0 || info.dli_fname == nullptr) return {};
    void* exodus = dlopen(info.dli_fname, RTLD_LAZY | RTLD_NOLOAD);
    if (exodus == nullptr) return {};
    // A library's handle searches it and then its dependencies (libexodusii defines neither); the
    // program's would search everything loaded, any netCDF.
    void* program = dlopen(nullptr, RTLD_LAZY);
    auto* redef = reinterpret_cast<Redef>(dlsym(exodus, "nc_redef"));
    auto* enddef = reinterpret_cast<Enddef>(dlsym(exodus, "nc__enddef"));
    const bool library = exodus != program;
    // libexodusii's own nc_* calls bind through the global scope first, then its own
    // dependencies: where the global scope holds another netCDF (a program that linked one), the
    // files live in that one, and these would act on another library's file numbers. So they are
    // used only when the global scope has no netCDF (the Python module, loaded locally) or the same.
    auto same = [](const char* name, void* ours) {
      void* global = dlsym(RTLD_DEFAULT, name);
      return global == nullptr || global == ours;
    };
    const bool one_netcdf =
        same("nc_redef", reinterpret_cast<void*>(redef)) && same("nc__enddef", reinterpret_cast<void*>(enddef));
    dlclose(exodus);
    if (program != nullptr) dlclose(program);
    if (!library || !one_netcdf || redef == nullptr || enddef == nullptr) return {};
    return {redef, enddef};
  }();
  if (netcdf.first == nullptr || netcdf.first(id) != 0) return;
  // The alignments are nc_enddef's own (4 bytes, no room after the fixed-size variables).
  const int status = netcdf.second(id, bytes, 4, 0, 4);
  if (status != 0) throw FormatError("write failed: the Exodus header (netCDF error " + std::to_string(status) + ")");
}

// The region values with their hex counts and spans; past region_groups' list, one pass through a
// map (the blocks are then found through `order`, see write_exodus).
RegionGroups block_regions(const std::vector<int32_t>& region) {
  RegionGroups regions = region_groups(region);
  if (!regions.many) return regions;
  std::map<int32_t, RegionGroup> by_region;
  for (std::size_t h = 0; h < region.size(); ++h) {
    RegionGroup& g = by_region.try_emplace(region[h], RegionGroup{region[h], 0, h, h}).first->second;
    ++g.count;
    g.last = h;
  }
  regions.many = false;
  for (const auto& [value, g] : by_region) regions.groups.push_back(g);
  return regions;
}

// The Exodus element number (1-based, block order) of the hex of each given face: the first
// element of its region's block plus the hexes of that region before it. `faces` ascending. One
// pass over the hexes' labels, in chunks on all threads, each chunk starting from the labels
// counted in the chunks before it. A chunk holds at least k hexes, so the per-chunk counts (chunks
// x k) stay within the hexes' number however many regions there are.
std::vector<int32_t> element_numbers(const HexMesh& mesh, const RegionGroups& regions,
                                     const std::vector<std::uint64_t>& block_start,
                                     const std::vector<std::uint32_t>& faces) {
  const std::size_t m = mesh.hexes.size(), k = regions.groups.size();
  const std::size_t chunk = std::max<std::size_t>(std::size_t{1} << 14, k);
  const std::size_t chunks = (m + chunk - 1) / chunk;
  // Labels come in runs: the group of the previous label is tried first.
  auto group_of = [&](int32_t region, std::size_t& cached) {
    if (regions.groups[cached].region != region) cached = regions.index_of(region);
    return cached;
  };
  std::vector<std::uint64_t> before(chunks * k, 0);  // hexes of each group before each chunk
  parallel_chunks(chunks, 1, [&](std::size_t cb, std::size_t ce) {
    for (std::size_t c = cb; c < ce; ++c) {
      if (c + 1 == chunks) break;  // the last chunk's counts start no chunk
      std::size_t g = 0;
      for (std::size_t h = c * chunk; h < (c + 1) * chunk; ++h) ++before[(c + 1) * k + group_of(mesh.region[h], g)];
    }
  });
  for (std::size_t c = 1; c < chunks; ++c)
    for (std::size_t g = 0; g < k; ++g) before[c * k + g] += before[(c - 1) * k + g];

  std::vector<int32_t> numbers(faces.size());
  parallel_chunks(chunks, 1, [&](std::size_t cb, std::size_t ce) {
    std::vector<std::uint64_t> count(k);
    for (std::size_t c = cb; c < ce; ++c) {
      const std::uint64_t first_face = 6 * c * chunk;
      auto q = static_cast<std::size_t>(std::lower_bound(faces.begin(), faces.end(), first_face) - faces.begin());
      if (q == faces.size() || faces[q] / 6 >= (c + 1) * chunk) continue;
      std::copy(before.begin() + static_cast<std::ptrdiff_t>(c * k),
                before.begin() + static_cast<std::ptrdiff_t>((c + 1) * k), count.begin());
      std::size_t g = 0;
      for (std::size_t h = c * chunk; h < std::min(m, (c + 1) * chunk) && q < faces.size(); ++h) {
        const std::size_t group = group_of(mesh.region[h], g);
        for (; q < faces.size() && faces[q] / 6 == h; ++q)
          numbers[q] = static_cast<int32_t>(block_start[group] + count[group] + 1);
        ++count[group];
      }
    }
  });
  return numbers;
}

}  // namespace

void write_exodus(const HexMesh& mesh, AtomicFile& out) {
  constexpr std::size_t kInt32 = std::numeric_limits<int32_t>::max();
  const std::size_t n = mesh.points.size();
  const std::size_t m = mesh.hexes.size();
  if (n > kInt32 || 6 * m > kInt32)
    throw FormatError("Exodus files of 32-bit integers hold at most 2^31 - 1 points and 357913941 hexes");

  // Blocks: the region values ascending, each block's hexes in hex order. With a handful of values
  // a block's hexes are found by scanning its span of hexes; with more, through `order` (the hexes
  // in block order), so that the scans do not grow with the number of blocks.
  const RegionGroups regions = block_regions(mesh.region);
  const std::size_t k = regions.groups.size();
  const bool ids_are_regions = k == 0 || regions.groups.front().region > 0;
  std::vector<std::uint64_t> block_start(k + 1, 0);
  std::vector<std::string> block_names;
  for (std::size_t g = 0; g < k; ++g) {
    block_start[g + 1] = block_start[g] + regions.groups[g].count;
    block_names.push_back("region_" + std::to_string(regions.groups[g].region));
  }
  // A CDF-2 (64-bit offset) file holds at most 2^32 - 4 bytes in a fixed-size variable: each
  // coordinate array (8 bytes per point) and each block's connectivity (32 bytes per hex). Said
  // here, before the face matching, rather than by libnetcdf when the variable is defined.
  constexpr std::size_t kVariableBytes = (std::size_t{1} << 32) - 4;
  if (8 * n > kVariableBytes)
    throw FormatError("Exodus (netCDF 64-bit offset) files hold at most 536870911 points; this mesh has " +
                      std::to_string(n));
  for (const RegionGroup& g : regions.groups)
    if (32 * g.count > kVariableBytes)
      throw FormatError("Exodus (netCDF 64-bit offset) files hold at most 134217727 hexes per region; region " +
                        std::to_string(g.region) + " has " + std::to_string(g.count));
  std::vector<std::uint32_t> order;
  if (k > kMaxRegionGroups) {
    order.resize(m);
    std::vector<std::uint64_t> fill(block_start.begin(), block_start.end() - 1);
    for (std::size_t h = 0; h < m; ++h) order[fill[regions.index_of(mesh.region[h])]++] = static_cast<std::uint32_t>(h);
  }
  // Calls each(h) for the hexes of block g in hex order.
  auto each_hex_of = [&](std::size_t g, const auto& each) {
    if (!order.empty()) {
      for (std::uint64_t e = block_start[g]; e < block_start[g + 1]; ++e) each(std::size_t{order[e]});
      return;
    }
    const RegionGroup& group = regions.groups[g];
    for (std::size_t h = group.first; h <= group.last; ++h)
      if (mesh.region[h] == group.region) each(h);
  };

  // The boundary node set and the interface side sets.
  const MatchedFaces faces = match_faces(mesh);
  std::vector<std::uint64_t> boundary_bits((n + 63) / 64, 0);
  for (const std::uint32_t f : faces.boundary)
    for (const int c : kHexFaces[f % 6]) {
      const uint32_t v = mesh.hexes[f / 6][c];
      boundary_bits[v / 64] |= std::uint64_t{1} << (v % 64);
    }
  std::uint64_t boundary_nodes = 0;
  for (const std::uint64_t w : boundary_bits) boundary_nodes += static_cast<std::uint64_t>(std::popcount(w));
  std::vector<std::string> side_set_names;
  for (const RegionInterface& i : faces.interfaces)
    side_set_names.push_back("interface_" + std::to_string(i.lower) + "_" + std::to_string(i.upper));
  const std::size_t s = faces.interfaces.size();

  ex_opts(0);  // errors come back as status codes, never printed or fatal
  int comp_ws = 8, io_ws = 8;
  // EX_SHARE (netCDF's NC_SHARE) reads and writes each 8 KiB piece of a variable directly instead
  // of through libnetcdf's two-page buffer: the same file in half the system calls (87 K instead
  // of 182 K on the bench_formats block, 0.94 s instead of 1.03 s).
  const int id = ex_create(out.temporary().c_str(), EX_CLOBBER | EX_LARGE_MODEL | EX_SHARE, &comp_ws, &io_ws);
  if (id < 0) throw FormatError(exodus_library::message("write failed: cannot create the Exodus database", id));
  Database db(id);

  // The definitions.
  const int node_sets = n > 0 ? 1 : 0;
  check(ex_put_init(id, "mchex-gpu all-hex mesh", 3, static_cast<int64_t>(n), static_cast<int64_t>(m),
                    static_cast<int64_t>(k), node_sets, static_cast<int64_t>(s)),
        "write failed: the Exodus header");
  // A block adds 2 dimensions and a variable with an attribute to the header, a side set a
  // dimension and 2 variables: under 200 bytes each with their names (the bench block's header is
  // 2.3 KB with 2 blocks and a side set).
  reserve_header(id, 4096 + 512 * (k + s));
  auto block_id = [&](std::size_t g) {
    return ids_are_regions ? static_cast<int64_t>(regions.groups[g].region) : static_cast<int64_t>(g) + 1;
  };
  for (std::size_t g = 0; g < k; ++g)
    check(
        ex_put_block(id, EX_ELEM_BLOCK, block_id(g), "HEX8", static_cast<int64_t>(regions.groups[g].count), 8, 0, 0, 0),
        "write failed: an element block");
  if (node_sets != 0)
    check(ex_put_set_param(id, EX_NODE_SET, 1, static_cast<int64_t>(boundary_nodes), 0),
          "write failed: the boundary node set");
  for (std::size_t j = 0; j < s; ++j)
    check(ex_put_set_param(id, EX_SIDE_SET, static_cast<int64_t>(j) + 1,
                           static_cast<int64_t>(faces.interfaces[j].faces.size()), 0),
          "write failed: an interface side set");
  // libexodusii defines the number map with its first write: one entry, written again below.
  if (m > 0) {
    // The first hex of the first block (each_hex_of's first).
    int first = static_cast<int>((order.empty() ? regions.groups[0].first : order[0]) + 1);
    check(ex_put_partial_id_map(id, EX_ELEM_MAP, 1, 1, &first), "write failed: the element number map");
  }

  // The data, in file order: the names, the coordinates, each block's connectivity, the sets, the
  // number map.
  auto put_names = [&](ex_entity_type type, std::vector<std::string> names, std::string_view what) {
    std::vector<char*> pointers;
    for (std::string& name : names) pointers.push_back(name.data());
    check(ex_put_names(id, type, pointers.data()), what);
  };
  if (k > 0) put_names(EX_ELEM_BLOCK, block_names, "write failed: the block names");
  if (node_sets != 0) put_names(EX_NODE_SET, {"boundary"}, "write failed: the node set name");
  if (s > 0) put_names(EX_SIDE_SET, side_set_names, "write failed: the side set names");
  if (n > 0) {
    const char* coordinate_names[] = {"x", "y", "z"};
    check(ex_put_coord_names(id, const_cast<char**>(coordinate_names)), "write failed: the coordinate names");
  }

  std::vector<double> coordinates(std::min(n, kSlice));
  for (int a = 0; a < 3; ++a)
    for (std::size_t begin = 0; begin < n; begin += kSlice) {
      const std::size_t count = std::min(kSlice, n - begin);
      for (std::size_t i = 0; i < count; ++i) coordinates[i] = mesh.points[begin + i][a];
      const double* component[3] = {nullptr, nullptr, nullptr};
      component[a] = coordinates.data();
      check(ex_put_partial_coord(id, static_cast<int64_t>(begin) + 1, static_cast<int64_t>(count), component[0],
                                 component[1], component[2]),
            "write failed: the coordinates");
    }

  // Writes the values put(h, p) makes for each hex of each block in slices of `per_slice` hexes:
  // write(g, first element of the slice in its block (0-based), hexes, values).
  std::vector<int> values;
  auto block_slices = [&](std::size_t per_hex, const auto& put, const auto& write) {
    const std::size_t per_slice = std::min(m, kSlice / per_hex);
    values.resize(per_hex * per_slice);
    for (std::size_t g = 0; g < k; ++g) {
      std::size_t written = 0, filled = 0;
      each_hex_of(g, [&](std::size_t h) {
        put(h, values.data() + per_hex * filled);
        if (++filled == per_slice) {
          write(g, written, filled);
          written += filled;
          filled = 0;
        }
      });
      if (filled > 0) write(g, written, filled);
    }
  };
  block_slices(
      8,
      [&](std::size_t h, int* p) {
        for (int c = 0; c < 8; ++c) p[c] = static_cast<int>(mesh.hexes[h][c] + 1);
      },
      [&](std::size_t g, std::size_t first, std::size_t count) {
        check(ex_put_partial_elem_conn(id, block_id(g), static_cast<int64_t>(first) + 1, static_cast<int64_t>(count),
                                       values.data()),
              "write failed: the connectivity");
      });

  if (boundary_nodes > 0) {
    std::vector<int> nodes(std::min<std::size_t>(boundary_nodes, kSlice));
    std::size_t written = 0, filled = 0;
    auto flush = [&] {
      check(ex_put_partial_set(id, EX_NODE_SET, 1, static_cast<int64_t>(written) + 1, static_cast<int64_t>(filled),
                               nodes.data(), nullptr),
            "write failed: the boundary node set");
      written += filled;
      filled = 0;
    };
    for (std::size_t v = 0; v < n; ++v)
      if ((boundary_bits[v / 64] >> (v % 64)) & 1) {
        nodes[filled] = static_cast<int>(v + 1);
        if (++filled == nodes.size()) flush();
      }
    if (filled > 0) flush();
  }
  // A face lies between one pair of regions: the side sets' faces are all different.
  std::vector<std::uint32_t> all_sides;
  for (const RegionInterface& i : faces.interfaces) all_sides.insert(all_sides.end(), i.faces.begin(), i.faces.end());
  std::sort(all_sides.begin(), all_sides.end());
  const std::vector<int32_t> numbers = element_numbers(mesh, regions, block_start, all_sides);
  for (std::size_t j = 0; j < s; ++j) {
    const RegionInterface& i = faces.interfaces[j];
    std::vector<int> elements(i.faces.size()), sides(i.faces.size());
    for (std::size_t q = 0; q < sides.size(); ++q) {
      const auto at = std::lower_bound(all_sides.begin(), all_sides.end(), i.faces[q]) - all_sides.begin();
      elements[q] = numbers[static_cast<std::size_t>(at)];
      sides[q] = kExodusSide[i.faces[q] % 6];
    }
    check(ex_put_set(id, EX_SIDE_SET, static_cast<int64_t>(j) + 1, elements.data(), sides.data()),
          "write failed: an interface side set");
  }

  block_slices(
      1, [&](std::size_t h, int* p) { *p = static_cast<int>(h + 1); },
      [&](std::size_t g, std::size_t first, std::size_t count) {
        check(ex_put_partial_id_map(id, EX_ELEM_MAP, static_cast<int64_t>(block_start[g] + first) + 1,
                                    static_cast<int64_t>(count), values.data()),
              "write failed: the element number map");
      });
  db.close("write failed: closing the Exodus database");
}

}  // namespace mchex::io_detail
