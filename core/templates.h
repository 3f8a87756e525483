// The standard 3-refinement transition templates (Schneiders 1996/2000, the "vanilla" templates
// whose cells the MCHex paper proves positive: Tong & Zhang 2025, Section 5, Figure 8).
//
// A leaf of the balanced octree (core/octree.h) is replaced by one template chosen by its
// *marked* corners: a corner is marked when it is a corner of a refined cell of the leaf's own
// level, i.e. when finer cells touch the leaf there. The fine cells are continued one layer into
// the leaf (child cubes of a third of its size along the marked corner, edge or face) and the rest
// of the leaf is filled with transition hexes:
//
//   kind   marked corners          made of                      coordinates used (twelfths)
//   cube   none                    the leaf itself              0, 12
//   node   1 corner                1 child cube + 3 hexes       0, 4, 12
//   edge   2 corners of an edge    3 child cubes + 8 hexes      0, 4, 8, 9, 12
//   face   4 corners of a face     9 child cubes + 13 hexes     0, 4, 6, 8, 9, 12
//   any other pattern (2 opposite corners, 3 corners, 6, all 8, ...) has no template: the
//   balancing refines such a leaf into its 27 children instead.
//
// Conformity comes from each cell face's own pattern depending only on which of its 4 corners
// are marked, so the two cells on either side of a face always agree:
//   0 marked      one quad;
//   1 marked      the corner's child square (1/3 x 1/3) and two quads meeting at the far corner
//                 (the "2D node" pattern);
//   2 (an edge)   three child squares along the edge, two points 3/4 of the way across at 1/3
//                 and 2/3 along it, and four quads (the "2D edge" pattern);
//   4             the 3 x 3 child squares.
// The interior levels (1/2 and 3/4 across) are the classic ones (notes/refinement-templates.md;
// the vanilla templates of CMU-CBML/Element-Saving-Hexahedral-3-Refinement-Templates use the
// same points). All coordinates are exact multiples of 1/12 of the leaf's edge, so the octree
// keys every point by integers and neighbours compute bit-identical coordinates.
//
// Concave transitions (paper, Section 2 and Section 7: these templates "only allow convex grid
// depth transitions") have no template here: a leaf with finer neighbours across two adjacent
// faces (6 marks, the concave edge) or three faces around a corner (7 marks, the concave corner)
// is refined (core/octree.h says what that costs). What such templates must satisfy, as far as it
// is established (tests/test_templates.cpp FacePatternDependsOnlyOnItsFourCornerMarks checks the
// first two facts on every face of every template):
//   - a face pattern must be invariant under the symmetries of the square that fix its marks, or
//     the two cells on the face could pick mirror images; the new 3-marked face must therefore be
//     symmetric about its diagonal through the unmarked corner;
//   - parity: a hex mesh of a cell has an even number of boundary quads (6 hexes = 2 inner faces +
//     boundary faces), and every face pattern above has an odd count (1, 3, 7, 9). A concave-corner
//     template has 3 full faces (9 each) and 3 three-marked faces, so the 3-marked face pattern
//     needs an ODD count. The obvious pattern (the 5 child squares along the two refined edges and
//     the 2D node pattern, 3 quads around one inner point, on the remaining [4, 12]^2) has 8, so
//     no concave-corner template can use it (a concave-edge template, with two such faces, could);
//   - keeping the 5 child squares, the remaining hexagon (4,4) (8,4) (12,4) (12,12) (4,12) (4,8)
//     needs an even number of quads, F = 6 / 2 + i - 1 by Euler's formula with i inner points, so
//     i is even; i = 0 is impossible (every split into two quads has three collinear corners), and
//     the diagonal-symmetric layouts with i = 2 are: two points (a, a), (b, b) on the diagonal,
//     6 < a < b < 8 (a kite at (4, 4), two strips, a kite at (12, 12); a = 6.5, b = 7 gives a worst
//     corner angle of about 152 degrees, sine 0.47, and needs 24ths, so kTemplateUnits = 24), or a
//     mirror pair p, q with quads (4,4) (8,4) p (12,12), (8,4) (12,4) (12,12) p and their mirrors
//     (slivers). Dropping child squares at the marked ends b, c (7 quads, 3 inner points) is the
//     other odd option; it needs a corner angle near 180 degrees at the raised point.
// The 3D fill of the concave edge (the box [0, 12] x [4, 12]^2 left by its 15 child cubes, faces:
// 3 x 2 child squares on y = 4 and z = 4, the upper part of the 2D edge pattern on y = 12 and
// z = 12, the 3-marked face's remainder on x = 0 and x = 12) and of the concave corner (the cube
// [4, 12]^3 left by its 19 child cubes) is not designed yet. Both are needed: with a concave-edge
// template alone a coarse block enclosed by finer cells still fills, since its corner leaves
// (7 marks) refine, which gives the leaves along its edges 7 marks, and the corners of what is left
// refine again, layer by layer. The element-saving templates of
// CMU-CBML/Element-Saving-Hexahedral-3-Refinement-Templates (removeHangingNodeMethod1, its types
// 5 and 6 for 3 marks on a face and 6 marks) use other face patterns for ALL marks (their node
// template is 5 hexes), so they cannot be mixed with these; taking them over means replacing
// every template and the cell-type table at once.
//
// Each template is stored once, in a canonical orientation (node at corner 0, edge on corners
// 0-1, face on corners 0-3 = z = 0); a leaf's marked pattern selects the kind and the rotation
// (one of core/mc33.h's 24 cube rotations) that carries the canonical marks onto it.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string_view>

namespace mchex {

enum class TemplateKind : std::uint8_t { kCube, kNode, kEdge, kFace };
inline constexpr int kNumTemplateKinds = 4;
std::string_view template_name(TemplateKind k);

// Template coordinates are integers in [0, kTemplateUnits]: twelfths of the leaf's edge.
inline constexpr int kTemplateUnits = 12;
using TemplatePoint = std::array<std::int8_t, 3>;

struct TemplateHex {
  std::array<TemplatePoint, 8> corners;  // VTK order, right-handed (det J > 0)
  bool child = false;  // a child cube (edge 1/3 of the leaf): a cell of the next level
};

// The hexes of a template in its canonical orientation: child cubes first.
std::span<const TemplateHex> template_hexes(TemplateKind k);

// Canonical marked corners (bit c <=> corner c, VTK order).
std::uint8_t template_canonical_marks(TemplateKind k);

// The template for a leaf with these marked corners: `valid` is false where no template exists
// (the leaf must be refined); otherwise kCube for no marks, and the rotation (an index into
// kCubeSymmetries, < 24) carrying the canonical marks onto `marks`.
struct TemplateChoice {
  bool valid = false;
  TemplateKind kind = TemplateKind::kCube;
  std::uint8_t rotation = 0;
};
TemplateChoice template_for_marks(std::uint8_t marks);

// A canonical template point moved by cube symmetry `symmetry` (kCubeSymmetries index), in the
// same convention as the symmetry's corner map: corner c's point goes to corner g.corner[c]'s.
TemplatePoint transform_template_point(TemplatePoint p, int symmetry);

}  // namespace mchex
