// The standard 3-refinement transition templates (Schneiders 1996/2000, the "vanilla" templates
// whose cells the MCHex paper proves positive: Tong & Zhang 2025, Section 5, Figure 8).
//
// A leaf of the balanced octree (core/grid/octree.h) is replaced by one template chosen by its
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
// The interior levels (1/2 and 3/4 across) are the classic ones (docs/templates.md;
// the vanilla templates of CMU-CBML/Element-Saving-Hexahedral-3-Refinement-Templates use the
// same points). All coordinates are exact multiples of 1/12 of the leaf's edge, so the octree
// keys every point by integers and neighbours compute bit-identical coordinates.
//
// Concave transitions (paper, Sections 2 and 7: these templates "only allow convex grid depth
// transitions") have no template here: a leaf with finer neighbours across two adjacent faces (the
// concave edge, 6 marks) or three faces around a corner (7 marks) is refined (core/grid/octree.h says
// what that costs). Two facts constrain any template added for them, and
// tests/test_templates.cpp FacePatternDependsOnlyOnItsFourCornerMarks checks them on every face:
// a face pattern must be invariant under the square's symmetries that fix its marks (else the two
// cells on a face could pick mirror images), and, since a hex mesh of a cell has an even number
// of boundary quads while every pattern above has an odd count (1, 3, 7, 9), a concave-corner
// template (3 full faces + 3 three-marked faces) needs a three-marked face pattern with an odd
// count: the 5 child squares plus a 3-quad corner fill (8) cannot be it.
// Both are needed at once: the coarse cells enclosed by finer ones always include a corner cell
// (7 marks), refining it gives its neighbour along the enclosed region's edge 7 marks, and so on.
// Where the design stands (checked numerically outside the code base, not built): a concave
// corner exists with these patterns. Three frustums, each the face template's 13 hexes above its child
// cubes pressed into the frustum between a refined face and a face of the cube [4, 12]^3 at the
// unmarked corner (4 thick, slanted sides on the planes x = y, y = z, x = z), and that cube: 40
// hexes, every Bernstein coefficient positive, min corner scaled Jacobian 0.30 with the layer's inner
// points at height 2 over 5 and 9 and its side points at height 3 over 6 and 9. Its
// three-marked face has 9 quads: along each refined edge the layer's side pattern (3 quads to
// the inner points, 1 to the cube's edge), and the cube's face. What blocks is the concave edge:
// its two other faces carry the 2D edge pattern, which puts two coplanar quads (left and top) at
// the cell's unmarked corner; with one quad of the three-marked face there, no hex can take both
// faces on either side (a flat corner), and the arrangements tried there (a fan of three hexes
// around that corner, the cube's face split on its diagonal) each left a degenerate hex. The
// element-saving templates of the paper's authors (CMU-CBML/Element-Saving-Hexahedral-3-
// Refinement-Templates, methods 3 and 4) change the 1- and 2-marked patterns too: the way left.
//
// Each template is stored once, in a canonical orientation (node at corner 0, edge on corners
// 0-1, face on corners 0-3 = z = 0); a leaf's marked pattern selects the kind and the rotation
// (one of core/cutting/mc33.h's 24 cube rotations) that carries the canonical marks onto it.
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
  bool child = false;                    // a child cube (edge 1/3 of the leaf): a cell of the next level
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
