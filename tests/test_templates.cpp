// The standard 3-refinement templates (core/grid/templates.h) and the cell-type table derived from them
// (core/grid/cell_types.h): geometry against independent facts (volumes, face matching, the vertex
// levels of docs/templates.md, the paper's count of 9 basic cells), the Bernstein
// certificate of every template hex, and conformity of every pair of face neighbours whose marks
// admit templates (exhaustive over the 2^12 marks of two cells).
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

std::vector<TemplateKind> kinds() {
  return {TemplateKind::kCube, TemplateKind::kNode, TemplateKind::kEdge, TemplateKind::kFace};
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

TEST(templates, CountsAndVertexLevelsMatchTheNotes) {
  // docs/templates.md: node 1 child + 3, edge 3 + 8, face 9 + 13, and the levels.
  const std::map<TemplateKind, std::pair<int, int>> made_of = {{TemplateKind::kCube, {0, 1}},
                                                               {TemplateKind::kNode, {1, 3}},
                                                               {TemplateKind::kEdge, {3, 8}},
                                                               {TemplateKind::kFace, {9, 13}}};
  const std::map<TemplateKind, std::set<int>> levels = {{TemplateKind::kCube, {0, 12}},
                                                        {TemplateKind::kNode, {0, 4, 12}},
                                                        {TemplateKind::kEdge, {0, 4, 8, 9, 12}},
                                                        {TemplateKind::kFace, {0, 4, 8, 12}}};
  for (TemplateKind k : kinds()) {
    int children = 0, others = 0;
    std::set<int> used, z_used;
    for (const TemplateHex& h : template_hexes(k)) {
      (h.child ? children : others)++;
      for (const TemplatePoint& p : h.corners) {
        used.insert(p[0]);
        used.insert(p[1]);
        z_used.insert(p[2]);
      }
    }
    EXPECT_EQ(children, made_of.at(k).first) << template_name(k);
    EXPECT_EQ(others, made_of.at(k).second) << template_name(k);
    if (k == TemplateKind::kFace) {
      EXPECT_EQ(z_used, (std::set<int>{0, 4, 6, 9, 12}));  // z = 0, 1/3, 1/2, 3/4, 1
      EXPECT_EQ(used, (std::set<int>{0, 4, 8, 12}));       // x, y: thirds
    } else {
      used.insert(z_used.begin(), z_used.end());
      EXPECT_EQ(used, levels.at(k)) << template_name(k);
    }
  }
}

TEST(templates, EachTemplateTilesItsCellAndEveryHexIsCertified) {
  for (TemplateKind k : kinds())
    for (int r = 0; r < kNumCubeRotations; ++r) {
      std::vector<std::array<Key, 8>> hexes;
      for (const TemplateHex& h : template_hexes(k)) hexes.push_back(placed(h, r, {0, 0, 0}));
      expect_conforming_tiling(hexes, {0, 0, 0}, {12, 12, 12},
                               std::string(template_name(k)) + " rotation " + std::to_string(r));
    }
}

TEST(templates, WorstCornerScaledJacobianAsInTheNotes) {
  // docs/templates.md: node ~0.577, edge ~0.485, face ~0.48 (the classic templates' figures).
  std::map<TemplateKind, double> worst;
  for (TemplateKind k : kinds()) {
    double w = 1;
    for (const TemplateHex& h : template_hexes(k)) w = std::min(w, scaled_jacobian(template_hex_corners(h)));
    worst[k] = w;
  }
  EXPECT_NEAR(worst[TemplateKind::kCube], 1.0, 1e-12);
  EXPECT_NEAR(worst[TemplateKind::kNode], 1 / std::sqrt(3.0), 1e-3);
  EXPECT_NEAR(worst[TemplateKind::kEdge], 0.485, 5e-3);
  EXPECT_NEAR(worst[TemplateKind::kFace], 0.48, 1e-2);
  std::printf("worst scaled Jacobian: node %.4f edge %.4f face %.4f\n", worst[TemplateKind::kNode],
              worst[TemplateKind::kEdge], worst[TemplateKind::kFace]);
}

TEST(templates, MarksTableCoversExactlyTheTemplatePatterns) {
  // Independent count: 1 (none) + 8 corners + 12 edges + 6 faces = 27 valid patterns.
  int valid = 0;
  for (int m = 0; m < 256; ++m) {
    const TemplateChoice c = template_for_marks(static_cast<std::uint8_t>(m));
    if (!c.valid) continue;
    ++valid;
    ASSERT_LT(c.rotation, kNumCubeRotations);
    // The rotation carries the canonical marks onto m.
    std::uint8_t image = 0;
    for (int i = 0; i < 8; ++i)
      if (template_canonical_marks(c.kind) >> i & 1)
        image |= static_cast<std::uint8_t>(1u << kCubeSymmetries[c.rotation].corner[i]);
    EXPECT_EQ(image, m);
    const int n = std::popcount(static_cast<unsigned>(m));
    EXPECT_EQ(n, (std::array<int, 4>{0, 1, 2, 4})[static_cast<int>(c.kind)]);
  }
  EXPECT_EQ(valid, 27);
  EXPECT_FALSE(template_for_marks(0x41).valid);  // opposite corners
  EXPECT_FALSE(template_for_marks(0x07).valid);  // three corners of a face
  EXPECT_FALSE(template_for_marks(0xFF).valid);  // all: refine fully
}

// Two cells side by side (x in [0, 12] and [12, 24]) with marks on their 12 vertices: wherever
// both cells have a template, the two templates meet face for face. Exhaustive.
TEST(templates, FaceNeighboursConformForEveryAdmissibleMarking) {
  // Vertex (a, b, c), a in {0, 1, 2}, b, c in {0, 1}: bit a + 3 * (b + 2 * c).
  int pairs = 0;
  for (int marks = 0; marks < 4096; ++marks) {
    std::array<std::uint8_t, 2> cell_marks{};
    for (int cell = 0; cell < 2; ++cell)
      for (int corner = 0; corner < 8; ++corner) {
        const int a = cell + kCubeCorners[corner][0], b = kCubeCorners[corner][1], c = kCubeCorners[corner][2];
        if (marks >> (a + 3 * (b + 2 * c)) & 1) cell_marks[cell] |= static_cast<std::uint8_t>(1u << corner);
      }
    const TemplateChoice t0 = template_for_marks(cell_marks[0]), t1 = template_for_marks(cell_marks[1]);
    if (!t0.valid || !t1.valid) continue;
    ++pairs;
    std::vector<std::array<Key, 8>> hexes;
    for (const TemplateHex& h : template_hexes(t0.kind)) hexes.push_back(placed(h, t0.rotation, {0, 0, 0}));
    for (const TemplateHex& h : template_hexes(t1.kind)) hexes.push_back(placed(h, t1.rotation, {12, 0, 0}));
    expect_conforming_tiling(hexes, {0, 0, 0}, {24, 12, 12}, "marks " + std::to_string(marks));
    if (HasFailure()) return;
  }
  EXPECT_GT(pairs, 100);
}

// The invariant the conformity of the complex rests on (core/grid/templates.h): the quads a template
// puts on a cell face depend only on that face's 4 corner marks. Checked directly on every face
// of every template in every rotation, independently of which template or rotation produced it:
// the face's quads and marks, moved by the symmetry of the square that puts the marks in a
// canonical position, must be one pattern per mark class, and the pattern must be invariant under
// the symmetries that fix its marks (else the two cells sharing the face could pick mirror images).
// Each pattern's quad count is odd (1, 3, 7, 9): a hex mesh of a cell has an even number of
// boundary quads (6 H = 2 interior faces + boundary), so any new face pattern that a template uses
// on an odd number of its faces (e.g. the 3-marked faces of a concave-corner template, 3 of them)
// must have an odd count too.
TEST(templates, FacePatternDependsOnlyOnItsFourCornerMarks) {
  using P2 = std::array<int, 2>;
  using Quad2 = std::array<P2, 4>;
  struct Pattern {
    int marks = 0;             // bit u + 2 v for the face corner (12 u, 12 v)
    std::vector<Quad2> quads;  // each quad's corners sorted, the list sorted
    bool operator==(const Pattern&) const = default;
  };
  // The 8 symmetries of the square [0, 12]^2: optional swap of (u, v), then optional flips.
  auto move = [](P2 p, int g) {
    if (g & 4) std::swap(p[0], p[1]);
    if (g & 1) p[0] = kTemplateUnits - p[0];
    if (g & 2) p[1] = kTemplateUnits - p[1];
    return p;
  };
  auto moved = [&](const Pattern& a, int g) {
    Pattern b;
    for (int c = 0; c < 4; ++c)
      if (a.marks >> c & 1) {
        const P2 q = move({kTemplateUnits * (c & 1), kTemplateUnits * (c >> 1)}, g);
        b.marks |= 1 << (q[0] / kTemplateUnits + 2 * (q[1] / kTemplateUnits));
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
  for (TemplateKind k : kinds())
    for (int r = 0; r < kNumCubeRotations; ++r) {
      std::uint8_t cell_marks = 0;
      for (int c = 0; c < 8; ++c)
        if (template_canonical_marks(k) >> c & 1)
          cell_marks |= static_cast<std::uint8_t>(1u << kCubeSymmetries[r].corner[c]);
      std::vector<std::array<Key, 8>> hexes;
      for (const TemplateHex& h : template_hexes(k)) hexes.push_back(placed(h, r, {0, 0, 0}));
      for (int axis = 0; axis < 3; ++axis)
        for (int side : {0, kTemplateUnits}) {
          const int ua = (axis + 1) % 3 < (axis + 2) % 3 ? (axis + 1) % 3 : (axis + 2) % 3;
          const int va = 3 - axis - ua;
          Pattern f;
          for (int c = 0; c < 8; ++c)
            if (kCubeCorners[c][axis] * kTemplateUnits == side && (cell_marks >> c & 1))
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
          // Invariant under the symmetries that fix the marks.
          for (int g = 0; g < 8; ++g)
            if (moved(f, g).marks == f.marks) {
              EXPECT_EQ(moved(f, g).quads, f.quads)
                  << template_name(k) << " rotation " << r << " axis " << axis << " side " << side;
            }
          // Canonical: the symmetry giving the smallest marks (any one: the pattern is invariant).
          Pattern best = f;
          for (int g = 1; g < 8; ++g)
            if (moved(f, g).marks < best.marks) best = moved(f, g);
          const auto it = by_class.emplace(best.marks, best).first;
          EXPECT_EQ(it->second, best) << template_name(k) << " rotation " << r << ": marks " << best.marks
                                      << " have two different face patterns";
        }
    }
  EXPECT_EQ(faces, 4 * kNumCubeRotations * 6);
  // The classes the four templates use: no mark, one corner, an edge, all four (canonical marks
  // 0, 1, 3, 15), with 1, 3, 7 and 9 quads (core/grid/templates.h's face patterns).
  std::map<int, std::size_t> counts;
  for (const auto& [m, p] : by_class) counts[m] = p.quads.size();
  EXPECT_EQ(counts, (std::map<int, std::size_t>{{0, 1}, {1, 3}, {3, 7}, {15, 9}}));
  for (const auto& [m, n] : counts) EXPECT_EQ(n % 2, 1u) << "face pattern with marks " << m;
}

// The hand classification in core/grid/cell_types.h: cube 1, node 1, edge 3, face 3 = 8 types, one
// fewer than the paper's 9 (reported there). The names record which template each came from.
TEST(cell_types, BasicCellsAreTheHandClassification) {
  const auto types = cell_types();
  std::vector<std::string> names;
  for (const CellType& t : types) names.push_back(t.name);
  EXPECT_EQ(names,
            (std::vector<std::string>{"cube", "node", "edge-1", "edge-2", "edge-3", "face-1", "face-2", "face-3"}));
  // Which template hexes fall into which type (counts per template, hand-derived above).
  std::map<std::pair<TemplateKind, int>, int> per;
  for (TemplateKind k : kinds())
    for (std::size_t h = 0; h < template_hexes(k).size(); ++h)
      ++per[{k, template_hex_type(k, static_cast<int>(h)).type}];
  EXPECT_EQ((per[{TemplateKind::kNode, 1}]), 3);
  EXPECT_EQ((per[{TemplateKind::kEdge, 2}]), 4);   // left and right of both sheets
  EXPECT_EQ((per[{TemplateKind::kEdge, 3}]), 2);   // middle prisms
  EXPECT_EQ((per[{TemplateKind::kEdge, 4}]), 2);   // top
  EXPECT_EQ((per[{TemplateKind::kFace, 0}]), 10);  // 9 children + the centre box
  EXPECT_EQ((per[{TemplateKind::kFace, 5}]), 4);
  EXPECT_EQ((per[{TemplateKind::kFace, 6}]), 4);
  EXPECT_EQ((per[{TemplateKind::kFace, 7}]), 4);
  for (const CellType& t : types)
    std::printf("cell type %-8s from %s hex %d\n", t.name.c_str(), std::string(template_name(t.source)).c_str(),
                t.source_hex);
  // No two types are affinely equivalent under any rotation (the table is a maximal set).
  for (std::size_t a = 0; a < types.size(); ++a)
    for (std::size_t b = 0; b < types.size(); ++b)
      for (int r = 0; r < kNumCubeRotations; ++r)
        if (a != b) {
          EXPECT_FALSE(affinely_equivalent(transform_hex(types[a].corners, r), types[b].corners)) << a << " " << b;
        }
  // Every template hex maps onto its recorded type and rotation.
  for (TemplateKind k : kinds()) {
    const auto hexes = template_hexes(k);
    for (std::size_t h = 0; h < hexes.size(); ++h) {
      const CellTypeMatch m = template_hex_type(k, static_cast<int>(h));
      ASSERT_GE(m.type, 0);
      EXPECT_TRUE(
          affinely_equivalent(transform_hex(types[m.type].corners, m.rotation), template_hex_corners(hexes[h])));
      if (hexes[h].child) {
        EXPECT_EQ(types[m.type].name, "cube");
      }
    }
  }
}

TEST(cell_types, AffineEquivalenceRejectsMirrorImagesAndAcceptsAffineImages) {
  const HexCorners node = cell_types()[1].corners;
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
