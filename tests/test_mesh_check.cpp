// The mesh validator (core/check/mesh_check.h) on grids of unit cells split into an inside and an
// outside mesh. Expected counts are computed here by direct loops over the cell grid (or by
// hand for the small shapes), independently of the checker's sort-based face matching.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <numeric>
#include <random>
#include <string>

#include "core/check/mesh_check.h"
#include "core/mesh/hex_faces.h"
#include "core/mesh/quality.h"

namespace mchex {
namespace {

// n[0] x n[1] x n[2] unit cells; a cell is inside or outside.
struct CellGrid {
  std::array<int, 3> n;
  std::vector<uint8_t> inside;

  explicit CellGrid(std::array<int, 3> dims)
      : n(dims), inside(static_cast<std::size_t>(dims[0]) * dims[1] * dims[2], 0) {}
  std::size_t cell(int i, int j, int k) const {
    return static_cast<std::size_t>(i) + static_cast<std::size_t>(n[0]) * (j + static_cast<std::size_t>(n[1]) * k);
  }
  bool valid(int i, int j, int k) const { return i >= 0 && j >= 0 && k >= 0 && i < n[0] && j < n[1] && k < n[2]; }
  void set(int i, int j, int k, bool v = true) { inside[cell(i, j, k)] = v ? 1 : 0; }
  bool in(int i, int j, int k) const { return inside[cell(i, j, k)] != 0; }

  template <class F>
  void for_each_cell(F&& f) const {
    for (int k = 0; k < n[2]; ++k) {
      for (int j = 0; j < n[1]; ++j) {
        for (int i = 0; i < n[0]; ++i) f(i, j, k);
      }
    }
  }
};

struct Layout {
  double h = 1;  // cell size
  Vec3 origin{0, 0, 0};
  uint64_t shuffle = 0;  // nonzero: permute points and hexes with this seed
};

// The cells with inside == want as a hex mesh with its own, compacted point array. Points are
// origin + h * (i, j, k), computed the same way for both meshes so shared points coincide.
HexMesh build_mesh(const CellGrid& g, bool want, const Layout& layout = {}) {
  const int px = g.n[0] + 1, py = g.n[1] + 1, pz = g.n[2] + 1;
  std::vector<uint32_t> index(static_cast<std::size_t>(px) * py * pz, UINT32_MAX);
  HexMesh m;
  auto point = [&](int i, int j, int k) {
    uint32_t& id =
        index[static_cast<std::size_t>(i) + static_cast<std::size_t>(px) * (j + static_cast<std::size_t>(py) * k)];
    if (id == UINT32_MAX) {
      id = static_cast<uint32_t>(m.points.size());
      m.points.push_back(layout.origin + layout.h * Vec3{double(i), double(j), double(k)});
    }
    return id;
  };
  g.for_each_cell([&](int i, int j, int k) {
    if (g.in(i, j, k) != want) return;
    // VTK_HEXAHEDRON order: bottom 0-1-2-3 counter-clockwise seen from +z, then the top.
    m.hexes.push_back({point(i, j, k), point(i + 1, j, k), point(i + 1, j + 1, k), point(i, j + 1, k),
                       point(i, j, k + 1), point(i + 1, j, k + 1), point(i + 1, j + 1, k + 1), point(i, j + 1, k + 1)});
  });
  m.region.assign(m.hexes.size(), want ? kInside : kOutside);
  if (layout.shuffle) {
    std::mt19937_64 rng(layout.shuffle);
    std::vector<uint32_t> perm(m.points.size());
    std::iota(perm.begin(), perm.end(), 0u);
    std::shuffle(perm.begin(), perm.end(), rng);
    std::vector<Vec3> points(m.points.size());
    for (std::size_t p = 0; p < perm.size(); ++p) points[perm[p]] = m.points[p];
    m.points = std::move(points);
    for (Hex& hex : m.hexes) {
      for (uint32_t& v : hex) v = perm[v];
    }
    std::shuffle(m.hexes.begin(), m.hexes.end(), rng);
  }
  return m;
}

// Counts by direct loops over the grid.
struct Expected {
  std::size_t interface = 0;        // inside/outside cell pairs across a face
  std::size_t inside_interior = 0;  // inside/inside pairs
  std::size_t outside_interior = 0;
  std::size_t inside_box = 0;  // inside cell faces on the box
  std::size_t outside_box = 0;
  std::size_t shared_points = 0;  // grid points touched by an inside and an outside cell
};

Expected expected_counts(const CellGrid& g) {
  Expected e;
  g.for_each_cell([&](int i, int j, int k) {
    const bool a = g.in(i, j, k);
    const int d[6][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
    for (int f = 0; f < 6; ++f) {
      const int x = i + d[f][0], y = j + d[f][1], z = k + d[f][2];
      if (!g.valid(x, y, z)) {
        (a ? e.inside_box : e.outside_box) += 1;
      } else if (f < 3) {  // each pair once
        const bool b = g.in(x, y, z);
        if (a != b) ++e.interface;
        else (a ? e.inside_interior : e.outside_interior) += 1;
      }
    }
  });
  for (int k = 0; k <= g.n[2]; ++k) {
    for (int j = 0; j <= g.n[1]; ++j) {
      for (int i = 0; i <= g.n[0]; ++i) {
        bool any_in = false, any_out = false;
        for (int c = 0; c < 8; ++c) {
          const int x = i - (c & 1), y = j - ((c >> 1) & 1), z = k - ((c >> 2) & 1);
          if (!g.valid(x, y, z)) continue;
          (g.in(x, y, z) ? any_in : any_out) = true;
        }
        e.shared_points += any_in && any_out;
      }
    }
  }
  return e;
}

CellGrid ball_grid(int n, double radius) {
  CellGrid g({n, n, n});
  const double c = n / 2.0;
  g.for_each_cell([&](int i, int j, int k) {
    const double x = i + 0.5 - c, y = j + 0.5 - c, z = k + 0.5 - c;
    g.set(i, j, k, x * x + y * y + z * z <= radius * radius);
  });
  return g;
}

bool any_message_contains(const MeshCheck& c, const std::string& s) {
  return std::any_of(c.errors.begin(), c.errors.end(),
                     [&](const std::string& m) { return m.find(s) != std::string::npos; });
}

std::string dump(const MeshCheck& c) { return to_json(c).dump(1); }

void expect_pair_ok(const CellGrid& g, const MeshCheck& c) {
  const Expected e = expected_counts(g);
  ASSERT_TRUE(c.ok) << dump(c);
  EXPECT_EQ(c.error_count, 0u);
  EXPECT_TRUE(c.errors.empty());
  ASSERT_TRUE(c.outside && c.combined);
  EXPECT_EQ(c.combined->interface_faces, e.interface);
  EXPECT_EQ(c.combined->matched_points, e.shared_points);
  EXPECT_EQ(c.combined->gap_faces, 0u);
  EXPECT_EQ(c.combined->overlap_faces, 0u);
  EXPECT_TRUE(c.combined->volume_ok);
  EXPECT_EQ(c.inside.interior_faces, e.inside_interior);
  EXPECT_EQ(c.inside.boundary_faces, e.interface + e.inside_box);
  EXPECT_EQ(c.inside.faces, e.inside_interior + e.interface + e.inside_box);
  EXPECT_EQ(c.outside->interior_faces, e.outside_interior);
  EXPECT_EQ(c.outside->boundary_faces, e.interface + e.outside_box);
  EXPECT_EQ(c.inside.boundary.quads, c.inside.boundary_faces);
  const std::size_t cells_in = static_cast<std::size_t>(std::count(g.inside.begin(), g.inside.end(), 1));
  EXPECT_EQ(c.inside.quality.count, cells_in);
  EXPECT_EQ(c.inside.quality.certified, cells_in);
  EXPECT_EQ(c.outside->quality.count, g.inside.size() - cells_in);
}

TEST(mesh_check, BallOfCellsSplitsTheGridCleanly) {
  const CellGrid g = ball_grid(10, 3.6);
  const HexMesh in = build_mesh(g, true, {0.1, {-0.5, -0.5, -0.5}, 0});
  const HexMesh out = build_mesh(g, false, {0.1, {-0.5, -0.5, -0.5}, 7});  // shuffled ids
  const MeshCheck c = check_mesh(in, &out, nullptr);
  expect_pair_ok(g, c);
  // Coordinates -0.5 + 0.1 i are rounded: cubes up to a few ulps.
  EXPECT_NEAR(c.inside.quality.min_scaled_jacobian, 1.0, 1e-15);
  EXPECT_NEAR(c.inside.quality.mean_scaled_jacobian, 1.0, 1e-15);
  EXPECT_NEAR(c.inside.quality.max_edge_ratio, 1.0, 1e-12);
  EXPECT_NEAR(c.inside.quality.min_bernstein_scaled, 1.0, 1e-12);
  EXPECT_NEAR(c.combined->volume, 1.0, 1e-12);
  EXPECT_NEAR(c.combined->box_volume, 1.0, 1e-12);
  EXPECT_NEAR(c.inside.quality.volume, 0.001 * c.inside.quality.count, 1e-12);
  // This digital ball's boundary is a sphere: one closed manifold component, chi = 2. The
  // outside's boundary is the box and the sphere: two components, chi = 4.
  EXPECT_TRUE(c.inside.boundary.closed_manifold()) << dump(c);
  EXPECT_EQ(c.inside.boundary.euler_characteristic, 2);
  EXPECT_EQ(c.inside.boundary.components, 1u);
  EXPECT_EQ(c.inside.boundary.misoriented_edges, 0u);
  EXPECT_TRUE(c.outside->boundary.closed_manifold());
  EXPECT_EQ(c.outside->boundary.euler_characteristic, 4);
  EXPECT_EQ(c.outside->boundary.components, 2u);
  EXPECT_FALSE(c.combined->box_given);
}

// A 2 x 2 x 2 block of cells in a 4^3 grid, counted by hand: the block's surface has 24 quads,
// 26 vertices (the 3 x 3 x 3 lattice minus its centre) and 48 edges; chi = 2.
TEST(mesh_check, CubeOfCellsHasASphereBoundary) {
  CellGrid g({4, 4, 4});
  for (int k = 1; k < 3; ++k) {
    for (int j = 1; j < 3; ++j) {
      for (int i = 1; i < 3; ++i) g.set(i, j, k);
    }
  }
  const HexMesh in = build_mesh(g, true), out = build_mesh(g, false, {1, {}, 3});
  const MeshCheck c = check_mesh(in, &out, nullptr);
  expect_pair_ok(g, c);
  EXPECT_EQ(c.combined->interface_faces, 24u);
  EXPECT_EQ(c.combined->matched_points, 26u);
  const BoundaryStats& b = c.inside.boundary;
  EXPECT_EQ(b.quads, 24u);
  EXPECT_EQ(b.vertices, 26u);
  EXPECT_EQ(b.edges, 48u);
  EXPECT_EQ(b.euler_characteristic, 2);
  EXPECT_EQ(b.components, 1u);
  EXPECT_TRUE(b.closed_manifold());
  EXPECT_EQ(c.inside.interior_faces, 12u);
  // Outside: box surface (6 * 16 quads) and the block's surface.
  EXPECT_EQ(c.outside->boundary.quads, 96u + 24u);
  EXPECT_EQ(c.outside->boundary.euler_characteristic, 4);
  EXPECT_EQ(c.combined->volume, 64.0);
  EXPECT_EQ(c.combined->box_volume, 64.0);
}

// A 3 x 3 x 1 ring (centre cell removed): a torus. By hand: 8 top + 8 bottom + 12 outer + 4
// inner quads = 32, 16 + 16 vertices, 24 + 24 horizontal + 16 vertical edges = 64: chi = 0.
TEST(mesh_check, RingOfCellsHasATorusBoundary) {
  CellGrid g({5, 5, 3});
  for (int j = 1; j < 4; ++j) {
    for (int i = 1; i < 4; ++i) g.set(i, j, 1, !(i == 2 && j == 2));
  }
  const HexMesh in = build_mesh(g, true, {1, {}, 5}), out = build_mesh(g, false, {1, {}, 6});
  const MeshCheck c = check_mesh(in, &out, nullptr);
  expect_pair_ok(g, c);
  const BoundaryStats& b = c.inside.boundary;
  EXPECT_EQ(b.quads, 32u);
  EXPECT_EQ(b.vertices, 32u);
  EXPECT_EQ(b.edges, 64u);
  EXPECT_EQ(b.euler_characteristic, 0);
  EXPECT_EQ(b.components, 1u);
  EXPECT_TRUE(b.closed_manifold());
  EXPECT_EQ(c.combined->interface_faces, 32u);
}

// RO-like output: two cells touching along one edge. The boundary surface is not a manifold
// (that edge is in 4 quads; its two end vertices have two fans each), which is reported, not
// an error. By hand: V = 16 - 2, E = 24 - 1, F = 12, chi = 3.
TEST(mesh_check, CellsTouchingAlongAnEdgeAreReportedNotRejected) {
  CellGrid g({4, 4, 3});
  g.set(1, 1, 1);
  g.set(2, 2, 1);
  const HexMesh in = build_mesh(g, true), out = build_mesh(g, false);
  const MeshCheck c = check_mesh(in, &out, nullptr);
  expect_pair_ok(g, c);
  const BoundaryStats& b = c.inside.boundary;
  EXPECT_FALSE(b.closed_manifold());
  EXPECT_EQ(b.bad_edges, 1u);
  EXPECT_EQ(b.bad_vertices, 2u);
  EXPECT_EQ(b.vertices, 14u);
  EXPECT_EQ(b.edges, 23u);
  EXPECT_EQ(b.quads, 12u);
  EXPECT_EQ(b.euler_characteristic, 3);
  EXPECT_EQ(b.components, 1u);
  EXPECT_EQ(c.combined->interface_faces, 12u);
  // The outside sees the same pinch.
  EXPECT_EQ(c.outside->boundary.bad_edges, 1u);

  // Touching at one vertex only: the edges are fine, one vertex has two fans. V = 15, E = 24.
  CellGrid v({4, 4, 4});
  v.set(1, 1, 1);
  v.set(2, 2, 2);
  const HexMesh vin = build_mesh(v, true), vout = build_mesh(v, false);
  const MeshCheck cv = check_mesh(vin, &vout, nullptr);
  expect_pair_ok(v, cv);
  EXPECT_EQ(cv.inside.boundary.bad_edges, 0u);
  EXPECT_EQ(cv.inside.boundary.bad_vertices, 1u);
  EXPECT_EQ(cv.inside.boundary.euler_characteristic, 15 - 24 + 12);
}

TEST(mesh_check, SingleMeshWithoutOutside) {
  const CellGrid g = ball_grid(6, 2.5);
  const HexMesh in = build_mesh(g, true);
  const MeshCheck c = check_mesh(in, nullptr, nullptr);
  EXPECT_TRUE(c.ok) << dump(c);
  EXPECT_FALSE(c.outside.has_value());
  EXPECT_FALSE(c.combined.has_value());
  EXPECT_EQ(c.inside.quality.volume, static_cast<double>(in.hexes.size()));
  EXPECT_EQ(c.inside.boundary.euler_characteristic, 2);
}

// Mesh fixtures for the defect tests: a 6^3 grid with a 2^3 block inside at (2..3)^3.
struct Pair {
  CellGrid g{{6, 6, 6}};
  HexMesh in, out;
  Pair() {
    for (int k = 2; k < 4; ++k) {
      for (int j = 2; j < 4; ++j) {
        for (int i = 2; i < 4; ++i) g.set(i, j, k);
      }
    }
    in = build_mesh(g, true);
    out = build_mesh(g, false);
  }
  // The index of the outside hex whose corner 0 is at p.
  std::size_t outside_hex_at(Vec3 p) const {
    for (std::size_t h = 0; h < out.hexes.size(); ++h) {
      if (out.points[out.hexes[h][0]] == p) return h;
    }
    return SIZE_MAX;
  }
};

TEST(mesh_check, DuplicatedHexPutsFacesInThreeHexes) {
  Pair p;
  p.in.hexes.push_back(p.in.hexes[0]);  // cell (2,2,2): 3 faces inside the block, 3 on its surface
  p.in.region.push_back(kInside);
  const MeshCheck c = check_mesh(p.in, &p.out, nullptr);
  EXPECT_FALSE(c.ok);
  EXPECT_EQ(c.inside.nonmanifold_faces, 3u);   // original, copy, inside neighbour
  EXPECT_EQ(c.inside.orientation_errors, 3u);  // original and copy, both facing out
  EXPECT_EQ(c.combined->overlap_faces, 3u);    // original, copy, outside neighbour
  EXPECT_FALSE(c.combined->volume_ok);
  EXPECT_TRUE(any_message_contains(c, "is in 3 hexes")) << dump(c);

  // Alone, without the outside mesh, the duplicate is still an error.
  const MeshCheck alone = check_mesh(p.in, nullptr, nullptr);
  EXPECT_FALSE(alone.ok);
  EXPECT_EQ(alone.inside.nonmanifold_faces, 3u);
}

// The union's face counts as the definition states them, by grouping every face of both meshes
// by its 4 corner coordinates (not by point ids, as the checker does, and not only the faces whose
// corners both meshes have, as the checker's union pass does): a face in one hex of the union and
// not on the box is a gap; a face in hexes of both meshes is an interface face when in exactly 2
// (an error unless their cycles run opposite ways), an overlap when in more.
struct UnionReference {
  std::size_t gap = 0, overlap = 0, interface = 0, interface_errors = 0;
};

UnionReference union_reference(const HexMesh& in, const HexMesh& out, const Box& box) {
  using Key = std::array<std::array<double, 3>, 4>;
  struct Seen {
    bool inside;
    std::array<Vec3, 4> cycle;
  };
  std::map<Key, std::vector<Seen>> faces;
  for (const HexMesh* m : {&in, &out})
    for (const Hex& hex : m->hexes)
      for (const auto& f : kHexFaces) {
        Seen s{m == &in, {}};
        Key key;
        for (int i = 0; i < 4; ++i) {
          s.cycle[i] = m->points[hex[f[i]]];
          key[i] = {s.cycle[i].x, s.cycle[i].y, s.cycle[i].z};
        }
        std::sort(key.begin(), key.end());
        faces[key].push_back(s);
      }
  UnionReference r;
  for (const auto& [key, seen] : faces) {
    const auto inside = std::count_if(seen.begin(), seen.end(), [](const Seen& s) { return s.inside; });
    if (seen.size() == 1) {
      bool on_box = false;
      for (int d = 0; d < 3; ++d)
        for (double plane : {box.lo[d], box.hi[d]})
          on_box = on_box || std::all_of(key.begin(), key.end(), [&](const auto& q) { return q[d] == plane; });
      r.gap += on_box ? 0 : 1;
    } else if (inside > 0 && inside < static_cast<std::ptrdiff_t>(seen.size())) {
      if (seen.size() > 2) {
        ++r.overlap;
      } else {
        ++r.interface;
        // Opposite cycles: b runs through a's corners backwards from some start.
        const auto& a = seen[0].cycle;
        const auto& b = seen[1].cycle;
        bool opposite = false;
        for (int k = 0; k < 4; ++k) {
          bool all = true;
          for (int i = 0; i < 4; ++i) all = all && a[i] == b[(k - i + 4) % 4];
          opposite = opposite || all;
        }
        r.interface_errors += opposite ? 0 : 1;
      }
    }
  }
  return r;
}

// The point of `m` at p, added when m has none there (a mesh keeps one point per coordinate).
uint32_t point_at(HexMesh& m, Vec3 p) {
  for (uint32_t i = 0; i < m.points.size(); ++i)
    if (m.points[i] == p) return i;
  m.points.push_back(p);
  return static_cast<uint32_t>(m.points.size() - 1);
}

TEST(mesh_check, UnionCountsEqualAGroupingOfEveryFaceByCoordinates) {
  // Random damage to a ball split out of a 6^3 grid: hexes removed, duplicated, copied into the
  // other mesh, turned inside out, and points moved; every count of the union pass must equal
  // the reference's, with the damage anywhere (along the interface or far from it).
  const CellGrid g = ball_grid(6, 2.2);
  const Box box{{0, 0, 0}, {6, 6, 6}};
  std::mt19937_64 rng(20261126);
  std::size_t nonzero = 0;
  for (int trial = 0; trial < 300; ++trial) {
    HexMesh mesh[2] = {build_mesh(g, true, {1, {0, 0, 0}, rng()}), build_mesh(g, false, {1, {0, 0, 0}, rng()})};
    const int edits = 1 + static_cast<int>(rng() % 3);
    for (int e = 0; e < edits; ++e) {
      HexMesh& m = mesh[rng() % 2];
      HexMesh& other = &m == &mesh[0] ? mesh[1] : mesh[0];
      if (m.hexes.empty()) continue;
      const std::size_t h = rng() % m.hexes.size();
      switch (rng() % 5) {
        case 0:  // removed
          m.hexes.erase(m.hexes.begin() + static_cast<std::ptrdiff_t>(h));
          m.region.pop_back();
          break;
        case 1:  // duplicated in its own mesh
          m.hexes.push_back(m.hexes[h]);
          m.region.push_back(m.region[0]);
          break;
        case 2: {  // copied into the other mesh, on that mesh's points
          Hex copy;
          for (int c = 0; c < 8; ++c) copy[c] = point_at(other, m.points[m.hexes[h][c]]);
          other.hexes.push_back(copy);
          other.region.push_back(other.region.empty() ? kOutside : other.region[0]);
          break;
        }
        case 3: {  // inside out: bottom and top swapped
          Hex& x = m.hexes[h];
          x = {x[4], x[5], x[6], x[7], x[0], x[1], x[2], x[3]};
          break;
        }
        case 4:  // a corner moved off the lattice
          m.points[m.hexes[h][rng() % 8]].x += 0.25;
          break;
      }
    }
    const MeshCheck c = check_mesh(mesh[0], &mesh[1], &box);
    const UnionReference r = union_reference(mesh[0], mesh[1], box);
    ASSERT_TRUE(c.combined);
    EXPECT_EQ(c.combined->gap_faces, r.gap) << "trial " << trial;
    EXPECT_EQ(c.combined->overlap_faces, r.overlap) << "trial " << trial;
    EXPECT_EQ(c.combined->interface_faces, r.interface) << "trial " << trial;
    EXPECT_EQ(c.combined->interface_errors, r.interface_errors) << "trial " << trial;
    nonzero += r.gap + r.overlap + r.interface_errors > 0;
  }
  EXPECT_GT(nonzero, 250u);  // the damage shows nearly always
}

TEST(mesh_check, RemovedOutsideHexLeavesAGap) {
  {
    // Cell (1,1,1): off the box, its 6 neighbours are all present -> 6 gap faces.
    Pair p;
    const std::size_t h = p.outside_hex_at({1, 1, 1});
    ASSERT_NE(h, SIZE_MAX);
    p.out.hexes.erase(p.out.hexes.begin() + static_cast<std::ptrdiff_t>(h));
    p.out.region.pop_back();
    const MeshCheck c = check_mesh(p.in, &p.out, nullptr);
    EXPECT_FALSE(c.ok);
    EXPECT_EQ(c.combined->gap_faces, 6u) << dump(c);
    EXPECT_FALSE(c.combined->volume_ok);
    EXPECT_NEAR(c.combined->volume_relative_error, 1.0 / 216, 1e-15);
    EXPECT_TRUE(any_message_contains(c, "a gap"));
    EXPECT_EQ(c.error_count, 7u);  // 6 gap faces + the volume
  }
  {
    // Cell (0,1,1) touches the box on one side: 5 gap faces (the box side just disappears).
    Pair p;
    const std::size_t h = p.outside_hex_at({0, 1, 1});
    p.out.hexes.erase(p.out.hexes.begin() + static_cast<std::ptrdiff_t>(h));
    p.out.region.pop_back();
    const MeshCheck c = check_mesh(p.in, &p.out, nullptr);
    EXPECT_EQ(c.combined->gap_faces, 5u);
    EXPECT_FALSE(c.ok);
  }
  {
    // Cell (1,2,2) is next to the inside block: its interface face leaves an inside boundary
    // face off the box that no outside face matches.
    Pair p;
    const std::size_t h = p.outside_hex_at({1, 2, 2});
    p.out.hexes.erase(p.out.hexes.begin() + static_cast<std::ptrdiff_t>(h));
    p.out.region.pop_back();
    const MeshCheck c = check_mesh(p.in, &p.out, nullptr);
    EXPECT_EQ(c.combined->gap_faces, 6u);
    EXPECT_EQ(c.combined->interface_faces, 23u);
    EXPECT_TRUE(any_message_contains(c, "of inside hex")) << dump(c);
  }
}

TEST(mesh_check, ExtraOutsideHexOverlappingTheInsideIsAnError) {
  Pair p;
  // An outside hex on top of inside cell (2,2,2), with its own points at the same coordinates.
  Hex extra;
  for (int c = 0; c < 8; ++c) {
    extra[c] = static_cast<uint32_t>(p.out.points.size());
    p.out.points.push_back(p.in.points[p.in.hexes[0][c]]);
  }
  p.out.hexes.push_back(extra);
  p.out.region.push_back(kOutside);
  const MeshCheck c = check_mesh(p.in, &p.out, nullptr);
  EXPECT_FALSE(c.ok);
  // 3 faces inside the block (inside, inside, extra) and 3 on its surface (inside, outside,
  // extra).
  EXPECT_EQ(c.combined->overlap_faces, 6u) << dump(c);
  EXPECT_FALSE(c.combined->volume_ok);
  EXPECT_TRUE(any_message_contains(c, "overlap"));
  // Each mesh alone is fine: the extra hex's points are new to the outside mesh.
  EXPECT_EQ(c.outside->nonmanifold_faces + c.outside->orientation_errors, 0u);
}

TEST(mesh_check, InvertedHexIsAStructuralError) {
  Pair p;
  Hex& h = p.in.hexes[0];
  std::swap_ranges(h.begin(), h.begin() + 4, h.begin() + 4);  // bottom <-> top
  const MeshCheck c = check_mesh(p.in, &p.out, nullptr);
  EXPECT_FALSE(c.ok);
  EXPECT_EQ(c.inside.inverted_hexes, 1u);
  EXPECT_EQ(c.inside.orientation_errors, 3u);  // its faces now point inwards
  // Its 3 faces on the block's surface are reversed: the 6 edges they share with the
  // neighbours' surface quads are run the same way by both.
  EXPECT_EQ(c.inside.boundary.misoriented_edges, 6u);
  EXPECT_EQ(c.combined->interface_errors, 3u);
  EXPECT_EQ(c.inside.quality.certified, 7u);
  EXPECT_EQ(c.inside.quality.min_scaled_jacobian, -1.0);
  EXPECT_TRUE(any_message_contains(c, "hex 0 is inverted")) << dump(c);
}

TEST(mesh_check, BadIndicesRepeatsAndPointsAreReportedWithoutCrashing) {
  {
    Pair p;
    p.in.hexes[1][5] = static_cast<uint32_t>(p.in.points.size() + 5);
    p.in.hexes[2][3] = UINT32_MAX;
    const MeshCheck c = check_mesh(p.in, &p.out, nullptr);
    EXPECT_FALSE(c.ok);
    EXPECT_EQ(c.inside.bad_index_hexes, 2u);
    EXPECT_EQ(c.inside.quality.count, 6u);
    EXPECT_TRUE(any_message_contains(c, "hex 1 has vertex index")) << dump(c);
  }
  {
    Pair p;
    p.in.hexes[3][6] = p.in.hexes[3][0];
    const MeshCheck c = check_mesh(p.in, &p.out, nullptr);
    EXPECT_FALSE(c.ok);
    EXPECT_EQ(c.inside.repeated_vertex_hexes, 1u);
    EXPECT_TRUE(any_message_contains(c, "hex 3 repeats a vertex"));
  }
  {
    Pair p;
    p.out.points[0].y = std::nan("");
    p.out.points[1].z = std::numeric_limits<double>::infinity();
    const MeshCheck c = check_mesh(p.in, &p.out, nullptr);
    EXPECT_FALSE(c.ok);
    EXPECT_EQ(c.outside->nonfinite_points, 2u);
    EXPECT_TRUE(any_message_contains(c, "outside: point 0 is not finite"));
  }
  {
    Pair p;
    p.in.region.pop_back();
    EXPECT_FALSE(check_mesh(p.in, &p.out, nullptr).ok);
    p.in.region.clear();
    EXPECT_FALSE(check_mesh(p.in, &p.out, nullptr).ok);
    CheckOptions lenient;
    lenient.require_regions = false;
    const MeshCheck c = check_mesh(p.in, &p.out, nullptr, lenient);
    EXPECT_TRUE(c.ok) << dump(c);
    p.in.region.push_back(1);  // a wrong non-zero size is an error either way
    EXPECT_FALSE(check_mesh(p.in, &p.out, nullptr, lenient).inside.region_size_ok);
  }
}

// A run of invalid hexes long enough to fill whole parallel leaves: their leaves measure
// nothing, and must not disturb the bounding box or the sums of the others.
TEST(mesh_check, LeavesOfOnlyInvalidHexesLeaveTheRestIntact) {
  const CellGrid g = ball_grid(20, 6);
  const HexMesh in = build_mesh(g, true);
  HexMesh out = build_mesh(g, false);
  const std::size_t valid = out.hexes.size();
  out.hexes.resize(valid + 20000, Hex{0, 1, 2, 3, 4, 5, 6, UINT32_MAX});
  out.region.resize(out.hexes.size(), kOutside);
  const MeshCheck c = check_mesh(in, &out, nullptr);
  EXPECT_EQ(c.outside->bad_index_hexes, 20000u);
  EXPECT_EQ(c.error_count, 20000u) << dump(c);
  EXPECT_EQ(c.outside->quality.count, valid);
  EXPECT_EQ(c.combined->box.lo, (Vec3{0, 0, 0}));
  EXPECT_EQ(c.combined->box.hi, (Vec3{20, 20, 20}));
  EXPECT_TRUE(c.combined->volume_ok);
  EXPECT_EQ(c.combined->gap_faces, 0u);
}

TEST(mesh_check, OutsideWithoutValidHexesDoesNotStretchTheBox) {
  Pair p;
  for (Hex& h : p.out.hexes) h[0] = UINT32_MAX;
  const MeshCheck c = check_mesh(p.in, &p.out, nullptr);
  EXPECT_EQ(c.combined->box.lo, (Vec3{2, 2, 2}));
  EXPECT_EQ(c.combined->box.hi, (Vec3{4, 4, 4}));
  EXPECT_TRUE(c.combined->volume_ok);  // the inside alone fills its own bounding box
  EXPECT_EQ(c.combined->gap_faces, 0u);
  EXPECT_EQ(c.error_count, p.out.hexes.size());
}

// Two hexes on the same 4 vertices listed in a different cyclic order: different quads.
TEST(mesh_check, SameVerticesInADifferentCyclicOrderIsAMismatch) {
  HexMesh m;
  for (int k = 0; k < 3; ++k) {
    for (int j = 0; j < 2; ++j) {
      for (int i = 0; i < 2; ++i) m.points.push_back({double(i), double(j), double(k)});
    }
  }
  auto id = [](int i, int j, int k) { return static_cast<uint32_t>(i + 2 * j + 4 * k); };
  m.hexes.push_back(
      {id(0, 0, 0), id(1, 0, 0), id(1, 1, 0), id(0, 1, 0), id(0, 0, 1), id(1, 0, 1), id(1, 1, 1), id(0, 1, 1)});
  // The upper hex's bottom lists (1,0,1) and (1,1,1) the other way round: a bow tie.
  m.hexes.push_back(
      {id(0, 0, 1), id(1, 1, 1), id(1, 0, 1), id(0, 1, 1), id(0, 0, 2), id(1, 0, 2), id(1, 1, 2), id(0, 1, 2)});
  m.region = {1, 1};
  const MeshCheck c = check_mesh(m, nullptr, nullptr);
  EXPECT_FALSE(c.ok);
  EXPECT_EQ(c.inside.cyclic_mismatches, 1u);
  EXPECT_TRUE(any_message_contains(c, "different cyclic orders")) << dump(c);
}

// Vertices are matched by exact coordinates with -0 == +0, whatever the point order.
TEST(mesh_check, NegativeZeroMatchesPositiveZero) {
  // The inside block touches the planes x, y, z = 0, where the outside has -0.
  CellGrid g({6, 6, 6});
  for (int k = 0; k < 2; ++k) {
    for (int j = 0; j < 2; ++j) {
      for (int i = 0; i < 2; ++i) g.set(i, j, k);
    }
  }
  HexMesh in = build_mesh(g, true), out = build_mesh(g, false, {1, {}, 9});
  std::size_t flipped = 0;
  for (Vec3& q : out.points) {
    for (int d = 0; d < 3; ++d) {
      if (q[d] == 0) {
        q[d] = -0.0;
        ++flipped;
      }
    }
  }
  ASSERT_GT(flipped, 0u);
  const MeshCheck c = check_mesh(in, &out, nullptr);
  expect_pair_ok(g, c);
  EXPECT_EQ(c.combined->interface_faces, 12u);
  EXPECT_EQ(c.combined->matched_points, 19u);  // 3 x 3 x 3 block corner lattice minus 8 hidden
}

TEST(mesh_check, ExplicitBox) {
  Pair p;
  const Box exact{{0, 0, 0}, {6, 6, 6}};
  const MeshCheck c = check_mesh(p.in, &p.out, &exact);
  EXPECT_TRUE(c.ok) << dump(c);
  EXPECT_TRUE(c.combined->box_given);
  // A larger box: the meshes' outer faces are not on its sides, and the volume falls short.
  const Box larger{{0, 0, 0}, {7, 6, 6}};
  const MeshCheck bad = check_mesh(p.in, &p.out, &larger);
  EXPECT_FALSE(bad.ok);
  EXPECT_EQ(bad.combined->gap_faces, 36u);  // the x = 6 side
  EXPECT_FALSE(bad.combined->volume_ok);
}

TEST(mesh_check, MessagesAreTheFirstFewInElementOrder) {
  Pair p;
  for (Hex& h : p.out.hexes) h[7] = UINT32_MAX;
  CheckOptions options;
  options.max_messages = 5;
  const MeshCheck c = check_mesh(p.in, &p.out, nullptr, options);
  EXPECT_FALSE(c.ok);
  EXPECT_EQ(c.outside->bad_index_hexes, p.out.hexes.size());
  ASSERT_EQ(c.errors.size(), 5u);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(c.errors[i].rfind("outside: hex " + std::to_string(i) + " has vertex index", 0), 0u) << c.errors[i];
  }
  EXPECT_GT(c.error_count, 5u);
  options.max_messages = 0;
  EXPECT_TRUE(check_mesh(p.in, &p.out, nullptr, options).errors.empty());
}

TEST(mesh_check, JsonReport) {
  Pair p;
  const nlohmann::json j = to_json(check_mesh(p.in, &p.out, nullptr));
  EXPECT_EQ(j["ok"], true);
  EXPECT_EQ(j["error_count"], 0);
  EXPECT_TRUE(j["errors"].empty());
  EXPECT_EQ(j["inside"]["hexes"], 8);
  EXPECT_EQ(j["inside"]["quality"]["certified"], 8);
  EXPECT_EQ(j["inside"]["quality"]["min_scaled_jacobian"], 1.0);
  EXPECT_EQ(j["inside"]["boundary"]["euler_characteristic"], 2);
  EXPECT_EQ(j["inside"]["boundary"]["closed_manifold"], true);
  EXPECT_EQ(j["outside"]["hexes"], 208);
  EXPECT_EQ(j["union"]["interface_faces"], 24);
  EXPECT_EQ(j["union"]["box"]["hi"][0], 6.0);
  EXPECT_EQ(j["union"]["volume"], 216.0);

  // An empty mesh: minima over no element are null, not inf (which JSON cannot hold).
  const nlohmann::json e = to_json(check_mesh(HexMesh{}, nullptr, nullptr));
  EXPECT_TRUE(e["inside"]["quality"]["min_scaled_jacobian"].is_null());
  EXPECT_EQ(e["outside"], nullptr);
  EXPECT_FALSE(e.dump().empty());
}

// ---------------------------------------------------------------------------------------------
// Quality statistics: histograms and the per-region split (docs/quality.md).

TEST(mesh_check, HistogramBinsAtTheirEdges) {
  Histogram h;
  for (double e : Histogram::kEdges) h.add(e);  // each edge starts its bin; 1 closes the last
  EXPECT_EQ(h.counts, (std::array<std::size_t, Histogram::kBins>{1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 2}));
  Histogram below_edges;
  for (int i = 1; i < Histogram::kBins; ++i) below_edges.add(std::nextafter(Histogram::kEdges[i], -2.0));
  EXPECT_EQ(below_edges.counts, (std::array<std::size_t, Histogram::kBins>{1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 0}));
  Histogram outside;
  for (double v : {-1.5, std::nextafter(-1.0, -2.0), std::nan(""), std::nextafter(1.0, 2.0), 27.0}) outside.add(v);
  EXPECT_EQ(outside.below, 3u);
  EXPECT_EQ(outside.above, 2u);
  EXPECT_EQ(outside.total(), 5u);
  h.join(outside);
  EXPECT_EQ(h.total(), 17u);
}

// Disjoint hexes x += s y (each its own 8 points): scaled Jacobian 1 / sqrt(1 + s^2) at all 9
// points, dihedral angles atan(1/|s|) and 180 - atan(1/|s|), edge ratio sqrt(1 + s^2), det J = 1.
struct ShearedHexes {
  HexMesh mesh;
  std::vector<double> shear;
  void add(double s, int32_t region, double offset) {
    const auto base = static_cast<uint32_t>(mesh.points.size());
    for (Vec3 p : kUnitCubeCorners) mesh.points.push_back(Vec3{p.x + s * p.y + offset, p.y, p.z});
    Hex h;
    for (uint32_t i = 0; i < 8; ++i) h[i] = base + i;
    mesh.hexes.push_back(h);
    mesh.region.push_back(region);
    shear.push_back(s);
  }
};

constexpr double kPi = 3.14159265358979323846;

// The bin of v by its definition, edge by edge.
int bin_of(double v) {
  int i = 0;
  while (i + 1 < Histogram::kBins && v >= Histogram::kEdges[i + 1]) ++i;
  return i;
}

TEST(mesh_check, QualityHistogramsAndRegions) {
  // Scaled Jacobians aimed at every bin from 0 to 1 (and 1 itself), in three regions.
  ShearedHexes m;
  const double targets[] = {0.05, 0.15, 0.25, 0.35, 0.45, 0.55, 0.65, 0.75, 0.85, 0.95, 1.0, 0.62, 0.33};
  const int32_t labels[] = {1, 2, 5};
  for (std::size_t i = 0; i < std::size(targets); ++i)
    m.add(std::sqrt(1 / (targets[i] * targets[i]) - 1), labels[i % 3], 100.0 * static_cast<double>(i));
  const MeshCheck c = check_mesh(m.mesh, nullptr, nullptr);
  ASSERT_TRUE(c.ok) << (c.errors.empty() ? "" : c.errors.front());
  const QualityStats& q = c.inside.quality;
  ASSERT_EQ(q.count, std::size(targets));

  // Expected values per region and overall, from the closed forms.
  struct Expect {
    std::size_t count = 0;
    double min_sj = 2, max_sj = -2, min_angle = 360, max_angle = 0, min_ratio = 1e300, max_ratio = 0;
    std::array<std::size_t, Histogram::kBins> sj{}, bernstein{};
  };
  std::map<int32_t, Expect> per_region;
  Expect all;
  for (std::size_t i = 0; i < m.shear.size(); ++i) {
    const double s = m.shear[i];
    const double sj = 1 / std::sqrt(1 + s * s);
    const double acute = std::atan(1 / s) * 180 / kPi;
    const double ratio = std::sqrt(1 + s * s);
    const double h = (8 + 4 * std::sqrt(1 + s * s)) / 12;  // mean edge
    for (Expect* e : {&per_region[m.mesh.region[i]], &all}) {
      ++e->count;
      e->min_sj = std::min(e->min_sj, sj);
      e->max_sj = std::max(e->max_sj, sj);
      e->min_angle = std::min(e->min_angle, s == 0 ? 90.0 : acute);
      e->max_angle = std::max(e->max_angle, s == 0 ? 90.0 : 180 - acute);
      e->min_ratio = std::min(e->min_ratio, ratio);
      e->max_ratio = std::max(e->max_ratio, ratio);
      ++e->sj[bin_of(sj)];
      ++e->bernstein[bin_of(1 / (h * h * h))];
    }
  }
  auto expect_stats = [](const QualityStats& got, const Expect& e, const std::string& what) {
    EXPECT_EQ(got.count, e.count) << what;
    EXPECT_NEAR(got.min_scaled_jacobian, e.min_sj, 1e-12) << what;
    EXPECT_NEAR(got.max_scaled_jacobian, e.max_sj, 1e-12) << what;
    EXPECT_NEAR(got.min_dihedral_angle, e.min_angle, 1e-9) << what;
    EXPECT_NEAR(got.max_dihedral_angle, e.max_angle, 1e-9) << what;
    EXPECT_NEAR(got.min_edge_ratio, e.min_ratio, 1e-12) << what;
    EXPECT_NEAR(got.max_edge_ratio, e.max_ratio, 1e-12) << what;
    EXPECT_EQ(got.scaled_jacobian_histogram.counts, e.sj) << what;
    EXPECT_EQ(got.bernstein_scaled_histogram.counts, e.bernstein) << what;
    EXPECT_EQ(got.scaled_jacobian_histogram.total(), e.count) << what;
    EXPECT_EQ(got.certified, e.count) << what;
  };
  expect_stats(q, all, "all");
  // The targets were aimed at bins 1..10 (one each, two more in [0.6, 0.7) and [0.3, 0.4)).
  EXPECT_EQ(q.scaled_jacobian_histogram.counts,
            (std::array<std::size_t, Histogram::kBins>{0, 1, 1, 1, 2, 1, 1, 2, 1, 1, 2}));
  ASSERT_EQ(c.inside.regions.size(), 3u);
  EXPECT_FALSE(c.inside.too_many_regions);
  for (std::size_t r = 0; r < 3; ++r) {
    EXPECT_EQ(c.inside.regions[r].region, labels[r]);
    expect_stats(c.inside.regions[r].quality, per_region[labels[r]], "region " + std::to_string(labels[r]));
  }

  // The same hexes in the JSON report.
  const nlohmann::json j = to_json(c);
  const nlohmann::json& jq = j["inside"]["quality"];
  EXPECT_EQ(
      jq["scaled_jacobian_histogram"]["counts"].get<std::vector<std::size_t>>(),
      std::vector<std::size_t>(q.scaled_jacobian_histogram.counts.begin(), q.scaled_jacobian_histogram.counts.end()));
  EXPECT_EQ(jq["scaled_jacobian_histogram"]["edges"].size(), Histogram::kBins + 1u);
  EXPECT_EQ(jq["scaled_jacobian_histogram"]["edges"][2], 0.1);
  EXPECT_EQ(jq["bernstein_scaled_histogram"]["below"], 0);
  EXPECT_EQ(jq["min_dihedral_angle"], q.min_dihedral_angle);
  EXPECT_EQ(jq["max_inverse_condition"], q.max_inverse_condition);
  ASSERT_EQ(j["inside"]["regions"].size(), 3u);
  EXPECT_EQ(j["inside"]["regions"][2]["region"], 5);
  EXPECT_EQ(j["inside"]["regions"][2]["quality"]["count"], per_region[5].count);
}

TEST(mesh_check, InvertedHexesFillTheFirstBin) {
  ShearedHexes m;
  m.add(0, 1, 0);
  m.add(0, 1, 10);
  // Mirror the second hex: scaled Jacobian -1, an error, and the bin [-1, 0).
  for (uint32_t i = 8; i < 16; ++i) m.mesh.points[i].x = -m.mesh.points[i].x;
  const MeshCheck c = check_mesh(m.mesh, nullptr, nullptr);
  EXPECT_FALSE(c.ok);
  EXPECT_EQ(c.inside.inverted_hexes, 1u);
  const QualityStats& q = c.inside.quality;
  EXPECT_EQ(q.scaled_jacobian_histogram.counts[0], 1u);
  EXPECT_EQ(q.scaled_jacobian_histogram.counts[Histogram::kBins - 1], 1u);
  EXPECT_EQ(q.bernstein_scaled_histogram.counts[0], 1u);
  EXPECT_EQ(q.min_scaled_jacobian, -1.0);
  EXPECT_EQ(q.max_dihedral_angle, 270.0);
  EXPECT_EQ(q.min_inverse_condition, -1.0);
  EXPECT_EQ(q.max_inverse_condition, 1.0);
}

TEST(mesh_check, RegionsWithoutLabelsOrTooMany) {
  ShearedHexes m;
  for (std::size_t i = 0; i <= MeshStats::kMaxRegions; ++i)
    m.add(0, static_cast<int32_t>(i) - 7, 2.0 * static_cast<double>(i));
  const MeshCheck many = check_mesh(m.mesh, nullptr, nullptr);
  EXPECT_TRUE(many.ok);
  EXPECT_TRUE(many.inside.too_many_regions);
  EXPECT_TRUE(many.inside.regions.empty());
  EXPECT_TRUE(to_json(many)["inside"]["regions"].is_null());
  EXPECT_EQ(many.inside.quality.count, MeshStats::kMaxRegions + 1);

  m.mesh.region.clear();
  CheckOptions unlabelled;
  unlabelled.require_regions = false;
  const MeshCheck none = check_mesh(m.mesh, nullptr, nullptr, unlabelled);
  EXPECT_TRUE(none.ok);
  EXPECT_FALSE(none.inside.too_many_regions);
  EXPECT_TRUE(none.inside.regions.empty());
  EXPECT_TRUE(to_json(none)["inside"]["regions"].empty());
}

// An 81^3 grid split by a ball (531441 hexes): the counts at the size the mesher makes.
// Its speed is measured by perf/bench_mesh, not here.
TEST(mesh_check, LargeGridPairIsExact) {
  const int n = 81;
  const CellGrid g = ball_grid(n, 0.35 * n);
  const Layout layout{1.0 / n, {0, 0, 0}, 0};
  const HexMesh in = build_mesh(g, true, layout);
  const HexMesh out = build_mesh(g, false, layout);
  expect_pair_ok(g, check_mesh(in, &out, nullptr));
}

}  // namespace
}  // namespace mchex
