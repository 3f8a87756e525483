#include "core/grid/templates.h"

#include <stdexcept>
#include <vector>

#include "core/mesh/cube.h"

namespace mchex {

namespace {

using P = TemplatePoint;

constexpr P pt(int x, int y, int z) {
  return {static_cast<std::int8_t>(x), static_cast<std::int8_t>(y), static_cast<std::int8_t>(z)};
}

// The hex on two quads a (bottom) and b (top, b[i] above a[i]); if the listed order is
// left-handed the quads are walked the other way, so every stored hex has det J > 0 at corner 0
// (and, being certified by the tests, everywhere).
TemplateHex make_hex(const std::array<P, 4>& a, const std::array<P, 4>& b, bool child = false) {
  auto sub = [](P u, P v) { return std::array<long, 3>{u[0] - v[0], u[1] - v[1], u[2] - v[2]}; };
  const auto e1 = sub(a[1], a[0]), e3 = sub(a[3], a[0]), e4 = sub(b[0], a[0]);
  const long det = e1[0] * (e3[1] * e4[2] - e3[2] * e4[1]) - e1[1] * (e3[0] * e4[2] - e3[2] * e4[0]) +
                   e1[2] * (e3[0] * e4[1] - e3[1] * e4[0]);
  if (det == 0) throw std::logic_error("template hex with a flat corner");
  TemplateHex h;
  h.child = child;
  const std::array<int, 4> order = det > 0 ? std::array<int, 4>{0, 1, 2, 3} : std::array<int, 4>{0, 3, 2, 1};
  for (int i = 0; i < 4; ++i) {
    h.corners[i] = a[order[i]];
    h.corners[4 + i] = b[order[i]];
  }
  return h;
}

TemplateHex child_cube(int x, int y, int z) {  // child cube with lowest corner (x, y, z), side 4
  return make_hex({pt(x, y, z), pt(x + 4, y, z), pt(x + 4, y + 4, z), pt(x, y + 4, z)},
                  {pt(x, y, z + 4), pt(x + 4, y, z + 4), pt(x + 4, y + 4, z + 4), pt(x, y + 4, z + 4)}, true);
}

std::vector<TemplateHex> make_cube() {
  return {make_hex({pt(0, 0, 0), pt(12, 0, 0), pt(12, 12, 0), pt(0, 12, 0)},
                   {pt(0, 0, 12), pt(12, 0, 12), pt(12, 12, 12), pt(0, 12, 12)})};
}

// Node template, corner 0 refined: the child cube [0, 4]^3 and three hexes, each on one of the
// child's far faces, meeting along the diagonal from (4, 4, 4) to (12, 12, 12).
std::vector<TemplateHex> make_node() {
  return {child_cube(0, 0, 0),
          make_hex({pt(4, 0, 0), pt(12, 0, 0), pt(12, 12, 0), pt(4, 4, 0)},
                   {pt(4, 0, 4), pt(12, 0, 12), pt(12, 12, 12), pt(4, 4, 4)}),
          make_hex({pt(0, 4, 0), pt(4, 4, 0), pt(12, 12, 0), pt(0, 12, 0)},
                   {pt(0, 4, 4), pt(4, 4, 4), pt(12, 12, 12), pt(0, 12, 12)}),
          make_hex({pt(0, 0, 4), pt(4, 0, 4), pt(4, 4, 4), pt(0, 4, 4)},
                   {pt(0, 0, 12), pt(12, 0, 12), pt(12, 12, 12), pt(0, 12, 12)})};
}

// The 2D edge pattern on a face whose edge t = 0 is refined, in (along, across) coordinates:
// above the three child squares (across 0..4) the quads left, middle, right and top, with the
// two inner points 3/4 of the way across (9 twelfths).
constexpr std::array<std::array<std::array<int, 2>, 4>, 4> kEdgeQuads2D = {{
    {{{0, 4}, {4, 4}, {4, 9}, {0, 12}}},
    {{{4, 4}, {8, 4}, {8, 9}, {4, 9}}},
    {{{8, 4}, {12, 4}, {12, 12}, {8, 9}}},
    {{{4, 9}, {8, 9}, {12, 12}, {0, 12}}},
}};

// Edge template, edge 0-1 (x axis at y = z = 0) refined: three child cubes along it; the rest is
// two sheets of four hexes, one on the face y = 0 and one on z = 0, each the 2D edge pattern of
// its face swept to the diagonal surface y = z, where the face point (x, 0, t) meets (x, t, t).
std::vector<TemplateHex> make_edge() {
  std::vector<TemplateHex> out = {child_cube(0, 0, 0), child_cube(4, 0, 0), child_cube(8, 0, 0)};
  for (int sheet = 0; sheet < 2; ++sheet)
    for (const auto& q : kEdgeQuads2D) {
      std::array<P, 4> face, diagonal;
      for (int i = 0; i < 4; ++i) {
        const int x = q[i][0], t = q[i][1];
        face[i] = sheet == 0 ? pt(x, 0, t) : pt(x, t, 0);
        diagonal[i] = pt(x, t, t);
      }
      out.push_back(make_hex(face, diagonal));
    }
  return out;
}

// Face template, face z = 0 refined: the 3 x 3 child cubes, then on their top (z = 4) a layer of
// nine hexes to the four inner points (i, j, 6), i, j in {4, 8}, and to the side faces' 2D edge
// points at z = 9 (the corner hexes reach the top corners), then three hexes over the middle
// row and column and one top slab. Point layout as in the vanilla face template of
// CMU-CBML/Element-Saving-Hexahedral-3-Refinement-Templates (removeHangingNodeMethod0).
std::vector<TemplateHex> make_face() {
  std::vector<TemplateHex> out;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) out.push_back(child_cube(4 * i, 4 * j, 0));
  auto b = [](int i, int j) { return pt(4 * i, 4 * j, 4); };  // top of the child layer
  auto c = [](int i, int j) { return pt(4 * i, 4 * j, 6); };  // inner points, i, j in {1, 2}
  const P y0a = pt(4, 0, 9), y0b = pt(8, 0, 9), y1a = pt(4, 12, 9), y1b = pt(8, 12, 9);
  const P x0a = pt(0, 4, 9), x0b = pt(0, 8, 9), x1a = pt(12, 4, 9), x1b = pt(12, 8, 9);
  const P t00 = pt(0, 0, 12), t10 = pt(12, 0, 12), t11 = pt(12, 12, 12), t01 = pt(0, 12, 12);
  // Layer on the children.
  out.push_back(make_hex({b(1, 0), b(2, 0), b(2, 1), b(1, 1)}, {y0a, y0b, c(2, 1), c(1, 1)}));
  out.push_back(make_hex({b(1, 1), b(2, 1), b(2, 2), b(1, 2)}, {c(1, 1), c(2, 1), c(2, 2), c(1, 2)}));
  out.push_back(make_hex({b(1, 2), b(2, 2), b(2, 3), b(1, 3)}, {c(1, 2), c(2, 2), y1b, y1a}));
  out.push_back(make_hex({b(0, 0), b(1, 0), b(1, 1), b(0, 1)}, {t00, y0a, c(1, 1), x0a}));
  out.push_back(make_hex({b(0, 1), b(1, 1), b(1, 2), b(0, 2)}, {x0a, c(1, 1), c(1, 2), x0b}));
  out.push_back(make_hex({b(0, 2), b(1, 2), b(1, 3), b(0, 3)}, {x0b, c(1, 2), y1a, t01}));
  out.push_back(make_hex({b(2, 0), b(3, 0), b(3, 1), b(2, 1)}, {y0b, t10, x1a, c(2, 1)}));
  out.push_back(make_hex({b(2, 1), b(3, 1), b(3, 2), b(2, 2)}, {c(2, 1), x1a, x1b, c(2, 2)}));
  out.push_back(make_hex({b(2, 2), b(3, 2), b(3, 3), b(2, 3)}, {c(2, 2), x1b, t11, y1b}));
  // Over the middle column (x = 4..8, from the y = 0 side to the y = 12 side) and beside it.
  out.push_back(make_hex({c(1, 1), c(2, 1), c(2, 2), c(1, 2)}, {y0a, y0b, y1b, y1a}));
  out.push_back(make_hex({x0a, c(1, 1), c(1, 2), x0b}, {t00, y0a, y1a, t01}));
  out.push_back(make_hex({c(2, 1), x1a, x1b, c(2, 2)}, {y0b, t10, t11, y1b}));
  out.push_back(make_hex({y0a, y0b, y1b, y1a}, {t00, t10, t11, t01}));
  return out;
}

struct Tables {
  std::array<std::vector<TemplateHex>, kNumTemplateKinds> hexes;
  std::array<TemplateChoice, 256> choice{};
};

constexpr std::array<std::uint8_t, kNumTemplateKinds> kCanonicalMarks = {0x00, 0x01, 0x03, 0x0F};

const Tables& tables() {
  static const Tables t = [] {
    Tables t;
    t.hexes = {make_cube(), make_node(), make_edge(), make_face()};
    // Every pattern reachable from a canonical one by a rotation; the lowest rotation index wins
    // so that the table is a pure function of kCubeSymmetries.
    for (int k = 0; k < kNumTemplateKinds; ++k)
      for (int r = kNumCubeRotations - 1; r >= 0; --r) {
        std::uint8_t image = 0;
        for (int c = 0; c < 8; ++c)
          if (kCanonicalMarks[k] >> c & 1) image |= static_cast<std::uint8_t>(1u << kCubeSymmetries[r].corner[c]);
        t.choice[image] = {true, static_cast<TemplateKind>(k), static_cast<std::uint8_t>(r)};
      }
    return t;
  }();
  return t;
}

}  // namespace

std::string_view template_name(TemplateKind k) {
  switch (k) {
    case TemplateKind::kCube: return "cube";
    case TemplateKind::kNode: return "node";
    case TemplateKind::kEdge: return "edge";
    case TemplateKind::kFace: return "face";
  }
  return "?";
}

std::span<const TemplateHex> template_hexes(TemplateKind k) { return tables().hexes[static_cast<int>(k)]; }

std::uint8_t template_canonical_marks(TemplateKind k) { return kCanonicalMarks[static_cast<int>(k)]; }

TemplateChoice template_for_marks(std::uint8_t marks) { return tables().choice[marks]; }

TemplatePoint transform_template_point(TemplatePoint p, int symmetry) {
  const CubeSymmetry& g = kCubeSymmetries.at(static_cast<std::size_t>(symmetry));
  TemplatePoint q;
  for (int i = 0; i < 3; ++i) {
    const int v = p[g.axis[i]];
    q[i] = static_cast<std::int8_t>((g.flip >> i & 1) ? kTemplateUnits - v : v);
  }
  return q;
}

}  // namespace mchex
