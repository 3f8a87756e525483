// The 3-regular polyhedra that cutting makes and midpoint subdivision consumes (paper Definition
// 4.2): the data type alone, so that the offsets, subdivision and repair need not include the
// cutter (core/cutting/polyhedra.h).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "core/base/geometry.h"

namespace mchex {

// A point of a cut cell, by what it is in the cell, so that later stages can share points
// between the polyhedra of one cell and between neighbouring cells: keys 0..7 are the cell
// corners (VTK order), 8 + e is the crossing on edge e (Table 1, 0-based, kCubeEdges).
using CellPointKey = std::uint8_t;
constexpr CellPointKey corner_key(int corner) { return static_cast<CellPointKey>(corner); }
constexpr CellPointKey crossing_key(int edge) { return static_cast<CellPointKey>(8 + edge); }
constexpr bool is_corner_key(CellPointKey k) { return k < 8; }
constexpr int key_edge(CellPointKey k) { return k - 8; }  // for crossing keys

struct Polyhedron {
  std::vector<Vec3> points;
  std::vector<CellPointKey> keys;                 // keys[i] identifies points[i] in the cell
  std::vector<std::vector<std::uint32_t>> faces;  // indices into points, CCW seen from outside
  int region_sign = 0;                            // +1 inside (f > 0), -1 outside, as CellRegion::sign
  std::uint8_t corners = 0;                       // bit c <=> cell corner c is a vertex (the region's corners)
  // How many of `faces` come first and are pieces of cell faces; the rest are isosurface loops.
  std::uint32_t num_cell_face_pieces = 0;
  // Where midpoint subdivision puts the volume centre when the mean of the vertices is not
  // certified: set by cut_cell from the volume-centre offset table (core/cutting/volume_centre_offset.h,
  // paper Section 5, Eq. 14), empty otherwise (midpoint_subdivide then takes the vertex mean).
  std::optional<Vec3> volume_centre;
};

}  // namespace mchex
