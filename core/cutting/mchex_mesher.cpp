// The MCHex mesher; see mchex_mesher.h for the names that make it conform.
#include "core/cutting/mchex_mesher.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/base/parallel.h"
#include "core/cutting/local_refinement.h"
#include "core/cutting/mc33.h"
#include "core/cutting/polyhedra.h"
#include "core/cutting/repair.h"
#include "core/cutting/subdivide.h"
#include "core/grid/complex_topology.h"
#include "core/mesh/hex_faces.h"
#include "core/mesh/quality.h"

namespace mchex {
namespace {

// An uncut cell (subcase kEmpty, most cells of a grid) is the parametric unit cube whatever its
// values: one polyhedron, inside or outside, and its midpoint subdivision. Both are made once per
// sign here instead of once per cell (cut_cell and midpoint_subdivide give the same result for
// every such cell; the mesh is byte for byte the same); the subdivision is kept as the table below.
struct UncutCube {
  std::vector<Polyhedron> polys;
  // The subdivision hexes' distinct corner keys in order of first appearance (corner by corner, hex by hex),
  // with their parametric points, and each hex corner's index among them: an affine uncut cell
  // maps and names each of its 27 points once instead of once per hex corner (64), in the order
  // the hexes first name them, so that the cell-local points are numbered as before.
  std::vector<SubdivisionPointKey> point_keys;
  std::vector<Vec3> point_params;
  std::vector<std::array<std::uint8_t, 8>> hex_points;
};

const UncutCube& uncut_cube(bool inside) {
  static const std::array<UncutCube, 2> cubes = [] {
    std::array<UncutCube, 2> out;
    for (int in = 0; in < 2; ++in) {
      std::array<double, 8> f;
      f.fill(in ? 1.0 : -1.0);
      UncutCube& u = out[in];
      u.polys = cut_cell(kUnitCubeCorners, classify(f));
      for (const SubdivisionHex& h : midpoint_subdivide(u.polys.at(0))) {
        std::array<std::uint8_t, 8> points{};
        for (int c = 0; c < 8; ++c) {
          const auto k = static_cast<std::size_t>(std::find(u.point_keys.begin(), u.point_keys.end(), h.keys[c]) -
                                                  u.point_keys.begin());
          if (k == u.point_keys.size()) {
            u.point_keys.push_back(h.keys[c]);
            u.point_params.push_back(h.corners[c]);
          } else if (std::memcmp(&u.point_params[k], &h.corners[c], sizeof(Vec3)) != 0) {
            throw std::logic_error("uncut cube: one subdivision point at two parametric places");
          }
          points[c] = static_cast<std::uint8_t>(k);
        }
        u.hex_points.push_back(points);
      }
      if (u.point_keys.size() > 32) throw std::logic_error("uncut cube: more than 32 subdivision points");
    }
    return out;
  }();
  return cubes[inside ? 1 : 0];
}

// Cell point keys (0..19) lying on each cell face: its 4 corners and the crossings of its 4
// edges. A face piece lies on the one face whose mask holds all its keys.
constexpr std::array<std::uint32_t, 6> make_face_key_masks() {
  std::array<std::uint32_t, 6> m{};
  for (int f = 0; f < 6; ++f) {
    std::uint32_t corners = 0;
    for (int c : kHexFaces[f]) corners |= 1u << c;
    m[f] = corners;
    for (int e = 0; e < 12; ++e)
      if ((corners >> kCubeEdges[e][0] & 1) && (corners >> kCubeEdges[e][1] & 1)) m[f] |= 1u << (8 + e);
  }
  return m;
}
constexpr std::array<std::uint32_t, 6> kFaceKeyMasks = make_face_key_masks();

// The cell face that holds two cell edges (-1 if none): where an isosurface chord between their
// crossings runs.
constexpr std::array<std::array<std::int8_t, 12>, 12> make_edge_pair_face() {
  std::array<std::array<std::int8_t, 12>, 12> t{};
  for (auto& row : t) row.fill(-1);
  for (int f = 0; f < 6; ++f)
    for (int a = 0; a < 12; ++a)
      for (int b = 0; b < 12; ++b)
        if (a != b && (kFaceKeyMasks[f] >> (8 + a) & 1) && (kFaceKeyMasks[f] >> (8 + b) & 1))
          t[a][b] = static_cast<std::int8_t>(f);
  return t;
}
constexpr auto kEdgePairFace = make_edge_pair_face();

// The corners of each cell face, as a bit mask.
constexpr std::array<std::uint8_t, 6> make_cell_face_corners() {
  std::array<std::uint8_t, 6> m{};
  for (int q = 0; q < 6; ++q)
    for (int c : kHexFaces[q]) m[q] = static_cast<std::uint8_t>(m[q] | 1u << c);
  return m;
}
constexpr auto kCellFaceCorners = make_cell_face_corners();

constexpr int cube_edge_of(int a, int b) {
  for (int e = 0; e < 12; ++e)
    if ((kCubeEdges[e][0] == a && kCubeEdges[e][1] == b) || (kCubeEdges[e][0] == b && kCubeEdges[e][1] == a)) return e;
  return -1;
}

// A point of the output while the cells run: a global id below kLocal, or kLocal | the index of
// a point its chunk made (fixed up once every chunk is done).
constexpr std::uint32_t kLocal = 0x80000000u;

// Where the shared points of each grid edge and face start in the global point array (after the
// complex's own points): an uncut edge or face needs one slot, a cut edge 3, a cut face 8.
struct SlotLayout {
  std::vector<std::uint32_t> edge_base, face_base;
  std::uint64_t end = 0;
};

SlotLayout lay_out_slots(const HexComplex& cx, const ComplexTopology& t, std::span<const double> f) {
  SlotLayout s;
  const auto positive = [&](std::uint32_t p) { return f[p] > 0; };
  std::uint64_t next = cx.points.size();
  s.edge_base.resize(t.edge_points.size());
  for (std::size_t e = 0; e < t.edge_points.size(); ++e) {
    s.edge_base[e] = static_cast<std::uint32_t>(next);
    next += positive(t.edge_points[e][0]) != positive(t.edge_points[e][1]) ? 3 : 1;
  }
  s.face_base.resize(t.face_points.size());
  for (std::size_t q = 0; q < t.face_points.size(); ++q) {
    s.face_base[q] = static_cast<std::uint32_t>(next);
    const auto& fp = t.face_points[q];
    const bool p0 = positive(fp[0]);
    const bool cut = positive(fp[1]) != p0 || positive(fp[2]) != p0 || positive(fp[3]) != p0;
    next += cut ? 8 : 1;
  }
  s.end = next;
  return s;
}

// One chunk's output, in cell order.
struct ChunkOutput {
  std::vector<Hex> inside, outside;
  std::vector<Vec3> locals;
  MchexStats stats;
  // The count a device computes from subcases alone (local_refinement_hexes on a general cell):
  // what the device's prefix sum is checked against. Affine 11/14 cells make fewer hexes.
  std::uint64_t subcase_hexes = 0;
};

// A cell to cut, as the mesher names its parts: the cell of the complex itself, or one child of
// a cell refined locally (paper Section 5, Figure 7), whose corners, edges and faces are either
// the parent's (then named globally) or inside the parent (then named by the indices of their
// points in the parent's refinement, cell-local).
struct PieceFrame {
  std::array<std::uint32_t, 8> global;  // corner's point id in the complex, or kNone
  std::array<std::uint8_t, 8> local;    // corner's index among the refinement's points
  std::array<std::uint32_t, 12> edge;   // global edge id, or kNone (an edge inside the parent)
  std::array<std::uint32_t, 6> face;    // global face id, or kNone
  std::uint32_t piece = 0;              // child index (0 for an unrefined cell)
};
constexpr std::uint32_t kNone = 0xFFFFFFFFu;

// Cell-local names: kind, then small fields (indices of refinement points, slots, children).
enum LocalKind : std::uint64_t { kLoopCentroid = 1, kVolumeCentre, kInnerPoint, kInnerEdge, kInnerFace };
constexpr std::uint64_t local_key(LocalKind kind, std::uint64_t a, std::uint64_t b = 0, std::uint64_t c = 0) {
  return kind << 56 | a << 40 | b << 8 | c;
}

struct Mesher {
  const HexComplex& cx;
  const ComplexTopology& topo;
  const SlotLayout& slots;
  std::span<const double> f;
  double eps;
  double tiny;                                    // the zero rule's tolerance: virtual values are at least this
  std::span<const std::uint8_t> device_subcases;  // empty, or the device's (cross-checked)
  // Per edge of the complex: the crossing parameter from the edge's first point (edge_points[e][0])
  // where MchexCrossings::field found the zero; empty for the linear rule, NaN on uncut edges.
  std::span<const double> exact;
  std::vector<Vec3>& shared;  // [0, slots.end): written by owners only

  // The points one cell makes for itself (loop centroids, volume centres, everything inside a
  // refined cell), by local name.
  struct LocalPoints {
    std::vector<std::pair<std::uint64_t, std::uint32_t>> ids;
    std::uint32_t get(std::uint64_t key, const Vec3& x, ChunkOutput& out) {
      for (const auto& [k, id] : ids)
        if (k == key) return id;
      const std::uint32_t id = kLocal | static_cast<std::uint32_t>(out.locals.size());
      out.locals.push_back(x);
      ids.emplace_back(key, id);
      return id;
    }
  };

  void mesh_cell(std::uint32_t cell, ChunkOutput& out) const {
    const CellCorners& gv = cx.cells[cell];
    std::array<double, 8> fc;
    std::array<Vec3, 8> xc;
    for (int c = 0; c < 8; ++c) {
      fc[c] = f[gv[c]];
      xc[c] = cx.points[gv[c]];
    }
    const CellClass cls = classify(fc);
    if (!device_subcases.empty() && device_subcases[cell] != static_cast<std::uint8_t>(cls.subcase))
      throw std::logic_error("mesh_mchex: cell " + std::to_string(cell) + ": the device classified subcase " +
                             std::string(subcase_name(static_cast<Subcase>(device_subcases[cell] % kNumSubcases))) +
                             " (code " + std::to_string(device_subcases[cell]) + "), core's classify() subcase " +
                             std::string(subcase_name(cls.subcase)));
    out.stats.cases[static_cast<int>(cls.subcase)] += 1;
    // 11 and 14 are cut directly (volume-centre offset) on affine cells, refined on the others.
    const bool refine = needs_local_refinement(cls, xc);
    out.stats.expected_hexes += static_cast<std::size_t>(
        local_refinement_hexes(cls.subcase, refine ? CellShape::kGeneral : CellShape::kAffine));
    out.subcase_hexes += static_cast<std::uint64_t>(local_refinement_hexes(cls.subcase));
    const auto& cell_edges = topo.cell_edges[cell];
    const auto& cell_faces = topo.cell_faces[cell];
    LocalPoints locals;
    if (!refine) {
      PieceFrame frame;
      frame.global = gv;
      for (int c = 0; c < 8; ++c) frame.local[c] = static_cast<std::uint8_t>(c);
      frame.edge = cell_edges;
      frame.face = cell_faces;
      mesh_piece(cell, frame, xc, cls, locals, out);
      return;
    }
    // Paper Section 5, Figure 7: the cell is cut as its local refinement's leaves. A leaf's edge
    // or face made of cell corners only is an edge or face of the cell (local_refinement.h:
    // the cell's faces are never split), named globally; everything else is inside the cell.
    const LocalRefinement lr = refine_locally(xc, fc, cls, tiny);
    ++out.stats.refined_cells;
    out.stats.refined_cells_two_levels += lr.levels == 2;
    for (std::size_t li = 0; li < lr.cells.size(); ++li) {
      const auto& leaf = lr.cells[li];
      PieceFrame frame;
      const LocalRefinementLeaf cell_of_leaf = leaf_cell(lr, li);
      for (int c = 0; c < 8; ++c) {
        const std::uint32_t idx = leaf[c];
        frame.global[c] = idx < 8 ? gv[idx] : kNone;
        frame.local[c] = static_cast<std::uint8_t>(idx);
      }
      for (int e = 0; e < 12; ++e) {
        const std::uint32_t a = leaf[kCubeEdges[e][0]], b = leaf[kCubeEdges[e][1]];
        frame.edge[e] = kNone;
        if (a < 8 && b < 8) {
          const int pe = cube_edge_of(static_cast<int>(a), static_cast<int>(b));
          if (pe < 0) throw std::logic_error("local refinement: a child edge joins two cell corners off a cell edge");
          frame.edge[e] = cell_edges[pe];
        }
      }
      for (int q = 0; q < 6; ++q) {
        std::uint8_t mask = 0;
        bool on_cell = true;
        for (int c : kHexFaces[q]) {
          on_cell = on_cell && leaf[c] < 8;
          if (leaf[c] < 8) mask |= static_cast<std::uint8_t>(1u << leaf[c]);
        }
        frame.face[q] = kNone;
        if (on_cell) {
          int pq = 0;
          while (pq < 6 && mask != kCellFaceCorners[pq]) ++pq;
          if (pq == 6) throw std::logic_error("local refinement: a child face has 4 cell corners off a cell face");
          frame.face[q] = cell_faces[pq];
        }
      }
      frame.piece = static_cast<std::uint32_t>(li + 1);
      const CellClass leaf_class = classify(cell_of_leaf.values);
      if (needs_local_refinement(leaf_class))
        throw std::logic_error("local refinement left a leaf of subcase " +
                               std::string(subcase_name(leaf_class.subcase)));
      mesh_piece(cell, frame, cell_of_leaf.corners, leaf_class, locals, out);
    }
  }

  // Cuts one (sub)cell and subdivides its polyhedra; `cls` already classified, tunnels resolved.
  void mesh_piece(std::uint32_t cell, const PieceFrame& fr, const std::array<Vec3, 8>& xc, CellClass cls,
                  LocalPoints& locals, ChunkOutput& out) const {
    // The field's own zero on the edges of the complex, when it was searched (an edge inside a
    // locally refined cell keeps the linear crossing of its interpolated values).
    if (!exact.empty())
      for (int e = 0; e < 12; ++e) {
        const std::uint32_t g = fr.edge[e];
        if (g == kNone || !(cls.cut_edges >> e & 1) || std::isnan(exact[g])) continue;
        cls.crossing[e] = fr.global[kCubeEdges[e][0]] == topo.edge_points[g][0] ? exact[g] : 1 - exact[g];
      }
    // Crossings clamped away from the corners (the eps of the paper's cutting): the value depends
    // on the edge alone, so all cells around the edge agree.
    clamp_crossings(cls, eps);

    // Each face's corners in canonical order, as comparable names: global point ids on a face of
    // the complex (build_topology's order), refinement indices on a face inside the parent.
    std::array<std::array<std::uint32_t, 4>, 6> order;
    for (int q = 0; q < 6; ++q) {
      if (fr.face[q] != kNone) {
        order[q] = topo.face_points[fr.face[q]];
      } else {
        std::array<std::uint32_t, 4> o;
        for (int i = 0; i < 4; ++i) o[i] = fr.local[kHexFaces[q][i]];
        std::rotate(o.begin(), std::min_element(o.begin(), o.end()), o.end());
        if (o[3] < o[1]) std::swap(o[1], o[3]);
        order[q] = o;
      }
    }
    auto name_in_face = [&](int q, int corner) { return fr.face[q] != kNone ? fr.global[corner] : fr.local[corner]; };
    auto rank_in_face = [&](int q, int corner) {
      const std::uint32_t name = name_in_face(q, corner);
      for (int r = 0; r < 4; ++r)
        if (order[q][r] == name) return r;
      return 4;  // unreachable for a consistent topology
    };
    // Rank of cell edge e in face q: r such that the edge joins face points r and r + 1.
    auto edge_rank_in_face = [&](int q, int e) {
      const int ra = rank_in_face(q, kCubeEdges[e][0]), rb = rank_in_face(q, kCubeEdges[e][1]);
      return ((ra + 1) & 3) == rb ? ra : rb;
    };
    // Slot `slot` of edge e / face q (mchex_mesher.h), with the point x.
    auto edge_point = [&](int e, std::uint32_t slot, const Vec3& x) {
      const std::uint32_t g = fr.edge[e];
      if (g != kNone) {
        const std::uint32_t id = slots.edge_base[g] + slot;
        if (topo.edge_owner[g] == cell) shared[id] = x;
        return id;
      }
      const std::uint64_t a = fr.local[kCubeEdges[e][0]], b = fr.local[kCubeEdges[e][1]];
      return locals.get(local_key(kInnerEdge, std::min(a, b) << 8 | std::max(a, b), 0, slot), x, out);
    };
    auto face_point = [&](int q, std::uint32_t slot, const Vec3& x) {
      const std::uint32_t g = fr.face[q];
      if (g != kNone) {
        const std::uint32_t id = slots.face_base[g] + slot;
        if (topo.face_owner[g] == cell) shared[id] = x;
        return id;
      }
      const std::uint64_t name = std::uint64_t(order[q][0]) << 24 | order[q][1] << 16 | order[q][2] << 8 | order[q][3];
      return locals.get(local_key(kInnerFace, name >> 16, name & 0xFFFF, slot), x, out);
    };
    // Whether corner c is the lower end of edge e (the end slot 0 starts from).
    auto is_lower_end = [&](int e, int c) {
      const int other = kCubeEdges[e][0] == c ? kCubeEdges[e][1] : kCubeEdges[e][0];
      if (fr.edge[e] != kNone) return fr.global[c] == topo.edge_points[fr.edge[e]][0];
      return fr.local[c] < fr.local[other];
    };
    auto corner_point = [&](int c, const Vec3& x) {
      if (fr.global[c] != kNone) return fr.global[c];
      return locals.get(local_key(kInnerPoint, fr.local[c]), x, out);
    };

    // Paper Section 5: the polyhedra and their midpoint subdivision are built in the cell's
    // parametric unit cube (crossings at s, face and volume centres as means of parametric
    // points) and every hex corner is mapped through the cell's trilinear map (Eq. 7), which is
    // what its proofs over the 3-refinement cell types assume. On a cube (uniform grid) this is
    // the same as building in space; on a transition cell with non-parallelogram faces the
    // means differ, and those taken in space certify less often (core/cutting/certify.h).
    const UncutCube* uncut = cls.subcase == Subcase::kEmpty ? &uncut_cube(cls.regions[0].sign > 0) : nullptr;
    std::vector<Polyhedron> cut;
    if (!uncut) cut = cut_cell(kUnitCubeCorners, cls);
    const std::vector<Polyhedron>& polys = uncut ? uncut->polys : cut;
    const bool uncut_affine = cls.subcase == Subcase::kEmpty && uncut_affine_cell_certified(xc);
    for (std::size_t pi = 0; pi < polys.size(); ++pi) {
      const Polyhedron& p = polys[pi];
      // Per face of the polyhedron: the cell face it lies on and its slot (pieces), or the local
      // key of its isosurface loop.
      std::vector<std::int32_t> face_slot(p.faces.size());
      std::vector<std::int8_t> face_cell_face(p.faces.size(), -1);
      for (std::size_t fi = 0; fi < p.faces.size(); ++fi) {
        const auto& face = p.faces[fi];
        if (fi < p.num_cell_face_pieces) {
          std::uint32_t mask = 0;
          for (std::uint32_t v : face) mask |= 1u << p.keys[v];
          int q = 0;
          while ((mask & ~kFaceKeyMasks[q]) != 0) ++q;  // cut_cell's pieces lie on a face
          int rank = 4;
          for (std::uint32_t v : face)
            if (is_corner_key(p.keys[v])) rank = std::min(rank, rank_in_face(q, p.keys[v]));
          face_cell_face[fi] = static_cast<std::int8_t>(q);
          face_slot[fi] = rank;
        } else {
          int min_crossing = 20;
          for (std::uint32_t v : face) min_crossing = std::min<int>(min_crossing, p.keys[v]);
          face_slot[fi] = min_crossing;
        }
      }
      auto& target = p.region_sign > 0 ? out.inside : out.outside;
      // The global or cell-local id of a hex corner (mchex_mesher.h's names), its point x.
      auto point_id = [&](const SubdivisionPointKey& sk, const Vec3& x) -> std::uint32_t {
        switch (sk.kind) {
          case SubdivisionPointKey::Kind::kVertex:
            return is_corner_key(sk.a) ? corner_point(sk.a, x) : edge_point(key_edge(sk.a), 1, x);
          case SubdivisionPointKey::Kind::kEdge: {
            const bool ca = is_corner_key(sk.a), cb = is_corner_key(sk.b);
            if (ca && cb) return edge_point(cube_edge_of(sk.a, sk.b), 0, x);  // an uncut cell edge
            if (ca || cb) {                                                   // corner to the crossing on its edge
              const int corner = ca ? sk.a : sk.b, e = key_edge(ca ? sk.b : sk.a);
              return edge_point(e, is_lower_end(e, corner) ? 0 : 2, x);
            }
            // An isosurface chord across a cell face.
            const int ea = key_edge(sk.a), eb = key_edge(sk.b);
            const int q = kEdgePairFace[ea][eb];
            return face_point(q, 4 + std::min(edge_rank_in_face(q, ea), edge_rank_in_face(q, eb)), x);
          }
          case SubdivisionPointKey::Kind::kFace:
            if (face_cell_face[sk.a] >= 0)
              return face_point(face_cell_face[sk.a], static_cast<std::uint32_t>(face_slot[sk.a]), x);
            return locals.get(local_key(kLoopCentroid, fr.piece, static_cast<std::uint64_t>(face_slot[sk.a])), x, out);
          case SubdivisionPointKey::Kind::kCentre: return locals.get(local_key(kVolumeCentre, fr.piece, pi), x, out);
        }
        return 0;  // unreachable: every kind is named above
      };
      if (uncut_affine) {
        // Certified by construction (repair.h), no check needed: each of the cube's subdivision
        // points mapped into the cell and named once, in the order the hexes first name them.
        std::array<std::uint32_t, 32> ids{};
        for (std::size_t k = 0; k < uncut->point_keys.size(); ++k)
          ids[k] = point_id(uncut->point_keys[k], trilinear_map(xc, uncut->point_params[k]));
        for (const auto& corners : uncut->hex_points) {
          Hex hex;
          for (int c = 0; c < 8; ++c) hex[c] = ids[corners[c]];
          target.push_back(hex);
        }
        continue;
      }
      // Mapped into the cell, every hex checked, the volume centre moved where one is not
      // certified (core/cutting/repair.h; the centre is this polyhedron's own point).
      const MappedSubdivision mapped = subdivide_in_cell(p, xc);
      out.stats.moved_centres += mapped.centre_moved;
      if (!mapped.certified) {
        ++out.stats.uncertified_polyhedra;
        if (out.stats.uncertified_cells.empty() || out.stats.uncertified_cells.back() != cell)
          out.stats.uncertified_cells.push_back(cell);
      }
      for (const SubdivisionHex& h : mapped.hexes) {
        Hex hex;
        for (int c = 0; c < 8; ++c) hex[c] = point_id(h.keys[c], h.corners[c]);
        target.push_back(hex);
      }
    }
  }
};

}  // namespace

static_assert(kMchexCaseSlots == kNumSubcases);

std::string_view mchex_case_name(int slot) { return subcase_name(static_cast<Subcase>(slot)); }

double zero_tolerance(double cell_size) { return 1e-10 * cell_size; }

double zero_tolerance_of(const HexComplex& cx) {
  double smallest = std::numeric_limits<double>::infinity();
  for (double h : cx.cell_size) smallest = std::min(smallest, h);
  if (!std::isfinite(smallest)) smallest = cx.box.empty() ? 1.0 : cx.box.diagonal();
  return zero_tolerance(smallest);
}

constexpr double kCrossingResidual = 1e-9;
constexpr double kCrossingBracket = 1e-12;
constexpr int kMaxCrossingSteps = 60;

void search_crossings(std::span<const Vec3> points, std::span<const std::array<std::uint32_t, 2>> edges,
                      std::span<const double> values, double tiny, const SdfBatch& field,
                      std::span<const std::uint32_t> which, std::span<double> t, CrossingSearch* stats) {
  struct Open {
    std::uint32_t edge;
    double lo, hi, f_lo, f_hi, at;
    int kept;  // -1: lo moved last, +1: hi moved last, 0: neither yet
  };
  auto rule = [tiny](double v) { return std::abs(v) < tiny ? -tiny : v; };
  std::vector<Open> open;
  auto consider = [&](std::uint32_t e) {
    const double fa = rule(values[edges[e][0]]), fb = rule(values[edges[e][1]]);
    t[e] = std::numeric_limits<double>::quiet_NaN();
    if ((fa > 0) != (fb > 0)) open.push_back({e, 0, 1, fa, fb, fa / (fa - fb), 0});
  };
  if (which.empty())
    for (std::uint32_t e = 0; e < edges.size(); ++e) consider(e);
  else
    for (std::uint32_t e : which) consider(e);
  CrossingSearch got;
  got.edges = open.size();
  std::vector<Vec3> x;
  std::vector<double> v;
  std::vector<std::uint8_t> done;
  for (int step = 0; step < kMaxCrossingSteps && !open.empty(); ++step) {
    x.resize(open.size());
    v.resize(open.size());
    parallel_for(open.size(), [&](std::size_t i) {
      const auto& ends = edges[open[i].edge];
      x[i] = (1 - open[i].at) * points[ends[0]] + open[i].at * points[ends[1]];
    });
    field(x, v);
    ++got.batches;
    done.assign(open.size(), 0);
    parallel_for(open.size(), [&](std::size_t i) {
      Open& o = open[i];
      const auto& ends = edges[o.edge];
      const double length = norm(points[ends[1]] - points[ends[0]]);
      if (!std::isfinite(v[i])) {  // no better point than the one bracketed so far
        done[i] = 1;
        return;
      }
      const double y = rule(v[i]);
      if (std::abs(y) <= kCrossingResidual * length) {
        done[i] = 1;
        return;
      }
      if ((y > 0) == (o.f_lo > 0)) {
        o.lo = o.at, o.f_lo = y;
        if (o.kept == -1) o.f_hi *= 0.5;
        o.kept = -1;
      } else {
        o.hi = o.at, o.f_hi = y;
        if (o.kept == 1) o.f_lo *= 0.5;
        o.kept = 1;
      }
      double next = (o.lo * o.f_hi - o.hi * o.f_lo) / (o.f_hi - o.f_lo);
      if (!(next > o.lo && next < o.hi)) next = 0.5 * (o.lo + o.hi);
      o.at = next;
      done[i] = o.hi - o.lo <= kCrossingBracket;
    });
    std::size_t kept = 0;
    for (std::size_t i = 0; i < open.size(); ++i) {
      if (!done[i]) {
        open[kept++] = open[i];
        continue;
      }
      t[open[i].edge] = open[i].at;
      const auto& ends = edges[open[i].edge];
      if (std::isfinite(v[i]))
        got.residual = std::max(got.residual, std::abs(v[i]) / norm(points[ends[1]] - points[ends[0]]));
    }
    open.resize(kept);
  }
  for (const Open& o : open) t[o.edge] = o.at;  // out of steps: the last point, inside its bracket
  if (stats) {
    stats->edges += got.edges;
    stats->batches += got.batches;
    stats->residual = std::max(stats->residual, got.residual);
  }
}

std::vector<double> apply_zero_rule(const HexComplex& cx, std::span<const double> values, std::size_t* perturbed) {
  if (values.size() != cx.points.size())
    throw InputError("mesh_mchex: " + std::to_string(values.size()) + " values for " +
                     std::to_string(cx.points.size()) + " grid points");
  // The zero rule (mchex_mesher.h), once per point.
  const double tiny = zero_tolerance_of(cx);
  std::vector<double> f(values.begin(), values.end());
  std::size_t moved = 0;
  for (double& v : f) {
    if (!std::isfinite(v)) throw InputError("mesh_mchex: a grid value is not finite");
    if (std::abs(v) < tiny) {
      v = -tiny;
      ++moved;
    }
  }
  if (perturbed) *perturbed = moved;
  return f;
}

MeshPair mesh_mchex(const HexComplex& cx, std::span<const double> values, double eps, MchexStats* stats_out,
                    const DeviceClassification& device, const MchexCrossings& crossings) {
  if (!(eps > 0 && eps < 0.5)) throw InputError("eps must be in (0, 0.5), got " + std::to_string(eps));
  MchexStats stats;
  const std::vector<double> f = apply_zero_rule(cx, values, &stats.perturbed_values);
  const double tiny = zero_tolerance_of(cx);
  if (!device.subcases.empty() && device.subcases.size() != cx.cells.size())
    throw std::invalid_argument("mesh_mchex: device subcases for " + std::to_string(device.subcases.size()) +
                                " cells, the complex has " + std::to_string(cx.cells.size()));
  if (!device.hex_offsets.empty() && device.hex_offsets.size() != cx.cells.size() + 1)
    throw std::invalid_argument("mesh_mchex: device hex offsets need cells + 1 entries");

  using Clock = std::chrono::steady_clock;
  auto since = [](Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); };
  auto t0 = Clock::now();
  // Fixed chunks (never the thread count) so that the output order is the same on any machine.
  constexpr std::size_t kChunk = 1024;
  const std::size_t num_chunks = (cx.cells.size() + kChunk - 1) / kChunk;
  std::vector<ChunkOutput> chunks(num_chunks);
  std::vector<Vec3> points;
  {
    // The complex's topology and slots serve the cells alone: freed before the chunks are
    // assembled, when the chunks' arrays and the meshes' are all live (about 30 MB of them for
    // the npm gearwheel's 177k cells: 72 bytes a cell and about 12 a face or an edge).
    const ComplexTopology topo = build_topology(cx);
    const SlotLayout slots = lay_out_slots(cx, topo, f);
    if (slots.end >= kLocal) throw ResourceError("mesh_mchex: more than 2^31 points");
    points.resize(slots.end);
    std::copy(cx.points.begin(), cx.points.end(), points.begin());
    stats.seconds_topology = since(t0);
    t0 = Clock::now();
    std::vector<double> exact;
    if (crossings.field) {
      exact.resize(topo.edge_points.size());
      CrossingSearch search;
      search_crossings(cx.points, topo.edge_points, f, tiny, crossings.field, {}, exact, &search);
      stats.exact_crossings = search.edges;
      stats.crossing_batches = search.batches;
      stats.crossing_residual = search.residual;
    }
    stats.seconds_crossings = since(t0);
    t0 = Clock::now();

    const Mesher mesher{cx, topo, slots, f, eps, tiny, device.subcases, exact, points};
    parallel_chunks(num_chunks, 1, [&](std::size_t b, std::size_t e) {
      for (std::size_t ch = b; ch < e; ++ch) {
        const std::size_t end = std::min(cx.cells.size(), (ch + 1) * kChunk);
        for (std::size_t c = ch * kChunk; c < end; ++c) mesher.mesh_cell(static_cast<std::uint32_t>(c), chunks[ch]);
        // Grown by doubling, the chunk's arrays hold up to twice what they use until assembled:
        // trimmed now, the room is the next chunk's on this thread (the chunks' arrays were 83 MB at
        // the npm gearwheel's peak, for 56 MB of hexes).
        chunks[ch].inside.shrink_to_fit();
        chunks[ch].outside.shrink_to_fit();
        chunks[ch].locals.shrink_to_fit();
        if (device.hex_offsets.empty()) continue;
        // The device counts from subcases alone (it does not see the cells' shapes): its sum over
        // the chunk must be the subcase count of what the cells were, and bounds what they made.
        const std::uint64_t expected = device.hex_offsets[end] - device.hex_offsets[ch * kChunk];
        const std::uint64_t made = chunks[ch].inside.size() + chunks[ch].outside.size();
        if (chunks[ch].subcase_hexes != expected || made > expected)
          throw std::logic_error("mesh_mchex: cells " + std::to_string(ch * kChunk) + " to " + std::to_string(end - 1) +
                                 " made " + std::to_string(made) + " hexes (" +
                                 std::to_string(chunks[ch].subcase_hexes) +
                                 " by their subcases), the device's prefix sum says " + std::to_string(expected));
      }
    });
  }
  stats.seconds_cells = since(t0);
  t0 = Clock::now();

  // Chunk-local points go after the shared ones; hexes keep the cells' order. Each chunk's place
  // in the three arrays comes from prefix sums over the chunks, so the chunks are copied in
  // parallel (serially this was most of the assembly's time at 4 M hexes).
  std::vector<std::size_t> in_at(num_chunks + 1, 0), out_at(num_chunks + 1, 0), local_at(num_chunks + 1, 0);
  for (std::size_t c = 0; c < num_chunks; ++c) {
    const ChunkOutput& ch = chunks[c];
    in_at[c + 1] = in_at[c] + ch.inside.size();
    out_at[c + 1] = out_at[c] + ch.outside.size();
    local_at[c + 1] = local_at[c] + ch.locals.size();
    for (int s = 0; s < kNumSubcases; ++s) stats.cases[s] += ch.stats.cases[s];
    stats.refined_cells += ch.stats.refined_cells;
    stats.refined_cells_two_levels += ch.stats.refined_cells_two_levels;
    stats.expected_hexes += ch.stats.expected_hexes;
    stats.moved_centres += ch.stats.moved_centres;
    stats.uncertified_polyhedra += ch.stats.uncertified_polyhedra;
    stats.uncertified_cells.insert(stats.uncertified_cells.end(), ch.stats.uncertified_cells.begin(),
                                   ch.stats.uncertified_cells.end());
  }
  // The chunks' own points stay where they are, read through point_at (gathering them after the
  // shared ones grew that array: its old and new copies and every chunk were live at once).
  const std::size_t shared_points = points.size();
  const std::size_t point_count = shared_points + local_at[num_chunks];
  if (point_count >= kLocal) throw ResourceError("mesh_mchex: more than 2^31 points");
  std::vector<Hex> inside(in_at[num_chunks]), outside(out_at[num_chunks]);
  parallel_chunks(num_chunks, 1, [&](std::size_t b, std::size_t e) {
    for (std::size_t c = b; c < e; ++c) {
      ChunkOutput& ch = chunks[c];
      const auto base = static_cast<std::uint32_t>(shared_points + local_at[c]);
      auto fix = [base](Hex h) {
        for (std::uint32_t& v : h)
          if (v & kLocal) v = base + (v & ~kLocal);
        return h;
      };
      std::transform(ch.inside.begin(), ch.inside.end(), inside.begin() + static_cast<std::ptrdiff_t>(in_at[c]), fix);
      std::transform(ch.outside.begin(), ch.outside.end(), outside.begin() + static_cast<std::ptrdiff_t>(out_at[c]),
                     fix);
      ch.inside = {};
      ch.outside = {};
    }
  });
  const auto point_at = [&](std::uint32_t v) -> const Vec3& {
    if (v < shared_points) return points[v];
    const std::size_t local = v - shared_points;
    const std::size_t c = std::size_t(std::upper_bound(local_at.begin(), local_at.end(), local) - local_at.begin()) - 1;
    return chunks[c].locals[local - local_at[c]];
  };

  // Distinct points of both meshes: the interface points are counted once.
  {
    std::vector<std::uint8_t> used(point_count, 0);
    for (const auto* hs : {&inside, &outside})
      parallel_for(hs->size(), [&](std::size_t h) {
        for (std::uint32_t v : (*hs)[h]) std::atomic_ref<std::uint8_t>(used[v]).store(1, std::memory_order_relaxed);
      });
    stats.points = parallel_reduce(
        used.size(), 65536, std::size_t{0},
        [&](std::size_t b, std::size_t e, std::size_t n) {
          return n + static_cast<std::size_t>(std::count(used.begin() + b, used.begin() + e, 1));
        },
        std::plus<>());
  }
  MeshPair out;
  out.inside = compact_mesh(point_count, point_at, std::move(inside), kInside);
  out.outside = compact_mesh(point_count, point_at, std::move(outside), kOutside);
  stats.seconds_assembly = since(t0);
  if (stats_out) *stats_out = stats;
  return out;
}

MeshPair mesh_mchex(const UniformGrid& grid, std::span<const double> values, double eps, MchexStats* stats) {
  return mesh_mchex(uniform_complex(grid), values, eps, stats);
}

}  // namespace mchex
