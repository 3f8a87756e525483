// The vertex-based 3-refinement templates (core/grid/templates.h) and the cell-type table derived from
// them (core/grid/cell_types.h), against facts independent of the table: the hex and marking counts
// and worst scaled Jacobians published for the set (docs/templates.md), volumes, face matching,
// split edges at thirds, the Bernstein certificate of every hex in every rotation, one face pattern
// per face marking, and conformity of every pair of face neighbours (exhaustive over the 2^12
// markings of two cells).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <map>
#include <set>
#include <vector>

#include "core/cutting/mc33.h"
#include "core/grid/cell_types.h"
#include "core/grid/templates.h"
#include "core/mesh/quality.h"

namespace mchex {
namespace {

using Key = std::array<int, 3>;
using Face = std::array<Key, 4>;

constexpr int U = kTemplateUnits;

// The cell's marking as its template's canonical marks moved by the chosen rotation would give:
// used to derive each template's marking from the table alone.
std::uint8_t rotated_marks(std::uint8_t marks, int r) {
  std::uint8_t out = 0;
  for (int c = 0; c < 8; ++c)
    if (marks >> c & 1) out |= static_cast<std::uint8_t>(1u << kCubeSymmetries[r].corner[c]);
  return out;
}

// Integer hex (template units, possibly offset) -> its 6 faces as sorted corner sets.
std::array<Face, 6> faces_of(const std::array<Key, 8>& h) {
  std::array<Face, 6> out;
  constexpr int f[6][4] = {{0, 4, 7, 3}, {1, 2, 6, 5}, {0, 1, 5, 4}, {3, 7, 6, 2}, {0, 3, 2, 1}, {4, 5, 6, 7}};
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 4; ++j) out[i][j] = h[f[i][j]];
    std::sort(out[i].begin(), out[i].end());
  }
  return out;
}

HexCorners to_corners(const std::array<Key, 8>& h) {
  HexCorners c;
  for (int i = 0; i < 8; ++i) c[i] = {double(h[i][0]), double(h[i][1]), double(h[i][2])};
  return c;
}

// A set of integer hexes tiles the box [lo, hi] conformingly: every hex certified positive,
// volumes add up, every face is in one or two hexes, and a face in one hex lies on the box.
void expect_conforming_tiling(const std::vector<std::array<Key, 8>>& hexes, Key lo, Key hi, const std::string& where) {
  std::map<Face, int> count;
  double volume = 0;
  for (const auto& h : hexes) {
    const HexCorners c = to_corners(h);
    EXPECT_TRUE(bernstein_certified(c)) << where;
    volume += hex_volume(c);
    for (const Face& f : faces_of(h)) ++count[f];
  }
  double box = 1;
  for (int d = 0; d < 3; ++d) box *= hi[d] - lo[d];
  EXPECT_NEAR(volume, box, 1e-9 * box) << where;
  for (const auto& [f, n] : count) {
    EXPECT_LE(n, 2) << where;
    if (n == 1) {
      bool on_side = false;
      for (int d = 0; d < 3; ++d)
        for (int side : {lo[d], hi[d]})
          on_side = on_side || std::all_of(f.begin(), f.end(), [&](const Key& k) { return k[d] == side; });
      EXPECT_TRUE(on_side) << where << ": a face inside the box belongs to one hex only (hanging node)";
    }
  }
}

std::array<Key, 8> placed(const TemplateHex& h, int rotation, Key origin) {
  std::array<Key, 8> out;
  for (int c = 0; c < 8; ++c) {
    const TemplatePoint p = transform_template_point(h.corners[c], rotation);
    for (int d = 0; d < 3; ++d) out[c][d] = origin[d] + p[d];
  }
  return out;
}

TEST(templates, HexCountsAndMarkingsPerTemplateAsPublished) {
  // Tong & Zhang's vertex-based set (docs/templates.md): hexes per template by source id, and how
  // many of the 256 markings each one serves.
  const std::map<int, int> hexes = {{1, 1},  {2, 5},   {3, 13},  {4, 14},  {5, 37},  {6, 32},  {7, 27}, {8, 27},
                                    {9, 13}, {10, 39}, {11, 40}, {12, 43}, {13, 57}, {14, 68}, {15, 27}};
  const std::map<int, int> markings = {{1, 35}, {2, 36},  {3, 6},   {4, 48},  {5, 12}, {6, 16}, {7, 12}, {8, 12},
                                       {9, 6},  {10, 24}, {11, 24}, {12, 12}, {13, 4}, {14, 8}, {15, 1}};
  std::map<int, int> got_hexes, got_markings;
  for (int t = 0; t < kNumTemplates; ++t) got_hexes[template_source_id(t)] = static_cast<int>(template_hexes(t).size());
  for (int m = 0; m < 256; ++m) ++got_markings[template_source_id(template_for_marks(static_cast<std::uint8_t>(m)).t)];
  EXPECT_EQ(got_hexes, hexes);
  EXPECT_EQ(got_markings, markings);
  // Only the uniform template's hexes are child cubes, and they are 1/3 of the leaf.
  for (int t = 0; t < kNumTemplates; ++t)
    for (const TemplateHex& h : template_hexes(t)) {
      EXPECT_EQ(h.child, t == kUniformTemplate);
      if (h.child) {
        EXPECT_NEAR(hex_volume(template_hex_corners(h)), 1.0 / 27, 1e-15);
      }
    }
}

TEST(templates, EveryMarkingGetsTheTemplateOfItsSplitEdges) {
  for (int m = 0; m < 256; ++m) {
    const TemplateChoice c = template_for_marks(static_cast<std::uint8_t>(m));
    ASSERT_LT(c.t, kNumTemplates);
    ASSERT_LT(c.rotation, kNumCubeRotations);
    EXPECT_EQ(split_edges(rotated_marks(template_canonical_marks(c.t), c.rotation)),
              split_edges(static_cast<std::uint8_t>(m)))
        << "marking " << m;
  }
  // A marking that splits no edge (no two marks on one edge) keeps the leaf whole.
  EXPECT_EQ(template_for_marks(0x41).t, 0);  // opposite corners
  EXPECT_EQ(template_for_marks(0x5A).t, 0);  // the 4 corners of a tetrahedron
  EXPECT_EQ(template_name(template_for_marks(0xFF).t), "uniform");
  EXPECT_EQ(template_name(template_for_marks(0xDD).t), "concave-edge");    // 6 marks: two adjacent faces
  EXPECT_EQ(template_name(template_for_marks(0xFD).t), "concave-corner");  // 7 marks
}

TEST(templates, EachTemplateTilesItsCellInEveryRotationAndEveryHexIsCertified) {
  for (int t = 0; t < kNumTemplates; ++t)
    for (int r = 0; r < kNumCubeRotations; ++r) {
      std::vector<std::array<Key, 8>> hexes;
      for (const TemplateHex& h : template_hexes(t)) hexes.push_back(placed(h, r, {0, 0, 0}));
      expect_conforming_tiling(hexes, {0, 0, 0}, {U, U, U},
                               std::string(template_name(t)) + " rotation " + std::to_string(r));
    }
}

// Boundary points are sixtieths of the leaf (the octree keys them by integers), and the points on a
// leaf edge are its ends plus, exactly when both ends are marked, the points at 1/3 and 2/3.
TEST(templates, BoundaryPointsAreSixtiethsAndSplitEdgesAreCutAtThirds) {
  for (int t = 0; t < kNumTemplates; ++t) {
    const std::uint16_t split = split_edges(template_canonical_marks(t));
    std::array<std::set<int>, 12> on_edge;
    for (const TemplateHex& h : template_hexes(t))
      for (const TemplatePoint& p : h.corners) {
        if (on_leaf_boundary(p)) {
          for (int d = 0; d < 3; ++d) EXPECT_EQ(p[d] % (U / kTemplateBoundaryUnits), 0) << template_name(t);
        }
        for (int e = 0; e < 12; ++e) {
          const auto& a = kCubeCorners[kCubeEdges[e][0]];
          const auto& b = kCubeCorners[kCubeEdges[e][1]];
          int along = -1;
          bool on = true;
          for (int d = 0; d < 3; ++d)
            if (a[d] != b[d]) along = d;
            else on = on && p[d] == a[d] * U;
          if (on) on_edge[e].insert(a[along] == 0 ? p[along] : U - p[along]);
        }
      }
    const std::set<int> whole{0, U}, thirds{0, U / 3, 2 * U / 3, U};
    for (int e = 0; e < 12; ++e)
      EXPECT_EQ(on_edge[e], (split >> e & 1) ? thirds : whole) << template_name(t) << " edge " << e;
  }
}

TEST(templates, WorstCornerScaledJacobianAsPublished) {
  // docs/templates.md: per template, the minimum corner scaled Jacobian of an exact re-evaluation of
  // the published coordinates; the set's minimum is the 0.2346 its authors report.
  const std::map<int, double> published = {{1, 1.0},    {2, 0.451},  {3, 0.338},  {4, 0.273},  {5, 0.235},
                                           {6, 0.241},  {7, 0.235},  {8, 0.235},  {9, 0.451},  {10, 0.235},
                                           {11, 0.235}, {12, 0.241}, {13, 0.241}, {14, 0.241}, {15, 1.0}};
  double worst = 1;
  for (int t = 0; t < kNumTemplates; ++t) {
    double w = 1;
    for (const TemplateHex& h : template_hexes(t)) w = std::min(w, scaled_jacobian(template_hex_corners(h)));
    EXPECT_NEAR(w, published.at(template_source_id(t)), 1e-3) << template_name(t);
    worst = std::min(worst, w);
  }
  EXPECT_NEAR(worst, 0.2346, 1e-4);
  std::printf("worst corner scaled Jacobian of the set: %.4f\n", worst);
}

// Ids 7 and 8 are mirror images (docs/templates.md): a reflection of one is the other under a
// rotation, and no rotation maps one onto itself mirrored, which is why a table of rotations needs both.
TEST(templates, TheChiralPairAreMirrorImages) {
  auto mirrored_marks = [](std::uint8_t m) {  // x -> 1 - x: corner (a, b, c) -> (1 - a, b, c)
    std::uint8_t out = 0;
    for (int c = 0; c < 8; ++c)
      if (m >> c & 1)
        for (int d = 0; d < 8; ++d)
          if (kCubeCorners[d][0] == 1 - kCubeCorners[c][0] && kCubeCorners[d][1] == kCubeCorners[c][1] &&
              kCubeCorners[d][2] == kCubeCorners[c][2])
            out |= static_cast<std::uint8_t>(1u << d);
    return out;
  };
  int seven = -1, eight = -1;
  for (int t = 0; t < kNumTemplates; ++t) {
    if (template_source_id(t) == 7) seven = t;
    if (template_source_id(t) == 8) eight = t;
  }
  ASSERT_GE(seven, 0);
  ASSERT_GE(eight, 0);
  EXPECT_EQ(template_for_marks(mirrored_marks(template_canonical_marks(seven))).t, eight);
  EXPECT_EQ(template_for_marks(mirrored_marks(template_canonical_marks(eight))).t, seven);
}

// Two cells side by side (x in [0, U] and [U, 2U]) with marks on their 12 vertices: the two templates
// meet face for face. Exhaustive over all 4096 markings.
TEST(templates, FaceNeighboursConformForEveryMarking) {
  // Vertex (a, b, c), a in {0, 1, 2}, b, c in {0, 1}: bit a + 3 * (b + 2 * c).
  for (int marks = 0; marks < 4096; ++marks) {
    std::array<std::uint8_t, 2> cell_marks{};
    for (int cell = 0; cell < 2; ++cell)
      for (int corner = 0; corner < 8; ++corner) {
        const int a = cell + kCubeCorners[corner][0], b = kCubeCorners[corner][1], c = kCubeCorners[corner][2];
        if (marks >> (a + 3 * (b + 2 * c)) & 1) cell_marks[cell] |= static_cast<std::uint8_t>(1u << corner);
      }
    const TemplateChoice t0 = template_for_marks(cell_marks[0]), t1 = template_for_marks(cell_marks[1]);
    std::vector<std::array<Key, 8>> hexes;
    for (const TemplateHex& h : template_hexes(t0.t)) hexes.push_back(placed(h, t0.rotation, {0, 0, 0}));
    for (const TemplateHex& h : template_hexes(t1.t)) hexes.push_back(placed(h, t1.rotation, {U, 0, 0}));
    expect_conforming_tiling(hexes, {0, 0, 0}, {2 * U, U, U}, "marks " + std::to_string(marks));
    if (HasFailure()) return;
  }
}

// The invariant the conformity of the complex rests on (core/grid/templates.h): the quads a template
// puts on a cell face depend only on that face's 4 corner marks. Checked directly on every face
// of every marking, independently of which template or rotation produced it: the face's quads and
// marks, moved by the symmetry of the square that puts the marks in a canonical position, must be
// one pattern per mark class, and the pattern must be invariant under the symmetries that fix its
// marks (else the two cells sharing the face could pick mirror images).
TEST(templates, FacePatternDependsOnlyOnItsFourCornerMarks) {
  using P2 = std::array<int, 2>;
  using Quad2 = std::array<P2, 4>;
  struct Pattern {
    int marks = 0;             // bit u + 2 v for the face corner (U u, U v)
    std::vector<Quad2> quads;  // each quad's corners sorted, the list sorted
    bool operator==(const Pattern&) const = default;
  };
  // The 8 symmetries of the square [0, U]^2: optional swap of (u, v), then optional flips.
  auto move = [](P2 p, int g) {
    if (g & 4) std::swap(p[0], p[1]);
    if (g & 1) p[0] = U - p[0];
    if (g & 2) p[1] = U - p[1];
    return p;
  };
  auto moved = [&](const Pattern& a, int g) {
    Pattern b;
    for (int c = 0; c < 4; ++c)
      if (a.marks >> c & 1) {
        const P2 q = move({U * (c & 1), U * (c >> 1)}, g);
        b.marks |= 1 << (q[0] / U + 2 * (q[1] / U));
      }
    for (Quad2 q : a.quads) {
      for (P2& p : q) p = move(p, g);
      std::sort(q.begin(), q.end());
      b.quads.push_back(q);
    }
    std::sort(b.quads.begin(), b.quads.end());
    return b;
  };
  std::map<int, Pattern> by_class;  // canonical marks -> canonical pattern
  int faces = 0;
  for (int m = 0; m < 256; ++m) {
    const std::uint8_t cell_marks = static_cast<std::uint8_t>(m);
    const TemplateChoice choice = template_for_marks(cell_marks);
    std::vector<std::array<Key, 8>> hexes;
    for (const TemplateHex& h : template_hexes(choice.t)) hexes.push_back(placed(h, choice.rotation, {0, 0, 0}));
    for (int axis = 0; axis < 3; ++axis)
      for (int side : {0, U}) {
        const int ua = (axis + 1) % 3 < (axis + 2) % 3 ? (axis + 1) % 3 : (axis + 2) % 3;
        const int va = 3 - axis - ua;
        Pattern f;
        for (int c = 0; c < 8; ++c)
          if (kCubeCorners[c][axis] * U == side && (cell_marks >> c & 1))
            f.marks |= 1 << (kCubeCorners[c][ua] + 2 * kCubeCorners[c][va]);
        for (const auto& h : hexes)
          for (const Face& q : faces_of(h))
            if (std::all_of(q.begin(), q.end(), [&](const Key& p) { return p[axis] == side; })) {
              Quad2 q2;
              for (int i = 0; i < 4; ++i) q2[i] = {q[i][ua], q[i][va]};
              std::sort(q2.begin(), q2.end());
              f.quads.push_back(q2);
            }
        std::sort(f.quads.begin(), f.quads.end());
        ++faces;
        for (int g = 0; g < 8; ++g)
          if (moved(f, g).marks == f.marks) {
            EXPECT_EQ(moved(f, g).quads, f.quads) << "marking " << m << " axis " << axis << " side " << side;
          }
        Pattern best = f;
        for (int g = 1; g < 8; ++g)
          if (moved(f, g).marks < best.marks) best = moved(f, g);
        const auto it = by_class.emplace(best.marks, best).first;
        EXPECT_EQ(it->second, best) << "marking " << m << ": face marks " << best.marks
                                    << " have two different face patterns";
      }
  }
  EXPECT_EQ(faces, 256 * 6);
  // core/grid/templates.h's patterns: no split edge (no mark, one corner, two diagonal corners) one
  // quad; one split edge (two adjacent corners, canonical marks 3) 4; two (three marks) 11; all 9.
  std::map<int, std::size_t> counts;
  for (const auto& [m, p] : by_class) counts[m] = p.quads.size();
  EXPECT_EQ(counts, (std::map<int, std::size_t>{{0, 1}, {1, 1}, {3, 4}, {6, 1}, {7, 11}, {15, 9}}));
}

// The type table (core/grid/cell_types.h): 50 shapes up to orientation-preserving affine maps and
// rotations (docs/templates.md), a maximal set, every template hex mapped onto its type.
TEST(cell_types, TypesAreAMaximalSetOfTheTemplateHexes) {
  const auto types = cell_types();
  EXPECT_EQ(types.size(), 50u);
  EXPECT_EQ(types[0].name, "single");
  for (const CellType& t : types)
    std::printf("cell type %-16s from %s hex %d\n", t.name.c_str(), std::string(template_name(t.source)).c_str(),
                t.source_hex);
  for (std::size_t a = 0; a < types.size(); ++a)
    for (std::size_t b = 0; b < types.size(); ++b)
      for (int r = 0; r < kNumCubeRotations; ++r)
        if (a != b) {
          EXPECT_FALSE(affinely_equivalent(transform_hex(types[a].corners, r), types[b].corners)) << a << " " << b;
        }
  for (int t = 0; t < kNumTemplates; ++t) {
    const auto hexes = template_hexes(t);
    for (std::size_t h = 0; h < hexes.size(); ++h) {
      const CellTypeMatch m = template_hex_type(t, static_cast<int>(h));
      ASSERT_GE(m.type, 0);
      EXPECT_TRUE(
          affinely_equivalent(transform_hex(types[m.type].corners, m.rotation), template_hex_corners(hexes[h])));
      if (hexes[h].child) {
        EXPECT_EQ(m.type, 0);  // the uniform template's children are cubes
      }
    }
  }
}

TEST(cell_types, AffineEquivalenceRejectsMirrorImagesAndAcceptsAffineImages) {
  const HexCorners node = cell_types()[1].corners;  // a hex of the edge template
  // An affine image with det > 0 is equivalent; a mirror image relabelled to stay right-handed
  // is a different cell unless it has an orientation-reversing affine symmetry.
  HexCorners sheared;
  for (int i = 0; i < 8; ++i) {
    const Vec3 p = node[i];
    sheared[i] = Vec3{2 * p.x + 0.3 * p.y, p.y - 0.2 * p.z, 0.5 * p.z + 0.1 * p.x} + Vec3{5, -1, 2};
  }
  EXPECT_TRUE(affinely_equivalent(node, sheared));
  HexCorners mirrored;
  for (int i = 0; i < 8; ++i) mirrored[i] = Vec3{-sheared[i].x, sheared[i].y, sheared[i].z};
  EXPECT_FALSE(affinely_equivalent(node, mirrored));  // det < 0
}

}  // namespace
}  // namespace mchex
