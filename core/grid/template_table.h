// The raw data of the vertex-based 3-refinement templates (core/grid/template_table.cpp, generated
// data: see its prologue for the source). Only core/grid/templates.cpp reads it; everything else
// uses core/grid/templates.h.
#pragma once

#include <array>
#include <cstdint>

namespace mchex::template_table {

using TablePoint = std::array<std::int16_t, 3>;  // 1/14400 of the leaf edge
using TableHex = std::array<std::uint8_t, 8>;    // indices into the template's points
struct TableTemplate {
  int es_id;  // the template's number in the public code (1 .. 15)
  int first_point, points;
  int first_hex, hexes;
  std::uint8_t canonical_marks;  // bit c = corner c (VTK order)
};

inline constexpr int kNumTemplates = 15;
inline constexpr int kNumPoints = 844;
inline constexpr int kNumHexes = 443;

extern const TablePoint kPoints[kNumPoints];
extern const TableHex kHexes[kNumHexes];
extern const TableTemplate kTemplates[kNumTemplates];

}  // namespace mchex::template_table
