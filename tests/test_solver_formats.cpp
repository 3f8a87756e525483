// The solver formats of core/io (docs/formats.md): MEDIT binary .meshb, Exodus II .exo, Abaqus /
// CalculiX .inp and Gmsh 4.1 binary .msh. test_mesh_io.cpp runs every format through the common
// tests (exact round trips, atomic writes, truncations, corruptions); here are the facts of each
// layout, checked against the format's definition or its own library: the .meshb bytes against
// libMeshb's layout, the .exo sets against libexodusii's own side-to-node table, the .inp fields
// against CalculiX's field widths, conversion between every pair of formats.
#include <exodusII.h>
#include <unistd.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/io/mesh_io.h"

namespace mchex {
namespace {

namespace fs = std::filesystem;

class TempDir {
 public:
  TempDir() {
    static std::atomic<int> serial{0};
    path_ = fs::temp_directory_path() /
            ("mchex_solver_formats_" + std::to_string(::getpid()) + "_" + std::to_string(serial++));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  fs::path operator/(const std::string& name) const { return path_ / name; }

 private:
  fs::path path_;
};

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_bytes(const fs::path& path, std::string_view bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// An n^3 block of hexes on a lattice of spacing 1/n, corners in VTK_HEXAHEDRON order; regions
// given per hex by `region_of(i, j, k)`.
template <class RegionOf>
HexMesh block_mesh(uint32_t n, const RegionOf& region_of) {
  HexMesh mesh;
  const uint32_t s = n + 1;
  for (uint32_t k = 0; k < s; ++k)
    for (uint32_t j = 0; j < s; ++j)
      for (uint32_t i = 0; i < s; ++i) mesh.points.push_back({i / double(n), j / double(n), k / double(n)});
  for (uint32_t k = 0; k < n; ++k)
    for (uint32_t j = 0; j < n; ++j)
      for (uint32_t i = 0; i < n; ++i) {
        const uint32_t b = i + s * j + s * s * k;
        mesh.hexes.push_back({b, b + 1, b + 1 + s, b + s, b + s * s, b + 1 + s * s, b + 1 + s + s * s, b + s + s * s});
        mesh.region.push_back(region_of(i, j, k));
      }
  return mesh;
}

std::string error_of(const fs::path& path) {
  try {
    read_hex_mesh(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

void expect_error(const fs::path& path, std::string_view bytes, const std::string& reason) {
  write_bytes(path, bytes);
  const std::string message = error_of(path);
  EXPECT_EQ(message.rfind(path.string() + ": ", 0), 0u) << message;
  EXPECT_NE(message.find(reason), std::string::npos) << message << "\nwanted: " << reason;
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
}

// ---------------------------------------------------------------------------------------------
// .meshb: libMeshb's binary layout (docs/formats.md)

template <class T>
void put(std::string& s, T v, bool big_endian = false) {
  char b[sizeof v];
  std::memcpy(b, &v, sizeof v);
  if (big_endian) std::reverse(b, b + sizeof v);
  s.append(b, sizeof v);
}

HexMesh one_hex(int32_t region) {
  HexMesh m;
  m.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 0.5}};
  m.hexes = {{0, 1, 2, 3, 4, 5, 6, 7}};
  m.region = {region};
  return m;
}

// A .meshb file of `mesh` in `version` (1..4), built here from the layout: code, version, then
// keywords of code, next position and (counted ones) a record count. `extra`: a Triangles section
// (one triangle) before the hexahedra, which a reader must skip.
std::string meshb_bytes(const HexMesh& mesh, int version, bool big_endian, bool extra) {
  std::string s;
  auto i32 = [&](int32_t v) { put(s, v, big_endian); };
  auto integer = [&](std::int64_t v) {
    if (version >= 4) {
      put(s, v, big_endian);
    } else {
      put(s, static_cast<int32_t>(v), big_endian);
    }
  };
  // Positions are patched once the next keyword's offset is known.
  std::size_t pending = 0;
  auto position = [&] {
    pending = s.size();
    if (version >= 3) {
      put<std::int64_t>(s, 0, big_endian);
    } else {
      i32(0);
    }
  };
  auto patch = [&] {
    std::string p;
    if (version >= 3) {
      put<std::int64_t>(p, static_cast<std::int64_t>(s.size()), big_endian);
    } else {
      put<int32_t>(p, static_cast<int32_t>(s.size()), big_endian);
    }
    s.replace(pending, p.size(), p);
  };
  i32(1);
  i32(version);
  i32(3);
  position();
  i32(3);
  patch();
  i32(4);
  position();
  integer(static_cast<std::int64_t>(mesh.points.size()));
  for (const Vec3& p : mesh.points) {
    for (int a = 0; a < 3; ++a) {
      if (version == 1) {
        put(s, static_cast<float>(p[a]), big_endian);
      } else {
        put(s, p[a], big_endian);
      }
    }
    integer(0);
  }
  patch();
  if (extra) {
    i32(6);  // Triangles
    position();
    integer(1);
    for (int v : {1, 2, 3, 9}) integer(v);
    patch();
  }
  i32(10);
  position();
  integer(static_cast<std::int64_t>(mesh.hexes.size()));
  for (std::size_t h = 0; h < mesh.hexes.size(); ++h) {
    for (const uint32_t v : mesh.hexes[h]) integer(std::int64_t{v} + 1);
    integer(mesh.region[h]);
  }
  patch();
  i32(54);
  if (version >= 3) {
    put<std::int64_t>(s, 0, big_endian);
  } else {
    i32(0);
  }
  return s;
}

TEST(SolverFormatsMeshb, WrittenBytesAreLibMeshbsVersion3Layout) {
  TempDir dir;
  const HexMesh mesh = one_hex(7);
  write_hex_mesh(mesh, dir / "one.meshb");
  EXPECT_EQ(read_bytes(dir / "one.meshb"), meshb_bytes(mesh, 3, false, false));
}

TEST(SolverFormatsMeshb, ReadsEveryVersionEitherByteOrderAndSkipsOtherKeywords) {
  TempDir dir;
  const HexMesh mesh = one_hex(-5);
  for (int version = 1; version <= 4; ++version)
    for (const bool big : {false, true})
      for (const bool extra : {false, true}) {
        SCOPED_TRACE("version " + std::to_string(version) + (big ? " big-endian" : "") + (extra ? " + triangles" : ""));
        write_bytes(dir / "v.meshb", meshb_bytes(mesh, version, big, extra));
        const HexMesh got = read_hex_mesh(dir / "v.meshb");
        EXPECT_EQ(got.points.size(), mesh.points.size());
        for (std::size_t i = 0; i < mesh.points.size(); ++i)
          for (int a = 0; a < 3; ++a) EXPECT_EQ(got.points[i][a], mesh.points[i][a]);  // exact in float too
        EXPECT_EQ(got.hexes, mesh.hexes);
        EXPECT_EQ(got.region, mesh.region);
      }
}

TEST(SolverFormatsMeshb, BadFiles) {
  TempDir dir;
  const std::string good = meshb_bytes(one_hex(1), 3, false, false);
  std::string tetrahedra = good;
  // The Hexahedra keyword code (10) becomes Tetrahedra (8).
  const std::size_t at = good.size() - 12 - (9 * 4 + 4 + 8 + 4);
  ASSERT_EQ(good[at], 10);
  tetrahedra[at] = 8;
  expect_error(dir / "tet.meshb", tetrahedra, "only all-hex meshes can be read");
  expect_error(dir / "text.meshb", "MeshVersionFormatted 2\n", "not a MEDIT binary file");
  std::string version = good;
  version[4] = 9;
  expect_error(dir / "version.meshb", version, "unknown .meshb version 9");
  std::string index = good;
  index[at + 4 + 8 + 4] = 99;  // the first corner of the hex
  expect_error(dir / "index.meshb", index, "vertex index 99 out of range 1..8");
  std::string count = good;
  count[at + 4 + 8] = 100;  // 100 hexahedra announced
  expect_error(dir / "count.meshb", count, "Hexahedra count 100 is more than the rest of the file can hold");
  std::string nan = good;
  const double not_a_number = std::nan("");
  std::memcpy(nan.data() + 8 + 16 + 16, &not_a_number, 8);
  expect_error(dir / "nan.meshb", nan, "a vertex coordinate is not a finite number");
}

// ---------------------------------------------------------------------------------------------
// .exo: blocks, the number map, the boundary node set and the interface side sets

// Faces (sorted corner indices) of every hex, counted by brute force: independent of the writer's
// face matching.
std::map<std::array<uint32_t, 4>, std::vector<std::size_t>> faces_by_corners(const HexMesh& mesh) {
  // The six faces as corner sets, from the VTK_HEXAHEDRON picture (not from core's table).
  constexpr int kFaces[6][4] = {{0, 1, 2, 3}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
  std::map<std::array<uint32_t, 4>, std::vector<std::size_t>> faces;
  for (std::size_t h = 0; h < mesh.hexes.size(); ++h)
    for (const auto& f : kFaces) {
      std::array<uint32_t, 4> key;
      for (int i = 0; i < 4; ++i) key[i] = mesh.hexes[h][f[i]];
      std::sort(key.begin(), key.end());
      faces[key].push_back(h);
    }
  return faces;
}

// Reads `path` with libexodusii and checks it holds `mesh`: one HEX8 block per region value,
// ascending, id = the region when all are positive (else 1..k), named region_R; the number map
// giving each element's hex; the node set "boundary" of the nodes of faces one hex has; a side set
// "interface_a_b" per pair of regions a < b that share faces, libexodusii's own side numbering
// turning each (element, side) into exactly those faces, the element on the region-a side.
void expect_exodus_holds(const fs::path& path, const HexMesh& mesh) {
  std::vector<int32_t> values(mesh.region);
  std::sort(values.begin(), values.end());
  values.erase(std::unique(values.begin(), values.end()), values.end());
  const auto faces = faces_by_corners(mesh);
  std::set<int> boundary;
  std::map<std::pair<int, int>, std::set<std::array<uint32_t, 4>>> expected;
  for (const auto& [key, hexes] : faces) {
    ASSERT_LE(hexes.size(), 2u) << "a face of more than two hexes: not a mesh for this check";
    if (hexes.size() == 1)
      for (const uint32_t v : key) boundary.insert(static_cast<int>(v + 1));
    if (hexes.size() == 2 && mesh.region[hexes[0]] != mesh.region[hexes[1]]) {
      const int a = std::min(mesh.region[hexes[0]], mesh.region[hexes[1]]);
      const int b = std::max(mesh.region[hexes[0]], mesh.region[hexes[1]]);
      expected[{a, b}].insert(key);
    }
  }

  ex_opts(0);
  int comp_ws = 8, io_ws = 0;
  float version = 0;
  const int id = ex_open(path.c_str(), EX_READ, &comp_ws, &io_ws, &version);
  ASSERT_GE(id, 0);
  char title[MAX_LINE_LENGTH + 1];
  int dim, nodes, elements, blocks, node_sets, side_sets;
  ASSERT_EQ(ex_get_init(id, title, &dim, &nodes, &elements, &blocks, &node_sets, &side_sets), 0);
  EXPECT_EQ(dim, 3);
  EXPECT_EQ(nodes, static_cast<int>(mesh.points.size()));
  EXPECT_EQ(elements, static_cast<int>(mesh.hexes.size()));
  ASSERT_EQ(blocks, static_cast<int>(values.size()));
  EXPECT_EQ(node_sets, 1);
  ASSERT_EQ(side_sets, static_cast<int>(expected.size()));

  std::vector<double> x(mesh.points.size()), y(x.size()), z(x.size());
  ASSERT_EQ(ex_get_coord(id, x.data(), y.data(), z.data()), 0);
  for (std::size_t i = 0; i < x.size(); ++i)
    EXPECT_TRUE((Vec3{x[i], y[i], z[i]} == mesh.points[i])) << "node " << i + 1;

  // Blocks in ascending region order; elements in block order, the number map giving each
  // element's hex, in hex order within a block.
  std::vector<int> ids(values.size());
  ASSERT_EQ(ex_get_ids(id, EX_ELEM_BLOCK, ids.data()), 0);
  std::vector<int> number(mesh.hexes.size());
  ASSERT_EQ(ex_get_id_map(id, EX_ELEM_MAP, number.data()), 0);
  const bool ids_are_regions = values.front() > 0;
  std::size_t element = 0;
  for (std::size_t k = 0; k < ids.size(); ++k) {
    EXPECT_EQ(ids[k], ids_are_regions ? values[k] : static_cast<int>(k + 1));
    char type[MAX_STR_LENGTH + 1];
    int count, per, edges, block_faces, attributes;
    ASSERT_EQ(ex_get_block(id, EX_ELEM_BLOCK, ids[k], type, &count, &per, &edges, &block_faces, &attributes), 0);
    EXPECT_STREQ(type, "HEX8");
    EXPECT_EQ(per, 8);
    char name[MAX_STR_LENGTH + 1];
    ASSERT_EQ(ex_get_name(id, EX_ELEM_BLOCK, ids[k], name), 0);
    EXPECT_EQ(std::string(name), "region_" + std::to_string(values[k]));
    std::vector<int> connectivity(8 * static_cast<std::size_t>(count));
    ASSERT_EQ(ex_get_conn(id, EX_ELEM_BLOCK, ids[k], connectivity.data(), nullptr, nullptr), 0);
    int previous = 0;
    for (int e = 0; e < count; ++e, ++element) {
      ASSERT_GT(number[element], previous);
      previous = number[element];
      const std::size_t h = static_cast<std::size_t>(number[element] - 1);
      ASSERT_LT(h, mesh.hexes.size());
      EXPECT_EQ(mesh.region[h], values[k]);
      for (int c = 0; c < 8; ++c) EXPECT_EQ(connectivity[8 * e + c], static_cast<int>(mesh.hexes[h][c] + 1));
    }
  }
  EXPECT_EQ(element, mesh.hexes.size());

  int set_ids[1];
  ASSERT_EQ(ex_get_ids(id, EX_NODE_SET, set_ids), 0);
  int entries = 0, factors = 0;
  ASSERT_EQ(ex_get_set_param(id, EX_NODE_SET, set_ids[0], &entries, &factors), 0);
  std::vector<int> set_nodes(static_cast<std::size_t>(entries));
  if (entries > 0) {
    ASSERT_EQ(ex_get_set(id, EX_NODE_SET, set_ids[0], set_nodes.data(), nullptr), 0);
  }
  EXPECT_EQ(std::set<int>(set_nodes.begin(), set_nodes.end()), boundary);
  EXPECT_EQ(set_nodes.size(), boundary.size());
  char set_name[MAX_STR_LENGTH + 1];
  ASSERT_EQ(ex_get_name(id, EX_NODE_SET, set_ids[0], set_name), 0);
  EXPECT_STREQ(set_name, "boundary");

  std::vector<int> side_ids(expected.size());
  if (!side_ids.empty()) {
    ASSERT_EQ(ex_get_ids(id, EX_SIDE_SET, side_ids.data()), 0);
  }
  std::map<std::pair<int, int>, std::set<std::array<uint32_t, 4>>> got;
  for (const int s : side_ids) {
    ASSERT_EQ(ex_get_set_param(id, EX_SIDE_SET, s, &entries, &factors), 0);
    std::vector<int> side_elements(static_cast<std::size_t>(entries)), sides(static_cast<std::size_t>(entries));
    ASSERT_EQ(ex_get_set(id, EX_SIDE_SET, s, side_elements.data(), sides.data()), 0);
    std::vector<int> counts(static_cast<std::size_t>(entries)), side_nodes(4 * static_cast<std::size_t>(entries));
    ASSERT_EQ(ex_get_side_set_node_list(id, s, counts.data(), side_nodes.data()), 0);
    ASSERT_EQ(ex_get_name(id, EX_SIDE_SET, s, set_name), 0);
    int a = 0, b = 0;
    ASSERT_EQ(std::sscanf(set_name, "interface_%d_%d", &a, &b), 2) << set_name;
    for (int e = 0; e < entries; ++e) {
      ASSERT_EQ(counts[e], 4);
      // The listed element is the region-a side of the face.
      EXPECT_EQ(mesh.region[static_cast<std::size_t>(number[side_elements[e] - 1] - 1)], a);
      std::array<uint32_t, 4> key;
      for (int i = 0; i < 4; ++i) key[i] = static_cast<uint32_t>(side_nodes[4 * e + i] - 1);
      std::sort(key.begin(), key.end());
      EXPECT_TRUE(got[std::make_pair(a, b)].insert(key).second) << "a face listed twice";
    }
  }
  EXPECT_EQ(got, expected);
  ex_close(id);
}

TEST(SolverFormatsExodus, BlocksNumberMapAndSetsAreWhatLibexodusiiReads) {
  TempDir dir;
  // Region 1 a 2x2x2 core, 2 around it, 3 a slab on top: interfaces 1-2, 2-3 and 1-3.
  const HexMesh mesh = block_mesh(4, [](uint32_t i, uint32_t j, uint32_t k) -> int32_t {
    if (k == 3) return 3;
    return (i >= 1 && i <= 2 && j >= 1 && j <= 2 && k >= 1) ? 1 : 2;
  });
  write_hex_mesh(mesh, dir / "m.exo");
  {
    SCOPED_TRACE("three regions");
    expect_exodus_holds(dir / "m.exo", mesh);
  }
  int comp_ws = 8, io_ws = 0;
  float version = 0;
  const int id = ex_open((dir / "m.exo").c_str(), EX_READ, &comp_ws, &io_ws, &version);
  ASSERT_GE(id, 0);
  char title[MAX_LINE_LENGTH + 1];
  int dim, nodes, elements, blocks, node_sets, side_sets;
  ASSERT_EQ(ex_get_init(id, title, &dim, &nodes, &elements, &blocks, &node_sets, &side_sets), 0);
  EXPECT_EQ(blocks, 3);
  EXPECT_EQ(side_sets, 3);
  ex_close(id);
}

// The faces are matched on all threads in slices of the hex order (core/io/face_matching.h): hexes
// in a scrambled order put a face's two hexes in different slices, far apart; the sets must still
// be the brute force's, with any labels (negative ones give block ids 1..k) and any number of
// regions. The largest mesh passes the writer's 64 Ki values per libexodusii call in points, in
// element numbers and in hexes per block. The file is netCDF classic with 64-bit offsets, the
// layout exodus.cpp reads itself.
TEST(SolverFormatsExodus, SetsAreTheBruteForcesInAnyHexOrder) {
  TempDir dir;
  auto scrambled = [](HexMesh mesh, unsigned seed) {
    std::mt19937 random(seed);
    for (std::size_t h = mesh.hexes.size(); h > 1; --h) {
      const std::size_t g = random() % h;
      std::swap(mesh.hexes[h - 1], mesh.hexes[g]);
      std::swap(mesh.region[h - 1], mesh.region[g]);
    }
    return mesh;
  };
  const auto three = [](uint32_t i, uint32_t j, uint32_t k) {
    return static_cast<int32_t>(1 + (i / 3 + j / 4 + k / 2) % 3);
  };
  const auto negative = [](uint32_t i, uint32_t j, uint32_t k) {
    return static_cast<int32_t>((i * 7 + j * 3 + k) % 5) - 2;
  };
  const auto many = [](uint32_t i, uint32_t j, uint32_t k) {
    return static_cast<int32_t>((i + 3 * j + 5 * k) % 40 + 1);
  };
  // More region values than core/io/region_groups.h lists, 0 among them.
  const auto hundreds = [](uint32_t i, uint32_t j, uint32_t k) {
    return static_cast<int32_t>((i + 8 * j + 64 * k) % 300);
  };
  const std::vector<std::pair<std::string, HexMesh>> meshes = {
      {"one region", block_mesh(6, [](uint32_t, uint32_t, uint32_t) { return 1; })},
      {"three regions", block_mesh(9, three)},
      {"three regions scrambled", scrambled(block_mesh(11, three), 7)},
      {"negative labels scrambled", scrambled(block_mesh(7, negative), 8)},
      {"40 regions scrambled", scrambled(block_mesh(10, many), 9)},
      {"300 regions", block_mesh(8, hundreds)},
      {"74088 hexes scrambled", scrambled(block_mesh(42, three), 10)},
  };
  for (const auto& [name, mesh] : meshes) {
    SCOPED_TRACE(name);
    write_hex_mesh(mesh, dir / "m.exo");
    expect_exodus_holds(dir / "m.exo", mesh);
    EXPECT_EQ(read_bytes(dir / "m.exo").substr(0, 4), std::string("CDF\x02", 4));
    const HexMesh back = read_hex_mesh(dir / "m.exo");
    EXPECT_TRUE(back.points == mesh.points && back.hexes == mesh.hexes && back.region == mesh.region);
  }
}

TEST(SolverFormatsExodus, NotAnExodusFile) {
  TempDir dir;
  expect_error(dir / "text.exo", "MeshVersionFormatted 2\n", "not an Exodus II file");
}

// ---------------------------------------------------------------------------------------------
// .inp: CalculiX's field widths, decks from other tools, bad decks

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

TEST(SolverFormatsAbaqus, EveryFieldFitsCalculiXsWidths) {
  TempDir dir;
  HexMesh mesh = block_mesh(3, [](uint32_t i, uint32_t, uint32_t) { return static_cast<int32_t>(i % 2 ? 1 : -4); });
  // The widest coordinates there are: full-precision negatives with 3-digit negative exponents.
  mesh.points[1] = {-2.2250738585072014e-308, -1.7976931348623157e308, -1.2345678901234567e-123};
  mesh.points[2] = {-0.1 - 0.2, 1.0 / 3.0, -5e-324};
  write_hex_mesh(mesh, dir / "m.inp");
  std::string section;
  std::size_t node_lines = 0, element_lines = 0;
  for (const std::string& line : lines_of(read_bytes(dir / "m.inp"))) {
    EXPECT_LE(line.size(), 132u) << line;  // CalculiX's line length
    if (line[0] == '*') {
      section = line.substr(0, line.find(','));
      continue;
    }
    std::vector<std::string> fields;
    std::istringstream f(line);
    for (std::string field; std::getline(f, field, ',');) fields.push_back(field);
    EXPECT_LE(fields.size(), 16u) << line;  // CalculiX splits a line into at most 16 fields
    if (section == "*NODE") {
      ++node_lines;
      ASSERT_EQ(fields.size(), 4u) << line;
      EXPECT_LE(fields[0].size(), 10u) << line;  // CalculiX reads an integer from 10 characters
      for (std::size_t a = 1; a < 4; ++a) {
        EXPECT_LE(fields[a].size(), 20u) << line;  // and a real from 20
        const double v = std::strtod(fields[a].c_str(), nullptr);
        const double want = mesh.points[node_lines - 1][static_cast<int>(a - 1)];
        EXPECT_LE(std::abs(v - want), 5e-13 * std::abs(want)) << line;
      }
    } else if (section == "*ELEMENT" || section == "*ELSET") {
      element_lines += section == "*ELEMENT";
      if (section == "*ELEMENT") {
        EXPECT_EQ(fields.size(), 9u) << line;
      }
      for (const std::string& field : fields) EXPECT_LE(field.size(), 10u);
    }
  }
  EXPECT_EQ(node_lines, mesh.points.size());
  EXPECT_EQ(element_lines, mesh.hexes.size());
  const HexMesh back = read_hex_mesh(dir / "m.inp");
  EXPECT_EQ(back.hexes, mesh.hexes);
  EXPECT_EQ(back.region, mesh.region);
}

TEST(SolverFormatsAbaqus, ReadsDecksOfOtherTools) {
  TempDir dir;
  const std::string deck = "** a deck as a pre-processor writes it\n"
                           "*Heading\n title line\n"
                           "*Node, nset=ALL\n"
                           "  10, 0., 0., 0.\n 20, 1., 0., 0.\n 30, 1., 1., 0.\n 40, 0., 1., 0.\n"
                           " 50, 0., 0., 1.\n 60, 1., 0., 1.\n 70, 1., 1., 1.\n 80, 0., 1., 1.\n 90, 2., 0., 0.\n"
                           "*Element, type=S4, elset=SKIN\n 1, 10, 20, 30, 40\n"
                           "*ELEMENT, TYPE=C3D8R, ELSET=PART\n"
                           " 7, 10, 20, 30, 40,\n 50, 60, 70, 80\n"
                           " 3, 10, 20, 30, 40, 50, 60, 70, 80\n"
                           "*Elset, elset=REGION_M2, generate\n 3, 3, 1\n"
                           "*Elset, elset=region9\n 7,\n"
                           "*Material, name=STEEL\n*Elastic\n 210000., 0.3\n";
  write_bytes(dir / "deck.inp", deck);
  const HexMesh m = read_hex_mesh(dir / "deck.inp");
  ASSERT_EQ(m.points.size(), 9u);
  EXPECT_EQ(m.points[8].x, 2.0);
  // In id order: element 3 then 7; the point of node 10 is point 0.
  ASSERT_EQ(m.hexes.size(), 2u);
  EXPECT_EQ(m.hexes[0], (Hex{0, 1, 2, 3, 4, 5, 6, 7}));
  EXPECT_EQ(m.hexes[1], m.hexes[0]);
  EXPECT_EQ(m.region, (std::vector<int32_t>{-2, 9}));
}

TEST(SolverFormatsAbaqus, BadDecks) {
  TempDir dir;
  const std::string nodes = "*NODE\n1,0,0,0\n2,1,0,0\n3,1,1,0\n4,0,1,0\n5,0,0,1\n6,1,0,1\n7,1,1,1\n8,0,1,1\n";
  expect_error(dir / "tet.inp", nodes + "*ELEMENT, TYPE=C3D4\n1,1,2,3,4\n",
               "line 10: elements of type C3D4: only 8-node hexahedra (C3D8) can be read");
  expect_error(dir / "node.inp", nodes + "*ELEMENT, TYPE=C3D8\n1,1,2,3,4,5,6,7,9\n",
               "element 1 uses node 9, which *NODE does not define");
  expect_error(dir / "twice.inp", nodes + "1,0,0,0\n", "node number 1 is defined twice");
  expect_error(dir / "number.inp", "*NODE\n1,0,0,zero\n", "line 2: expected a coordinate (a number), found 'zero'");
  expect_error(dir / "short.inp", nodes + "*ELEMENT, TYPE=C3D8\n1,1,2,3,4,5,6,7\n",
               "a C3D8 element needs its number and 8 node numbers");
  expect_error(dir / "data.inp", "1,0,0,0\n", "line 1: expected a keyword line starting with '*'");
  expect_error(dir / "type.inp", nodes + "*ELEMENT\n1,1,2,3,4,5,6,7,8\n", "*ELEMENT without TYPE=");
  expect_error(dir / "set.inp", nodes + "*ELEMENT, TYPE=C3D8\n1,1,2,3,4,5,6,7,8\n*ELSET, ELSET=REGION2\n5\n",
               "set REGION2 names element 5, which is no C3D8 element of the file");
  expect_error(dir / "inf.inp", "*NODE\n1,0,1e999,0\n", "coordinate '1e999' is not a finite number");
}

// ---------------------------------------------------------------------------------------------
// Gmsh 4.1 binary

TEST(SolverFormatsGmshBinary, HoldsWhatTheAsciiFileHolds) {
  TempDir dir;
  const HexMesh mesh =
      block_mesh(5, [](uint32_t i, uint32_t j, uint32_t) { return static_cast<int32_t>((i + j) % 3 - 1); });
  MeshWriteOptions binary;
  binary.binary = true;
  write_hex_mesh(mesh, dir / "b.msh", binary);
  write_hex_mesh(mesh, dir / "a.msh");
  const std::string bytes = read_bytes(dir / "b.msh");
  // The header as Gmsh writes it: version, file-type 1, data size 8, then the int 1.
  std::string head = "$MeshFormat\n4.1 1 8\n";
  put<int32_t>(head, 1);
  head += "\n$EndMeshFormat\n";
  EXPECT_EQ(bytes.substr(0, head.size()), head);
  const HexMesh a = read_hex_mesh(dir / "a.msh");
  const HexMesh b = read_hex_mesh(dir / "b.msh");
  EXPECT_EQ(a.hexes, b.hexes);
  EXPECT_EQ(a.region, b.region);
  EXPECT_EQ(b.region, mesh.region);
  ASSERT_EQ(a.points.size(), b.points.size());
  for (std::size_t i = 0; i < a.points.size(); ++i)
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(std::bit_cast<uint64_t>(a.points[i][k]), std::bit_cast<uint64_t>(b.points[i][k]));
}

// ---------------------------------------------------------------------------------------------
// Every pair of formats

TEST(SolverFormatsConvert, EveryPairKeepsTheMesh) {
  TempDir dir;
  const HexMesh mesh =
      block_mesh(3, [](uint32_t i, uint32_t j, uint32_t k) { return static_cast<int32_t>(1 + (i * j + k) % 4); });
  const std::vector<std::pair<std::string, bool>> formats = {{".mesh", false}, {".meshb", false}, {".vtu", false},
                                                             {".msh", false},  {".msh", true},    {".exo", false},
                                                             {".inp", false}};
  for (const auto& [from, from_binary] : formats)
    for (const auto& [to, to_binary] : formats) {
      SCOPED_TRACE(from + (from_binary ? " binary" : "") + " -> " + to + (to_binary ? " binary" : ""));
      MeshWriteOptions a, b;
      a.binary = from_binary;
      b.binary = to_binary;
      write_hex_mesh(mesh, dir / ("in" + from), a);
      write_hex_mesh(read_hex_mesh(dir / ("in" + from)), dir / ("out" + to), b);
      const HexMesh got = read_hex_mesh(dir / ("out" + to));
      // Every coordinate of this lattice has a short exact form, so .inp keeps it too.
      ASSERT_EQ(got.points.size(), mesh.points.size());
      for (std::size_t i = 0; i < mesh.points.size(); ++i)
        for (int k = 0; k < 3; ++k) ASSERT_EQ(got.points[i][k], mesh.points[i][k]);
      EXPECT_EQ(got.hexes, mesh.hexes);
      EXPECT_EQ(got.region, mesh.region);
    }
}

}  // namespace
}  // namespace mchex
