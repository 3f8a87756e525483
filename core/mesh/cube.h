// The unit cube's corners, edges and 48 symmetries: the one table of cube topology that the
// grid (octree, templates, cell types, complex topology) and MC33 classification share.
//
// Conventions (used everywhere in the project):
//   corners   VTK hexahedron / paper Eq. 8 order: 0(0,0,0) 1(1,0,0) 2(1,1,0) 3(0,1,0)
//             4(0,0,1) 5(1,0,1) 6(1,1,1) 7(0,1,1);
//   edges     paper Table 1, points 1..12 stored 0-based; the crossing parameter s on an edge is
//             measured from its first-listed corner;
//   faces     2k + v is the face {p : p[k] = v}: x=0, x=1, y=0, y=1, z=0, z=1 (core/mesh/hex_faces.h).
#pragma once

#include <array>
#include <cstdint>

namespace mchex {

// ---- Cube topology ---------------------------------------------------------------------------

// Corner coordinates in the paper's Eq. 8 order.
inline constexpr std::array<std::array<int, 3>, 8> kCubeCorners = {
    {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}}};

// The 12 edges in the order of the paper's Table 1 (its points 1..12), each from the corner where
// s = 0 to the corner where s = 1: point i lies at (1 - s_i) * corner[a] + s_i * corner[b].
// clang-format off
inline constexpr std::array<std::array<int, 2>, 12> kCubeEdges = {{
    {0, 1}, {0, 3}, {0, 4}, {1, 2}, {1, 5}, {3, 2},
    {2, 6}, {3, 7}, {4, 5}, {4, 7}, {5, 6}, {7, 6}}};
// clang-format on

// ---- The 48 symmetries of the cube -----------------------------------------------------------

// A symmetry maps the point p of the unit cube to p' with p'[i] = p[axis[i]], or 1 - p[axis[i]]
// where bit i of `flip` is set. Everything else is derived from that map (never typed by hand):
// corner[c] is the corner that corner c goes to, edge[e] / face[f] likewise, and bit e of
// edge_reversed says that edge e's first corner goes to the *second* corner of edge[e], so a
// crossing parameter s on edge e becomes 1 - s on edge[e].
struct CubeSymmetry {
  std::array<std::uint8_t, 3> axis{};
  std::uint8_t flip = 0;
  std::array<std::uint8_t, 8> corner{};
  std::array<std::uint8_t, 12> edge{};
  std::uint16_t edge_reversed = 0;
  std::array<std::uint8_t, 6> face{};
  std::uint8_t inverse = 0;  // index of the inverse symmetry in kCubeSymmetries
  bool reflection = false;   // determinant -1: maps right-handed hexes to left-handed ones
};

inline constexpr int kNumCubeSymmetries = 48;
inline constexpr int kNumCubeRotations = 24;  // indices 0..23 are rotations, 24..47 reflections

namespace detail {

constexpr int cube_corner_index(int x, int y, int z) { return 4 * z + (y ? (x ? 2 : 3) : (x ? 1 : 0)); }

constexpr int cube_edge_index(int a, int b) {
  for (int e = 0; e < 12; ++e)
    if ((kCubeEdges[e][0] == a && kCubeEdges[e][1] == b) || (kCubeEdges[e][0] == b && kCubeEdges[e][1] == a)) return e;
  return -1;
}

constexpr CubeSymmetry make_cube_symmetry(std::array<int, 3> axis, int flip) {
  CubeSymmetry g;
  for (int i = 0; i < 3; ++i) g.axis[i] = static_cast<std::uint8_t>(axis[i]);
  g.flip = static_cast<std::uint8_t>(flip);
  // Determinant of the signed permutation: the permutation's parity times one -1 per flip.
  const int inversions = (axis[0] > axis[1]) + (axis[0] > axis[2]) + (axis[1] > axis[2]);
  int sign = inversions % 2 ? -1 : 1;
  for (int i = 0; i < 3; ++i)
    if (flip >> i & 1) sign = -sign;
  g.reflection = sign < 0;
  for (int c = 0; c < 8; ++c) {
    int p[3] = {};
    for (int i = 0; i < 3; ++i) {
      const int v = kCubeCorners[c][axis[i]];
      p[i] = (flip >> i & 1) ? 1 - v : v;
    }
    g.corner[c] = static_cast<std::uint8_t>(cube_corner_index(p[0], p[1], p[2]));
  }
  for (int e = 0; e < 12; ++e) {
    const int a = g.corner[kCubeEdges[e][0]], b = g.corner[kCubeEdges[e][1]];
    const int img = cube_edge_index(a, b);
    g.edge[e] = static_cast<std::uint8_t>(img);
    if (kCubeEdges[img][0] != a) g.edge_reversed |= static_cast<std::uint16_t>(1u << e);
  }
  // Face 2k + v is the face {p : p[k] = v}; its image is the face where output axis i reads
  // input axis k, on side v or 1 - v.
  for (int f = 0; f < 6; ++f) {
    const int k = f / 2, v = f % 2;
    for (int i = 0; i < 3; ++i)
      if (axis[i] == k) g.face[f] = static_cast<std::uint8_t>(2 * i + ((flip >> i & 1) ? 1 - v : v));
  }
  return g;
}

constexpr std::array<CubeSymmetry, 48> make_cube_symmetries() {
  constexpr std::array<std::array<int, 3>, 6> perms = {
      {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}}};
  std::array<CubeSymmetry, 48> out{};
  int n = 0;
  // Rotations first (identity at index 0), then the reflections, each in (permutation, flip)
  // order, so that "prefer a rotation, then the lowest index" is a plain index comparison.
  for (int want_reflection = 0; want_reflection < 2; ++want_reflection)
    for (const auto& p : perms)
      for (int flip = 0; flip < 8; ++flip) {
        const CubeSymmetry g = make_cube_symmetry(p, flip);
        if (g.reflection == (want_reflection != 0)) out[n++] = g;
      }
  for (int i = 0; i < 48; ++i)
    for (int j = 0; j < 48; ++j) {
      bool identity = true;
      for (int c = 0; c < 8; ++c) identity = identity && out[j].corner[out[i].corner[c]] == c;
      if (identity) out[i].inverse = static_cast<std::uint8_t>(j);
    }
  return out;
}

}  // namespace detail

inline constexpr std::array<CubeSymmetry, kNumCubeSymmetries> kCubeSymmetries = detail::make_cube_symmetries();

}  // namespace mchex
