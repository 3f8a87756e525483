// The vertex-based 3-refinement transition templates (Tong & Zhang, "Element-Saving Hexahedral
// 3-Refinement Templates", arXiv 2512.14862: the complete set for all 256 corner markings, whose
// coordinates core/grid/template_table.cpp holds). They replace the standard (Schneiders) set, which
// has no template for a concave edge or corner, so each refined region used to fill its bounding
// box level after level (MCHex paper, Section 7); with these, a level's refinement stays within a
// layer of the cells its error marked.
//
// Marks. A corner of a leaf of level L is MARKED when a finer leaf touches it, which in a balanced
// octree is exactly when it is a corner of a refined cell of level L (core/grid/octree.h). A leaf
// EDGE is SPLIT at 1/3 and 2/3 when both of its ends are marked; a mark alone splits nothing. The
// template a leaf gets depends only on its split edges (12 bits), and every one of the 4096 edge
// sets that 256 markings produce is one of the 15 canonical templates below under one of the 24
// rotations (tests/test_templates.cpp checks all 256; ids 7 and 8 are mirror images, so a table of
// rotations needs both).
//
// Conformity comes from each face's pattern depending only on the split edges of that face
// (tests/test_templates.cpp checks every face of every marking against every other):
//   no split edge      one quad;
//   one split edge     4 quads, two inner points 8/15 across at 1/3 and 2/3 along the edge;
//   two split edges    11 quads (an inner square at 1/4, 3/4 and points at 2/15 .. 13/15);
//   four split edges   the 3 x 3 squares at thirds.
// (Two opposite split edges on one face cannot occur: their 4 ends would mark every corner.) With
// the octree's moderate balance (leaves sharing a face or an edge differ by at most one level,
// core/grid/octree.h) a face shared with a finer leaf always has all 4 corners marked (3 x 3), and
// the finer leaf's face on it has at most one mark (one quad), so the grid has no hanging node.
//
//   id  canonical marks  hexes  made of (the source's composition)
//    1  none (and any marking that splits no edge)   1   the leaf
//    2  one edge                                     5   box on the edge + 4 frustums
//    3  one face                                    13   3 x 3 on the face + transition
//    4  3 corners of a face                         14   box + 2 edge + 3 single
//    5  concave edge (6 corners)                    37   column + 2 face + 2 edge
//    6..13  composites (box or column + frustums, each frustum a smaller template)
//   14  concave corner (7 corners)                  68   box + 3 face + 2 composite
//   15  all 8 corners                               27   the leaf's 27 children
// Every template point is an integer number of 1/14400 of the leaf edge, and every point on the
// leaf's boundary a multiple of 240 (1/60 of the edge), so the octree keys boundary points by
// integers and both cells of a face compute them bit for bit; inner points belong to one leaf.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string_view>

namespace mchex {

inline constexpr int kNumTemplates = 15;
// Template coordinates are integers in [0, kTemplateUnits]; on the leaf boundary they are
// multiples of kTemplateUnits / kTemplateBoundaryUnits.
inline constexpr int kTemplateUnits = 14400;
inline constexpr int kTemplateBoundaryUnits = 60;
inline constexpr int kUniformTemplate = kNumTemplates - 1;  // id 15: the 27 children
using TemplatePoint = std::array<std::int16_t, 3>;

struct TemplateHex {
  std::array<TemplatePoint, 8> corners;  // VTK order, right-handed (det J > 0)
  bool child = false;                    // one of the uniform template's child cubes: a cell of the next level
};

// Short names for reports ("single", "edge", "face", ..., "uniform"); t = id - 1.
std::string_view template_name(int t);
// The source's number of the template (1 .. 15), as cited above.
int template_source_id(int t);

// The hexes of a template in its canonical orientation.
std::span<const TemplateHex> template_hexes(int t);

// Canonical marked corners (bit c <=> corner c, VTK order).
std::uint8_t template_canonical_marks(int t);

// Edges with both ends marked (bit e <=> kCubeEdges[e]).
std::uint16_t split_edges(std::uint8_t marks);

// The template for a leaf with these marked corners and the rotation (an index into
// kCubeSymmetries, < 24) carrying its canonical split edges onto the leaf's. Every marking has one.
struct TemplateChoice {
  std::uint8_t t = 0;
  std::uint8_t rotation = 0;
};
TemplateChoice template_for_marks(std::uint8_t marks);

// A canonical template point moved by cube symmetry `symmetry` (kCubeSymmetries index), in the
// same convention as the symmetry's corner map: corner c's point goes to corner g.corner[c]'s.
TemplatePoint transform_template_point(TemplatePoint p, int symmetry);

// Whether a template point lies on the boundary of its leaf.
constexpr bool on_leaf_boundary(const TemplatePoint& p) {
  for (int v : p)
    if (v == 0 || v == kTemplateUnits) return true;
  return false;
}

}  // namespace mchex
