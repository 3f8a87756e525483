// The MCHex mesher on a uniform grid; see mchex_mesher.h for the keys that make it conform.
#include "core/mchex_mesher.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/error.h"
#include "core/hex_faces.h"
#include "core/mc33.h"
#include "core/polyhedra.h"
#include "core/subdivide.h"

namespace mchex {
namespace {


// A global point key: kind in the top 3 bits of hi, the rest as mchex_mesher.h lists.
struct PointKey {
  std::uint64_t hi = 0, lo = 0;
  friend bool operator==(const PointKey&, const PointKey&) = default;
};
enum KeyKind : std::uint64_t { kVertexKey, kMidpointKey, kFacePieceKey, kLoopKey, kCentreKey };
constexpr PointKey make_key(KeyKind kind, std::uint64_t a, std::uint64_t b) {
  return {(std::uint64_t(kind) << 61) | a, b};
}

struct PointKeyHash {
  std::size_t operator()(const PointKey& k) const {
    // splitmix64 finaliser over both words.
    std::uint64_t x = k.hi * 0x9E3779B97F4A7C15ull ^ (k.lo + 0x632BE59BD9B4E019ull + (k.hi << 6));
    x ^= x >> 30;
    x *= 0xBF58476D1CE4E5B9ull;
    x ^= x >> 27;
    x *= 0x94D049BB133111EBull;
    x ^= x >> 31;
    return static_cast<std::size_t>(x);
  }
};

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

// Regions of a cell without any interior join: same-sign corners linked along cell edges and
// across the diagonal each ambiguous face joins (CellClass::face_joins), numbered by lowest
// corner as classify() numbers them. This is the partner topology of a tunnel subcase.
void regions_without_interior(CellClass& c) {
  std::array<std::uint8_t, 8> adj{};
  for (const auto& e : kCubeEdges) {
    const bool pa = c.sign_mask >> e[0] & 1, pb = c.sign_mask >> e[1] & 1;
    if (pa == pb) {
      adj[e[0]] |= std::uint8_t(1u << e[1]);
      adj[e[1]] |= std::uint8_t(1u << e[0]);
    }
  }
  for (int f = 0; f < 6; ++f) {
    if (!(c.ambiguous_faces >> f & 1)) continue;
    const auto& q = kHexFaces[f];
    const bool want = c.face_joins >> f & 1;
    // The diagonal (q0, q2) or (q1, q3) whose corners have the joined sign.
    const bool first = ((c.sign_mask >> q[0] & 1) != 0) == want;
    const int u = first ? q[0] : q[1], v = first ? q[2] : q[3];
    adj[u] |= std::uint8_t(1u << v);
    adj[v] |= std::uint8_t(1u << u);
  }
  std::uint8_t left = 0xFF;
  int n = 0;
  while (left) {
    const int c0 = std::countr_zero(left);
    std::uint8_t comp = std::uint8_t(1u << c0), frontier = comp;
    while (frontier) {
      std::uint8_t next = 0;
      for (std::uint8_t m = frontier; m; m &= std::uint8_t(m - 1)) next |= adj[std::countr_zero(m)];
      next &= std::uint8_t(~comp);
      comp |= next;
      frontier = next;
    }
    auto& r = c.regions[n];
    r.sign = (c.sign_mask >> c0 & 1) ? 1 : -1;
    r.corners = comp;
    r.count = static_cast<std::uint8_t>(std::popcount(comp));
    for (std::uint8_t m = comp; m; m &= std::uint8_t(m - 1))
      c.corner_region[std::countr_zero(m)] = static_cast<std::uint8_t>(n);
    left &= std::uint8_t(~comp);
    ++n;
  }
  c.num_regions = static_cast<std::uint8_t>(n);
  for (int i = n; i < 8; ++i) c.regions[i] = {};
}

// The cell stage: every grid cell cut and subdivided, its hex corners merged by global keys into
// one point array.
struct MchexCells {
  std::vector<Vec3> points;  // every global point once, in first-use order
  std::vector<std::array<std::uint32_t, 8>> inside, outside;  // VTK order, into points
};

MchexCells mchex_cut_cells(const UniformGrid& grid, std::span<const double> f, double eps,
                           MchexStats& stats) {
  const std::vector<Vec3> grid_points = grid.vertices();
  const std::uint64_t num_vertices = grid.vertex_count();
  const std::uint32_t n = grid.cells_per_axis();

  std::unordered_map<PointKey, std::uint32_t, PointKeyHash> ids;
  ids.reserve(grid.cell_count() * 16);
  std::vector<Vec3> points;
  std::vector<std::array<std::uint32_t, 8>> inside, outside;
  auto id_of = [&](const PointKey& key, const Vec3& p) {
    auto [it, inserted] = ids.try_emplace(key, static_cast<std::uint32_t>(points.size()));
    if (inserted) points.push_back(p);  // first computed wins: one coordinate per key
    return it->second;
  };

  for (std::uint32_t k = 0; k < n; ++k)
    for (std::uint32_t j = 0; j < n; ++j)
      for (std::uint32_t i = 0; i < n; ++i) {
        const std::uint64_t cell_id = i + std::uint64_t(n) * (j + std::uint64_t(n) * k);
        const std::array<std::uint32_t, 8> gv = grid.cell_corners(i, j, k);
        std::array<double, 8> fc;
        std::array<Vec3, 8> xc;
        for (int c = 0; c < 8; ++c) {
          fc[c] = f[gv[c]];
          xc[c] = grid_points[gv[c]];
        }
        CellClass cls = classify(fc);
        stats.cases[static_cast<int>(cls.subcase)] += 1;
        // Crossings clamped away from the corners (the eps of the paper's cutting): the value
        // depends on the edge's two values only, so all cells around the edge agree.
        for (int e = 0; e < 12; ++e)
          if (cls.cut_edges >> e & 1) cls.crossing[e] = std::clamp(cls.crossing[e], eps, 1 - eps);
        if (subcase_has_tunnel(cls.subcase)) {
          // KNOWN GAP: the paper refines a tunnel cell locally (Section 5, Figure 7). Until that
          // exists the cell is cut with its partner's topology: the same face chords (so the
          // neighbours still conform) and regions joined only along edges and faces.
          cls.subcase = subcase_info(cls.subcase).tunnel_partner;
          cls.tunnel = 0;
          regions_without_interior(cls);
          ++stats.tunnel_cells;
        }
        stats.expected_hexes += 8 + 2 * static_cast<std::size_t>(std::popcount(cls.cut_edges));

        // Global base key of a cell point key: grid vertex, or grid edge (after the vertices).
        auto base_key = [&](CellPointKey key) -> std::uint64_t {
          if (is_corner_key(key)) return gv[key];
          const int e = key_edge(key);
          const int a = kCubeEdges[e][0], b = kCubeEdges[e][1];  // a is the lower end (+axis)
          int axis = 0;
          while (kCubeCorners[a][axis] == kCubeCorners[b][axis]) ++axis;
          return num_vertices + 3 * std::uint64_t(gv[a]) + axis;
        };

        const std::vector<Polyhedron> polys = cut_cell(xc, cls);
        for (std::size_t pi = 0; pi < polys.size(); ++pi) {
          const Polyhedron& p = polys[pi];
          // Global keys of the polyhedron's faces.
          std::vector<PointKey> face_keys(p.faces.size());
          for (std::size_t fi = 0; fi < p.faces.size(); ++fi) {
            const auto& face = p.faces[fi];
            if (fi < p.num_cell_face_pieces) {
              std::uint32_t mask = 0;
              std::uint64_t min_corner = ~std::uint64_t(0);
              for (std::uint32_t v : face) {
                mask |= 1u << p.keys[v];
                if (is_corner_key(p.keys[v])) min_corner = std::min<std::uint64_t>(min_corner, gv[p.keys[v]]);
              }
              int cf = 0;
              while ((mask & ~kFaceKeyMasks[cf]) != 0) ++cf;  // cut_cell's pieces lie on a face
              const int axis = cf / 2, side = cf % 2;
              std::array<std::uint32_t, 3> lo = {i, j, k};
              lo[axis] += side;
              const std::uint64_t grid_face = 3 * std::uint64_t(grid.vertex_index(lo[0], lo[1], lo[2])) + axis;
              face_keys[fi] = make_key(kFacePieceKey, grid_face, min_corner);
            } else {
              int min_crossing = 20;
              for (std::uint32_t v : face) min_crossing = std::min<int>(min_crossing, p.keys[v]);
              face_keys[fi] = make_key(kLoopKey, cell_id, static_cast<std::uint64_t>(min_crossing));
            }
          }
          const PointKey centre = make_key(kCentreKey, cell_id, pi);
          auto& target = p.region_sign > 0 ? inside : outside;
          for (const SubdivisionHex& h : midpoint_subdivide(p)) {
            std::array<std::uint32_t, 8> out;
            for (int c = 0; c < 8; ++c) {
              const SubdivisionPointKey& sk = h.keys[c];
              PointKey key;
              switch (sk.kind) {
                case SubdivisionPointKey::Kind::kVertex:
                  key = make_key(kVertexKey, base_key(sk.a), 0);
                  break;
                case SubdivisionPointKey::Kind::kEdge: {
                  const std::uint64_t a = base_key(sk.a), b = base_key(sk.b);
                  key = make_key(kMidpointKey, std::min(a, b), std::max(a, b));
                  break;
                }
                case SubdivisionPointKey::Kind::kFace:
                  key = face_keys[sk.a];
                  break;
                case SubdivisionPointKey::Kind::kCentre:
                  key = centre;
                  break;
              }
              out[c] = id_of(key, h.corners[c]);
            }
            target.push_back(out);
          }
        }
      }

  stats.points = points.size();
  return {std::move(points), std::move(inside), std::move(outside)};
}

}  // namespace

static_assert(kMchexCaseSlots == kNumSubcases);

std::string_view mchex_case_name(int slot) {
  return subcase_name(static_cast<Subcase>(slot));
}

double zero_tolerance(double cell_size) { return 1e-10 * cell_size; }

MeshPair mesh_mchex(const UniformGrid& grid, std::span<const double> values, double eps,
                    MchexStats* stats_out) {
  if (!(eps > 0 && eps < 0.5)) throw InputError("eps must be in (0, 0.5), got " + std::to_string(eps));
  if (values.size() != grid.vertex_count())
    throw InputError("mesh_mchex: " + std::to_string(values.size()) + " values for " +
                     std::to_string(grid.vertex_count()) + " grid vertices");
  MchexStats stats;

  // The zero rule (mchex_mesher.h), once per vertex.
  const double tiny = zero_tolerance(grid.cell_size());
  std::vector<double> f(values.begin(), values.end());
  for (double& v : f) {
    if (!std::isfinite(v)) throw InputError("mesh_mchex: a grid value is not finite");
    if (std::abs(v) < tiny) {
      v = -tiny;
      ++stats.perturbed_values;
    }
  }

  MchexCells cells = mchex_cut_cells(grid, f, eps, stats);
  if (stats_out) *stats_out = stats;
  // Both meshes from the one point array: interface points are bit-identical.
  return {compact_mesh(cells.points, cells.inside, kInside),
          compact_mesh(cells.points, cells.outside, kOutside)};
}

}  // namespace mchex
