#include "core/optimize/optimize.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <numeric>
#include <span>
#include <vector>

#include "core/base/parallel.h"
#include "core/base/stage_clock.h"
#include "core/check/mesh_check.h"
#include "core/mesh/feature_curves.h"
#include "core/mesh/point_index.h"
#include "core/mesh/quality.h"

namespace mchex {
namespace {

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

constexpr double kInf = std::numeric_limits<double>::infinity();

// Corner index of reference vertex (a, b, c) in VTK order (as core/mesh/quality.cpp).
constexpr int corner_of(int a, int b, int c) { return 4 * c + (b == 0 ? a : 3 - a); }

// Per corner: its three edge neighbours, three face diagonals and the opposite corner, by
// flipping one, two or three of its reference bits. The "ideal corner" of a hex at corner i is
// sum(edge neighbours) - sum(face diagonals) + opposite: exact for a parallelepiped (the affine
// map's value at i from the other seven), so it is where i would sit if the hex were affine.
struct CornerTable {
  std::array<std::array<int, 3>, 8> edge{}, diagonal{};
  std::array<int, 8> opposite{};
};
constexpr CornerTable make_corner_table() {
  CornerTable t;
  for (int c = 0; c < 2; ++c)
    for (int b = 0; b < 2; ++b)
      for (int a = 0; a < 2; ++a) {
        const int i = corner_of(a, b, c);
        t.edge[i] = {corner_of(1 - a, b, c), corner_of(a, 1 - b, c), corner_of(a, b, 1 - c)};
        t.diagonal[i] = {corner_of(a, 1 - b, 1 - c), corner_of(1 - a, b, 1 - c), corner_of(1 - a, 1 - b, c)};
        t.opposite[i] = corner_of(1 - a, 1 - b, 1 - c);
      }
  return t;
}
constexpr CornerTable kCorners = make_corner_table();

// The 12 edges of a hex as corner pairs (each corner with its edge neighbours of higher index).
constexpr std::array<std::array<int, 2>, 12> make_hex_edges() {
  std::array<std::array<int, 2>, 12> edges{};
  int n = 0;
  for (int i = 0; i < 8; ++i)
    for (int e : kCorners.edge[i])
      if (e > i) edges[n++] = {i, e};
  return edges;
}
constexpr std::array<std::array<int, 2>, 12> kHexEdges = make_hex_edges();

// Vertex constraints.
// kPlaced: a surface vertex that a move has put onto the input surface (the mesher's interface
// points are only near it: edge crossings of the interpolated field, face and cell centres).
// kFeature: a surface vertex that represents a feature of the input, a curve or a corner (its
// `target`): until it lies on it (kSnapped) it moves on the surface, never away from the target;
// then along the curve (a corner's holds it).
// kBesideSurface: a vertex sharing a hex with a surface vertex (kOnSurface included).
enum : uint8_t { kOnSurface = 1, kFixed = 2, kPlaced = 4, kFeature = 8, kSnapped = 16, kBesideSurface = 32 };

// Steps along the ideal-corner and neighbour-mean directions (full, half, quarter), and along the
// gradient of the worst scaled Jacobian (in units of the vertex's mean edge length: the worst
// hexes are thin, so the steps that help them are short).
constexpr int kSteps = 3, kGradientSteps = 6;
// In the second phase, a surface vertex on the surface whose hexes are below kSearchBelow (it cannot search: each
// position needs a projection) also tries 8 directions of its tangent plane at 2 steps, projected
// with the others (unused slots are NaN and skipped).
constexpr int kTangentAngles = 8, kTangentSteps = 2;
constexpr int kTangent = 1 + 2 * kSteps + kGradientSteps;
constexpr int kQualityCandidates = kTangent + kTangentAngles * kTangentSteps;  // slot 0: the current point (projected)
// A feature vertex not yet on its target has three more: half and a quarter of the way to the
// nearest point of the target (projected), and that point itself (not projected: it is on the
// surface).
constexpr int kApproach = kQualityCandidates, kTarget = kApproach + 2, kCandidates = kTarget + 1;
constexpr std::size_t kMaxValence = 48;  // vertices in more hexes are left fixed
// In the second phase (Optimizer::searching, once the plain sweeps stall), a vertex whose hexes
// stay below kSearchBelow after the candidates above searches further: a
// compass search from the best of them along the 3 axes and the 4 cube diagonals, both ways,
// from kSearchStart of its mean edge length, taking the first step that gains, halving the step
// when none does, for at most kSearchRounds rounds. The candidates above are few directions
// (one point's gradient, two means); where two hexes tie at the minimum, every one of them
// lowers one of the two, and a search over directions finds the ones that raise both.
constexpr double kSearchBelow = 0.3, kSearchStart = 0.25;
// The compass: the 3 axes and the 4 cube diagonals, both ways.
constexpr double kDiagonal = 0.57735026918962573;  // 1 / sqrt(3)
constexpr Vec3 kCompass[14] = {{1, 0, 0},
                               {-1, 0, 0},
                               {0, 1, 0},
                               {0, -1, 0},
                               {0, 0, 1},
                               {0, 0, -1},
                               {kDiagonal, kDiagonal, kDiagonal},
                               {-kDiagonal, -kDiagonal, -kDiagonal},
                               {kDiagonal, kDiagonal, -kDiagonal},
                               {-kDiagonal, -kDiagonal, kDiagonal},
                               {kDiagonal, -kDiagonal, kDiagonal},
                               {-kDiagonal, kDiagonal, -kDiagonal},
                               {-kDiagonal, kDiagonal, kDiagonal},
                               {kDiagonal, -kDiagonal, -kDiagonal}};
constexpr int kSearchRounds = 16, kSearchHalvings = 4;

// The pair as one mesh: inside points first, then the outside points that are not on the
// interface; hexes of the inside, then of the outside.
struct Joined {
  std::vector<Vec3> x;
  std::vector<Hex> hexes;
  std::size_t inside_hexes = 0;
  std::vector<uint32_t> outside_point;  // outside point -> joined vertex
};

constexpr uint32_t kNoPoint = std::numeric_limits<uint32_t>::max();

// For each of `points`, the lowest index into `keys` of a point with exactly its coordinates, or
// kNoPoint: how the outside mesh's points on the interface find their inside twins (the interface
// is shared bit for bit). A hash of the keys, probed once per point (most outside points fall
// outside the box of the keys and are not even hashed).
std::vector<uint32_t> coinciding(std::span<const Vec3> points, const std::vector<Vec3>& keys) {
  const PointIndex index(keys);
  static_assert(PointIndex::kNone == kNoPoint);
  std::vector<uint32_t> found(points.size());
  parallel_for(points.size(), [&](std::size_t k) { found[k] = index.find(points[k]); });
  return found;
}

// Greedy colouring in index order: each i < n that `take` accepts gets the smallest colour that
// none of its neighbours (for_each_neighbour(i, f) calls f(w) for each) has yet. Sequential, so
// deterministic; the classes list their members in increasing order.
template <class Take, class ForEachNeighbour>
std::vector<std::vector<uint32_t>> greedy_colours(std::size_t n, const Take& take,
                                                  const ForEachNeighbour& for_each_neighbour) {
  std::vector<int> colour(n, -1);
  std::vector<std::vector<uint32_t>> classes;
  std::vector<std::size_t> seen;  // seen[c] == i + 1: a neighbour of i has colour c
  for (std::size_t i = 0; i < n; ++i) {
    if (!take(i)) continue;
    for_each_neighbour(i, [&](uint32_t w) {
      if (colour[w] >= 0) seen[std::size_t(colour[w])] = i + 1;
    });
    std::size_t pick = 0;
    while (pick < seen.size() && seen[pick] == i + 1) ++pick;
    if (pick == seen.size()) {
      seen.push_back(0);
      classes.emplace_back();
    }
    colour[i] = int(pick);
    classes[pick].push_back(uint32_t(i));
  }
  return classes;
}

Joined join(const MeshPair& m) {
  Joined j;
  j.x = m.inside.points;
  j.outside_point = coinciding(m.outside.points, m.inside.points);
  for (std::size_t k = 0; k < m.outside.points.size(); ++k)
    if (j.outside_point[k] == kNoPoint) {
      j.outside_point[k] = uint32_t(j.x.size());
      j.x.push_back(m.outside.points[k]);
    }
  j.hexes = m.inside.hexes;
  j.inside_hexes = m.inside.hexes.size();
  j.hexes.reserve(j.hexes.size() + m.outside.hexes.size());
  for (const Hex& h : m.outside.hexes) {
    Hex g;
    for (int i = 0; i < 8; ++i) g[i] = j.outside_point[h[i]];
    j.hexes.push_back(g);
  }
  return j;
}

// Incident hexes per vertex, each list sorted (so that every loop over them has one order).
KeyGroups vertex_hexes(std::size_t vertices, const std::vector<Hex>& hexes) {
  KeyGroups g = group_by_key(
      vertices, [&](auto&& f) { parallel_for(hexes.size() * 8, [&](std::size_t k) { f(uint32_t(k)); }); },
      [&](uint32_t k) { return hexes[k / 8][k % 8]; });
  parallel_for(vertices,
               [&](std::size_t v) { std::sort(g.items.begin() + g.start[v], g.items.begin() + g.start[v + 1]); });
  return g;  // items are hex * 8 + corner
}

// Into `c` (a visit's loops reuse one: a fresh HexCorners is zeroed first).
void gather(const std::vector<Vec3>& x, const Hex& h, HexCorners& c) {
  for (int i = 0; i < 8; ++i) c[i] = x[h[i]];
}

HexCorners corners_of(const std::vector<Vec3>& x, const Hex& h) {
  HexCorners c;
  gather(x, h, c);
  return c;
}

// Unit normal of a quad from its diagonals (defined also for a nearly degenerate quad), and its
// size (twice the area of the projected quad).
Vec3 quad_normal(const std::vector<Vec3>& x, const std::array<uint32_t, 4>& q, double& size) {
  const Vec3 n = cross(x[q[2]] - x[q[0]], x[q[3]] - x[q[1]]);
  size = norm(n);
  return size > 0 ? n / size : Vec3{};
}

}  // namespace

void project_to_surface(const SignedDistance& surface, std::span<Vec3> points) {
  if (points.empty()) return;
  if (const auto* exact = dynamic_cast<const SurfaceSdf*>(&surface)) {
    std::vector<Vec3> in(points.begin(), points.end());
    exact->closest_points(in, points);
    return;
  }
  // An analytic field is a distance (|grad f| = 1 near the surface), so p - f grad f is the
  // closest point; two Newton steps absorb the difference where it is only close to one.
  const Box b = surface.bounds();
  const double h = 1e-6 * std::max(b.diagonal(), 1e-300);
  std::vector<Vec3> probe(points.size() * 7);
  std::vector<double> f(probe.size());
  for (int iteration = 0; iteration < 2; ++iteration) {
    parallel_for(points.size(), [&](std::size_t i) {
      probe[7 * i] = points[i];
      for (int a = 0; a < 3; ++a) {
        Vec3 d{};
        d[a] = h;
        probe[7 * i + 1 + 2 * a] = points[i] + d;
        probe[7 * i + 2 + 2 * a] = points[i] - d;
      }
    });
    surface.evaluate(probe, f);
    parallel_for(points.size(), [&](std::size_t i) {
      Vec3 g;
      for (int a = 0; a < 3; ++a) g[a] = (f[7 * i + 1 + 2 * a] - f[7 * i + 2 + 2 * a]) / (2 * h);
      const double g2 = dot(g, g);
      if (g2 > 0 && std::isfinite(f[7 * i])) points[i] -= (f[7 * i] / g2) * g;
    });
  }
}

SnapStats snap_boundary(MeshPair& meshes, const SignedDistance& surface, const SnapLimits& limits,
                        const SnapHeld& held) {
  const double t0 = now();
  SnapStats st;
  HexMesh& in = meshes.inside;
  HexMesh& out = meshes.outside;
  // The boundary's vertices, in increasing order, and each outside point's twin among them: the
  // inside point at the same coordinates (the interface is shared bit for bit), as its number in
  // `boundary`. With an outside mesh the inside mesh's boundary is all interface, but where the
  // solid reaches the box: so the boundary vertices are the inside points an outside point
  // coincides with, and those on the box that none does are held there anyway (below). One
  // lookup of every outside point finds both, no face grouping of the inside mesh (the bunny's
  // 62,470 quads: 76 -> 30 ms a snap). Without one, its boundary quads.
  std::vector<uint32_t> boundary;
  std::vector<uint32_t> twin_number;  // outside point -> number in `boundary`, or kNoPoint
  {
    std::vector<uint8_t> on(in.points.size(), 0);
    if (out.points.empty()) {
      for (const auto& q : boundary_quads(in))
        for (uint32_t v : q) on[v] = 1;
    } else {
      twin_number = coinciding(out.points, in.points);
      for (uint32_t a : twin_number)
        if (a != kNoPoint) on[a] = 1;
    }
    for (uint32_t v = 0; v < on.size(); ++v)
      if (on[v]) boundary.push_back(v);
  }
  st.vertices = boundary.size();
  if (boundary.empty()) return st;
  // Each one's place among them (inside point -> its number).
  std::vector<uint32_t> number(in.points.size(), kNoPoint);
  for (uint32_t b = 0; b < boundary.size(); ++b) number[boundary[b]] = b;
  for (uint32_t& a : twin_number)
    if (a != kNoPoint) a = number[a];
  std::vector<uint32_t> twin(boundary.size(), kNoPoint);
  for (uint32_t k = 0; k < twin_number.size(); ++k)
    if (twin_number[k] != kNoPoint) twin[twin_number[k]] = k;
  const std::size_t ni = in.hexes.size();
  auto corner_number = [&](uint64_t h, int c) {
    return h < ni ? number[in.hexes[h][c]] : twin_number[out.hexes[h - ni][c]];
  };
  // Items: hex * 8 + corner over both meshes (outside hexes after the inside ones), grouped by
  // the boundary vertex at that corner, each group sorted.
  KeyGroups star = group_by_key(
      boundary.size(),
      [&](auto&& f) {
        parallel_for((ni + out.hexes.size()) * 8, [&](std::size_t k) {
          if (corner_number(k / 8, int(k % 8)) != kNoPoint) f(uint32_t(k));
        });
      },
      [&](uint32_t k) { return corner_number(k / 8, int(k % 8)); });
  parallel_for(boundary.size(), [&](std::size_t b) {
    std::sort(star.items.begin() + star.start[b], star.items.begin() + star.start[b + 1]);
  });
  auto corners = [&](uint64_t h) {
    HexCorners x;
    for (int c = 0; c < 8; ++c) x[c] = h < ni ? in.points[in.hexes[h][c]] : out.points[out.hexes[h - ni][c]];
    return x;
  };
  // Where each would go; vertices on a face of the box (an outside mesh's boundary there) stay.
  Box box;
  for (const Vec3& p : out.points) box.extend(p);
  std::vector<Vec3> target(boundary.size());
  for (std::size_t b = 0; b < boundary.size(); ++b) target[b] = in.points[boundary[b]];
  // The points held are asked about where they are, before the projection moves the targets.
  std::vector<uint8_t> stays = held ? held(target) : std::vector<uint8_t>(boundary.size(), 0);
  project_to_surface(surface, target);
  if (!out.points.empty())
    for (std::size_t b = 0; b < boundary.size(); ++b)
      for (int a = 0; a < 3; ++a) {
        const double x = in.points[boundary[b]][a];
        if (x == box.lo[a] || x == box.hi[a]) stays[b] = 1;
      }
  // Colours in boundary order, among the boundary vertices of each one's hexes; by topology alone
  // (not skipping those already on the surface), so the colours do not depend on rounding.
  const auto classes = greedy_colours(
      boundary.size(), [&](std::size_t b) { return !stays[b]; },
      [&](std::size_t b, auto&& f) {
        for (uint32_t k = star.start[b]; k < star.start[b + 1]; ++k)
          for (int c = 0; c < 8; ++c)
            if (const uint32_t w = corner_number(star.items[k] / 8, c); w != kNoPoint) f(w);
      });
  std::vector<uint8_t> result(boundary.size(), 0);  // 1 moved, 2 partly
  for (const std::vector<uint32_t>& cls : classes)
    parallel_for(cls.size(), [&](std::size_t i) {
      const uint32_t b = cls[i];
      const uint32_t first = star.start[b], count = star.start[b + 1] - first;
      constexpr uint32_t kMost = 64;
      if (count > kMost) return;
      std::array<HexCorners, kMost> x;
      // Each hex's measures as this corner moves: scaled_jacobian and edge_ratio bit for bit
      // (quality.h), a trial costing the corner's own edges only.
      std::array<MovingCorner, kMost> moving;
      std::array<double, kMost> floor, cap;
      const Vec3 from = in.points[boundary[b]];
      for (uint32_t k = 0; k < count; ++k) {
        x[k] = corners(star.items[first + k] / 8);
        moving[k] = MovingCorner(x[k], int(star.items[first + k] % 8));
        floor[k] = std::min(moving[k].scaled_jacobian(from, -kInf), limits.floor);
        cap[k] = limits.max_edge_ratio < kInf ? std::max(moving[k].edge_ratio(from), limits.max_edge_ratio) : kInf;
      }
      for (const double t : {1.0, 0.5, 0.25}) {
        const Vec3 y = t == 1 ? target[b] : from + t * (target[b] - from);
        bool ok = true;
        for (uint32_t k = 0; k < count && ok; ++k) {
          ok = !(moving[k].scaled_jacobian(y, floor[k]) < floor[k]) && !(moving[k].edge_ratio(y) > cap[k]);
          if (!ok) break;
          HexCorners c = x[k];
          c[star.items[first + k] % 8] = y;
          // Certified after the move whether or not it was before: the mesher's hexes are.
          ok = bernstein_certified(c);
        }
        if (!ok) continue;
        in.points[boundary[b]] = y;
        if (twin[b] != kNoPoint) out.points[twin[b]] = y;
        result[b] = t == 1 ? 1 : 2;
        return;
      }
    });
  for (uint8_t r : result) (r == 1 ? st.moved : r == 2 ? st.partly : st.stayed) += 1;
  st.seconds = now() - t0;
  return st;
}

namespace {

struct Optimizer {
  Joined& j;
  const SignedDistance* surface;
  const OptimizeOptions& o;
  FeatureCurves features;
  KeyGroups incident;
  std::vector<uint8_t> flags;
  std::vector<uint32_t> target;  // kFeature vertices: their curve or corner (FeatureCurves)
  double on_target = 0;          // squared distance within which a vertex is on its target
  std::vector<uint8_t> locked;   // bit a: coordinate a is held (box planes)
  std::vector<Vec3> normal;      // surface vertices: the area-weighted boundary normal
  std::vector<double> sj;        // per hex, the scaled Jacobian (min over the 9 points)
  std::vector<double> ratio;     // per hex, the edge ratio
  std::vector<uint8_t> certified;
  // A vertex is visited again only once a vertex sharing a hex with it has moved (or it moved
  // itself): otherwise its candidates and their scores are those it has already refused.
  std::vector<uint8_t> dirty;
  Box box;
  // The second phase (optimize): once the plain sweeps stall, the search and the tangent
  // candidates join in, so the result is never below the plain sweeps' own.
  bool searching = false;
  // The third phase (optimize): once the search stops, moves that lower the edge ratios above
  // OptimizeOptions::max_edge_ratio, each keeping the minimum scaled Jacobian of the vertex's
  // hexes at least min(where it is, ratio_floor).
  bool ratios = false;
  double ratio_floor = 0;

  Optimizer(Joined& joined, const SignedDistance* s, const TriangleSurface* triangles, const OptimizeOptions& opt,
            const HexMesh& inside, bool pair)
      : j(joined), surface(s), o(opt) {
    const std::size_t nv = j.x.size();
    if (surface && triangles) features = FeatureCurves(*triangles, o.feature_angle);
    incident = vertex_hexes(nv, j.hexes);
    flags.assign(nv, 0);
    target.assign(nv, FeatureCurves::kAnyCurve);
    dirty.assign(nv, 1);
    locked.assign(nv, 0);
    normal.assign(nv, Vec3{});
    for (const Vec3& p : j.x) box.extend(p);
    // Box planes: only where there is an outside mesh (the inside alone has no box).
    if (pair)
      parallel_for(nv, [&](std::size_t v) {
        for (int a = 0; a < 3; ++a)
          if (j.x[v][a] == box.lo[a] || j.x[v][a] == box.hi[a]) locked[v] |= uint8_t(1u << a);
        if (locked[v] == 7) flags[v] |= kFixed;
      });
    // The inside boundary: the interface (on the surface), its features.
    const std::vector<std::array<uint32_t, 4>> quads = boundary_quads(inside);
    KeyGroups at = group_by_key(
        nv,
        [&](auto&& f) {
          for (uint32_t k = 0; k < quads.size() * 4; ++k) f(k);
        },
        [&](uint32_t k) { return quads[k / 4][k % 4]; });
    const double cos_feature = std::cos(o.feature_angle * M_PI / 180);
    const double diagonal = box.diagonal();
    on_target = 1e-24 * diagonal * diagonal;
    parallel_for(nv, [&](std::size_t v) {
      const uint32_t b = at.start[v], e = at.start[v + 1];
      if (b == e) return;
      std::vector<uint32_t> mine(at.items.begin() + b, at.items.begin() + e);
      std::sort(mine.begin(), mine.end());
      flags[v] |= kOnSurface;
      if (!surface || locked[v]) flags[v] |= kFixed;
      double largest = 0;
      std::vector<std::pair<Vec3, double>> n;
      Vec3 sum{};
      for (uint32_t k : mine) {
        double size = 0;
        const Vec3 u = quad_normal(j.x, quads[k / 4], size);
        n.emplace_back(u, size);
        sum += size * u;
        largest = std::max(largest, size);
      }
      normal[v] = normalized(sum);
      if (flags[v] & kFixed || features.empty()) return;
      // Quads far smaller than the largest around the vertex (slivers at clamped crossings)
      // have normals of little meaning: only the others say whether the mesh folds here, and
      // their edges give the vertex's size h.
      bool folds = false;
      double h = 0;
      int edges = 0;
      for (std::size_t p = 0; p < n.size(); ++p) {
        if (n[p].second < 0.05 * largest) continue;
        const auto& q = quads[mine[p] / 4];
        const int i = int(std::find(q.begin(), q.end(), uint32_t(v)) - q.begin());
        h += norm(j.x[q[(i + 1) % 4]] - j.x[v]) + norm(j.x[q[(i + 3) % 4]] - j.x[v]);
        edges += 2;
        for (std::size_t r = p + 1; r < n.size(); ++r)
          folds = folds || (n[r].second >= 0.05 * largest && dot(n[p].first, n[r].first) < cos_feature);
      }
      if (!folds) return;
      h /= edges;
      // A fold is a feature only where the input has a sharp edge within h: the vertex then
      // represents that curve, or a corner of the input within h.
      const FeatureCurves::Nearest on = features.nearest(j.x[v], FeatureCurves::kAnyCurve, h);
      if (on.curve == FeatureCurves::kAnyCurve) return;
      const FeatureCurves::Nearest corner = features.nearest(j.x[v], FeatureCurves::kCorner, h);
      const FeatureCurves::Nearest& to = corner.curve != FeatureCurves::kAnyCurve ? corner : on;
      flags[v] |= kFeature;
      target[v] = to.curve;
      // A vertex already on its target (a crossing exactly on a sharp edge: a box's edges on grid
      // lines) is snapped from the start: no move brings it closer, and while snapping the rule
      // "never away from the target" would refuse every move off that exact point.
      if (to.squared_distance <= on_target) flags[v] |= kSnapped;
    });
    parallel_for(nv, [&](std::size_t v) {
      if (incident.start[v + 1] - incident.start[v] > kMaxValence) flags[v] |= kFixed;
    });
    // Vertices sharing a hex with a surface vertex (the second phase visits them as it visits the
    // surface's own); each writes its own entry of `beside`, read from flags no one writes here.
    std::vector<uint8_t> beside(nv, 0);
    parallel_for(nv, [&](std::size_t v) {
      for (uint32_t k = incident.start[v]; k < incident.start[v + 1] && !beside[v]; ++k)
        for (uint32_t w : j.hexes[incident.items[k] / 8])
          if (flags[w] & kOnSurface) beside[v] = 1;
    });
    parallel_for(nv, [&](std::size_t v) {
      if (beside[v]) flags[v] |= kBesideSurface;
    });
    sj.resize(j.hexes.size());
    ratio.resize(j.hexes.size());
    certified.resize(j.hexes.size());
    parallel_for(j.hexes.size(), [&](std::size_t h) {
      const HexQuality q = hex_quality(corners_of(j.x, j.hexes[h]));
      sj[h] = q.scaled_jacobian;
      ratio[h] = q.edge_ratio;
      certified[h] = q.certified();
    });
  }

  bool movable(std::size_t v) const { return !(flags[v] & kFixed); }

  // Greedy colouring in vertex order: each movable vertex takes the smallest colour that no
  // movable vertex sharing a hex with it has taken. Sequential, so deterministic.
  std::vector<std::vector<uint32_t>> colour() const {
    return greedy_colours(
        j.x.size(), [&](std::size_t v) { return movable(v); },
        [&](std::size_t v, auto&& f) {
          for (uint32_t k = incident.start[v]; k < incident.start[v + 1]; ++k)
            for (uint32_t w : j.hexes[incident.items[k] / 8]) f(w);
        });
  }

  struct Local {
    double min = kInf, sum = 0;
    // Better than `from` by more than rounding: a higher minimum, or the same and a higher sum.
    bool gains_over(const Local& from) const {
      return min - from.min > 1e-12 || (min >= from.min && sum - from.sum > 1e-9 * (from.sum + 1));
    }
  };

  // A vertex's hexes where it is, for try_move: their minimum and sum, the offset of the worst
  // hex and its worst point.
  struct Visit {
    Local now;
    uint32_t worst = 0;
    int point = 0;
    double length = 0;  // mean length of its edges
  };

  // A visit's hexes, each measured with the vertex moving (MovingCorner: the parts that do not
  // depend on its position computed once, when a candidate first reaches the hex).
  struct Star {
    std::array<MovingCorner, kMaxValence> hex;
    uint64_t built = 0;  // bit per offset
    // The corners of the visit's hexes, copied at its start in one pass: the loads are then
    // independent and overlap, where a copy per build would wait for each in turn.
    std::array<HexCorners, kMaxValence> corners;
    std::array<uint8_t, kMaxValence> corner;
    uint32_t refused = kMaxValence;          // the hex that refused the last candidate (evaluate)
    std::array<double, kMaxValence> ratios;  // the edge ratios at the search's position (search)
    void gather(const Joined& j, const KeyGroups& incident, uint32_t v) {
      built = 0;
      refused = kMaxValence;
      for (uint32_t k = incident.start[v], off = 0; k < incident.start[v + 1]; ++k, ++off) {
        mchex::gather(j.x, j.hexes[incident.items[k] / 8], corners[off]);
        corner[off] = uint8_t(incident.items[k] % 8);
      }
    }
    const MovingCorner& at(uint32_t off) {
      if (!(built >> off & 1)) {
        std::construct_at(&hex[off], corners[off], int(corner[off]));
        built |= uint64_t(1) << off;
      }
      return hex[off];
    }
  };
  static_assert(kMaxValence <= 64);

  // The scaled Jacobians of v's hexes with v at y (the certificate and the edge ratio, given a
  // finite ratio_cap, are apart: they are asked only of the candidate chosen); stops early
  // (min = -inf) as soon as a point of a hex falls below `floor` or a hex passes `ratio_cap`.
  // `mins` gets each hex's scaled Jacobian (by offset), as hex_quality has it (the same
  // operations); the minimum and the sum are taken in a fixed order: `first` (an offset into v's
  // incident hexes, the worst hex at the current point), then the others. Which hex is measured
  // first changes no result, only how soon a candidate is refused: the hex that refused the
  // visit's last candidate (it usually refuses the next), else `first`.
  Local evaluate(uint32_t v, Vec3 y, double floor, double ratio_cap, uint32_t first, Star& star, double* mins) const {
    const uint32_t n = incident.start[v + 1] - incident.start[v];
    auto measure = [&](uint32_t off) {
      const MovingCorner& m = star.at(off);
      const double lowest = m.scaled_jacobian(y, floor);
      if (lowest == -kInf || (ratio_cap < kInf && m.edge_ratio(y) > ratio_cap)) {
        star.refused = off;
        return false;
      }
      mins[off] = lowest;
      return true;
    };
    const uint32_t lead = star.refused < n ? star.refused : first;
    Local refused;
    refused.min = -kInf;
    if (!measure(lead)) return refused;
    for (uint32_t off = 0; off < n; ++off)
      if (off != lead && !measure(off)) return refused;
    Local l;
    for (uint32_t i = 0; i < n; ++i) {
      const uint32_t off = i == 0 ? first : (i <= first ? i - 1 : i);
      l.min = std::min(l.min, mins[off]);
      l.sum += mins[off];
    }
    return l;
  }

  // Whether every hex of v that is certified now stays certified with v at y.
  bool keeps_certificates(uint32_t v, Vec3 y) const {
    for (uint32_t k = incident.start[v]; k < incident.start[v + 1]; ++k) {
      const uint32_t h = incident.items[k] / 8, corner = incident.items[k] % 8;
      if (!certified[h]) continue;
      HexCorners c = corners_of(j.x, j.hexes[h]);
      c[corner] = y;
      if (!bernstein_certified(c)) return false;
    }
    return true;
  }

  bool snapped(uint32_t v) const { return (flags[v] & (kFeature | kSnapped)) == (kFeature | kSnapped); }
  bool snapping(uint32_t v) const { return (flags[v] & (kFeature | kSnapped)) == kFeature; }
  // Whether a snapping vertex at y would be on its target.
  bool reaches_target(uint32_t v, Vec3 y) const {
    return snapping(v) && features.nearest(y, target[v]).squared_distance <= on_target;
  }

  // Keeps only the motion a vertex may make: in the plane or along the line of its box face or
  // edge, along its feature curve (`tangent`, 0 at a corner), or in the tangent plane of the
  // surface (the projection then puts it back on the curve or the surface).
  Vec3 constrain(uint32_t v, Vec3 d, Vec3 tangent) const {
    for (int a = 0; a < 3; ++a)
      if (locked[v] >> a & 1) d[a] = 0;
    if (snapped(v)) return dot(d, tangent) * tangent;
    if (flags[v] & kOnSurface) d -= dot(d, normal[v]) * normal[v];
    return d;
  }

  bool unplaced(uint32_t v) const { return surface && (flags[v] & (kOnSurface | kPlaced)) == kOnSurface; }

  // How many of v's candidates the surface projection takes (a snapping vertex's target is on
  // the surface already, a snapped vertex's are on its curve).
  int projected_count(uint32_t v) const {
    if (!surface || !(flags[v] & kOnSurface) || snapped(v)) return 0;
    return snapping(v) ? kTarget : kQualityCandidates;
  }

  // The candidate positions of v (slot 0: where it is), before projection onto the surface; a
  // snapped vertex's are projected onto its curve here.
  void candidates(uint32_t v, Vec3* out, Visit& visit) const {
    const Vec3 x = j.x[v];
    Vec3 ideal{}, mean{};
    double length = 0;
    int count = 0;
    for (uint32_t k = incident.start[v]; k < incident.start[v + 1]; ++k) {
      const Hex& h = j.hexes[incident.items[k] / 8];
      const int i = int(incident.items[k] % 8);
      Vec3 p = j.x[h[kCorners.opposite[i]]];
      for (int e = 0; e < 3; ++e) {
        const Vec3 n = j.x[h[kCorners.edge[i][e]]];
        p += n - j.x[h[kCorners.diagonal[i][e]]];
        mean += n;
        length += norm(n - x);
      }
      ideal += p;
      ++count;
    }
    ideal = ideal / count;
    mean = mean / (3.0 * count);
    length /= 3.0 * count;
    visit.length = length;
    // Where v is, its hexes' scaled Jacobians are the cached ones (sj, recomputed by place()
    // whenever a corner moves, with the same operations).
    Local now;
    for (uint32_t k = incident.start[v]; k < incident.start[v + 1]; ++k) {
      const double lowest = sj[incident.items[k] / 8];
      if (lowest < now.min) now.min = lowest, visit.worst = k - incident.start[v];
      now.sum += lowest;
    }
    visit.now = now;
    // Gradient of the worst scaled Jacobian at v (central differences on that one point).
    const uint32_t item = incident.items[incident.start[v] + visit.worst];  // hex * 8 + v's corner
    const MovingCorner worst(corners_of(j.x, j.hexes[item / 8]), int(item % 8));
    std::array<double, 9> s;
    worst.scaled_jacobians(x, -kInf, s);
    visit.point = int(std::min_element(s.begin(), s.end()) - s.begin());
    Vec3 gradient{};
    if (now.min > -kInf) {
      const double step = 1e-4 * length;
      for (int a = 0; a < 3; ++a) {
        Vec3 d{};
        d[a] = step;
        worst.scaled_jacobians(x + d, -kInf, s);
        const double up = s[visit.point];
        worst.scaled_jacobians(x - d, -kInf, s);
        const double down = s[visit.point];
        gradient[a] = (up - down) / (2 * step);
      }
    }
    const FeatureCurves::Nearest on = flags[v] & kFeature ? features.nearest(x, target[v]) : FeatureCurves::Nearest{};
    const Vec3 dirs[2] = {constrain(v, ideal - x, on.tangent), constrain(v, mean - x, on.tangent)};
    out[0] = x;
    for (int d = 0; d < 2; ++d) {
      double t = 1;
      for (int s = 0; s < kSteps; ++s, t *= 0.5) out[1 + d * kSteps + s] = x + t * dirs[d];
    }
    const Vec3 g = length * normalized(constrain(v, gradient, on.tangent));
    double t = 0.5;
    for (int s = 0; s < kGradientSteps; ++s, t *= 0.5) out[1 + 2 * kSteps + s] = x + t * g;
    constexpr double nan = std::numeric_limits<double>::quiet_NaN();
    std::fill(out + kTangent, out + kQualityCandidates, Vec3{nan, nan, nan});
    if (searching && now.min < kSearchBelow && surface && (flags[v] & (kOnSurface | kFeature | kFixed)) == kOnSurface &&
        !locked[v]) {
      const Vec3 n = normal[v];
      const Vec3 axis = std::abs(n.x) < 0.5 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
      const Vec3 t1 = normalized(cross(n, axis)), t2 = cross(n, t1);
      for (int a = 0; a < kTangentAngles; ++a) {
        const double angle = 2 * M_PI * a / kTangentAngles;
        const Vec3 d = std::cos(angle) * t1 + std::sin(angle) * t2;
        double step = 0.25 * length;
        for (int s = 0; s < kTangentSteps; ++s, step *= 0.25) out[kTangent + a * kTangentSteps + s] = x + step * d;
      }
    }
    if (ratios) ratio_candidates(v, out + kTangent, length);
    if (snapped(v))
      for (int k = 0; k < (ratios ? kQualityCandidates : kTangent); ++k)
        if (is_finite(out[k])) out[k] = features.nearest(out[k], target[v]).point;
    if (snapping(v)) {
      out[kApproach] = x + 0.5 * (on.point - x);
      out[kApproach + 1] = x + 0.25 * (on.point - x);
      out[kTarget] = on.point;
    }
  }

  // The edge-ratio phase's own candidates (kQualityCandidates - kTangent slots): in each of v's two
  // hexes of largest edge ratio above the cap, where v ends that hex's shortest edge, steps away
  // from its other end that would lengthen it to longest / (kRatioAim cap) (full, half, quarter,
  // eighth); else, where v ends the longest edge, steps towards its other end that would shorten
  // it to kRatioAim cap x shortest (at most half of it). Unused slots are NaN.
  void ratio_candidates(uint32_t v, Vec3* out, double length) const {
    constexpr int kSlots = kQualityCandidates - kTangent, kRatioSteps = 4;
    // The full step aims a little below the cap: aimed at it, rounding left hexes at 8.3001.
    constexpr double kRatioAim = 0.97;
    static_assert(kSlots >= 4 * kRatioSteps);
    constexpr double nan = std::numeric_limits<double>::quiet_NaN();
    std::fill(out, out + kSlots, Vec3{nan, nan, nan});
    const uint32_t b = incident.start[v], e = incident.start[v + 1];
    // The two largest ratios above the cap (by offset; ties: the lower offset).
    uint32_t pick[2] = {e, e};
    for (uint32_t k = b; k < e; ++k) {
      const double r = ratio[incident.items[k] / 8];
      if (!(r > o.max_edge_ratio)) continue;
      if (pick[0] == e || r > ratio[incident.items[pick[0]] / 8]) {
        pick[1] = pick[0];
        pick[0] = k;
      } else if (pick[1] == e || r > ratio[incident.items[pick[1]] / 8]) {
        pick[1] = k;
      }
    }
    const Vec3 x = j.x[v];
    int slot = 0;
    for (uint32_t k : pick) {
      if (k == e) continue;
      const Hex& h = j.hexes[incident.items[k] / 8];
      const int i = int(incident.items[k] % 8);
      // The hex's shortest and longest edges.
      double lo = kInf, hi = 0;
      int lo_edge = 0, hi_edge = 0;
      for (int edge = 0; edge < 12; ++edge) {
        const double l = norm(j.x[h[kHexEdges[edge][0]]] - j.x[h[kHexEdges[edge][1]]]);
        if (l < lo) lo = l, lo_edge = edge;
        if (l > hi) hi = l, hi_edge = edge;
      }
      auto other_end = [&](int edge) {
        const auto& c = kHexEdges[edge];
        return c[0] == i ? c[1] : c[1] == i ? c[0] : -1;
      };
      Vec3 dir{};
      double step = 0;
      if (const int w = other_end(lo_edge); w >= 0) {
        dir = constrain(v, x - j.x[h[w]], Vec3{});
        step = hi / (kRatioAim * o.max_edge_ratio) - lo;
      } else if (const int u = other_end(hi_edge); u >= 0) {
        dir = constrain(v, j.x[h[u]] - x, Vec3{});
        step = std::min(hi - kRatioAim * o.max_edge_ratio * lo, 0.5 * hi);
      }
      const double d = norm(dir);
      if (!(d > 1e-12 * length) || !(step > 0)) continue;
      for (int s = 0; s < kRatioSteps; ++s, step *= 0.5) out[slot++] = x + (step / d) * dir;
    }
  }

  // A move of the edge-ratio phase: among v's candidates, the one that lowers most the excess of
  // its hexes' edge ratios over the cap (the sum of ratio - cap where positive), keeping every
  // hex's ratio at most max(cap, its own), every certificate, and the minimum scaled Jacobian of
  // v's hexes at least min(where it is, ratio_floor) (so the pair's minimum never falls).
  bool ratio_move(uint32_t v, const Vec3* cand, const Visit& visit, Star& star) {
    star.gather(j, incident, v);
    const Vec3 x = j.x[v];
    const uint32_t b = incident.start[v], n = incident.start[v + 1] - b;
    const double cap = o.max_edge_ratio;
    double own[kMaxValence], excess_now = 0;
    for (uint32_t i = 0; i < n; ++i) {
      own[i] = ratio[incident.items[b + i] / 8];
      excess_now += std::max(0.0, own[i] - cap);
    }
    const double floor = std::min(visit.now.min, ratio_floor);
    // Every candidate that lowers the excess (by more than rounding) and keeps the floor; of those,
    // the ones that bring every ratio to the cap rank first, by the minimum scaled Jacobian of v's
    // hexes (the mildest fix), the others by their excess.
    struct Option {
      int k;
      double excess, min;
    };
    Option options[kQualityCandidates];
    double mins[kQualityCandidates][kMaxValence], ratios_at[kQualityCandidates][kMaxValence];
    int count = 0;
    for (int k = 0; k < kQualityCandidates; ++k) {
      const Vec3 y = cand[k];
      if (!is_finite(y) || y == x) continue;
      double excess = 0;
      bool fits = true;
      for (uint32_t i = 0; i < n && fits; ++i) {
        const double r = star.at(i).edge_ratio(y);
        fits = r <= std::max(cap, own[i]);
        ratios_at[count][i] = r;
        excess += std::max(0.0, r - cap);
      }
      if (!fits || !(excess < excess_now - 1e-9 * (excess_now + 1))) continue;
      const Local l = evaluate(v, y, floor, kInf, visit.worst, star, mins[count]);
      if (l.min == -kInf) continue;
      options[count] = {k, excess, l.min};
      ++count;
    }
    int order[kQualityCandidates];
    std::iota(order, order + count, 0);
    std::stable_sort(order, order + count, [&](int p, int q) {
      const Option &a = options[p], &b = options[q];
      if ((a.excess == 0) != (b.excess == 0)) return a.excess == 0;
      return a.excess == 0 ? a.min > b.min : a.excess < b.excess;
    });
    int chosen = -1;
    for (int i = 0; i < count && chosen < 0; ++i)
      if (keeps_certificates(v, cand[options[order[i]].k])) chosen = order[i];
    // Where no candidate brings every ratio to the cap, a free vertex or one on the box runs the
    // compass search of the second phase from the chosen point on the same rules, lowering the
    // excess (not a surface vertex, even off the surface: its moves here are projected ones).
    if ((chosen < 0 || options[chosen].excess > 0) && searches(v) && !(flags[v] & kOnSurface)) {
      Vec3 y = chosen >= 0 ? cand[options[chosen].k] : x;
      double excess = chosen >= 0 ? options[chosen].excess : excess_now;
      double found_mins[kMaxValence], found_ratios[kMaxValence];
      if (ratio_search(v, visit, floor, own, y, excess, found_mins, found_ratios, star)) {
        place(v, y, false, found_mins, found_ratios, false);
        return true;
      }
    }
    if (chosen < 0) return false;
    place(v, cand[options[chosen].k], false, mins[chosen], ratios_at[chosen]);
    return true;
  }

  // The compass search of ratio_move from `y` (excess `excess`): true when a step lowered the
  // excess, then `y`, `excess`, `mins`, `ratios` are at the best point. The steps keep what
  // ratio_move's candidates keep.
  bool ratio_search(uint32_t v, const Visit& visit, double floor, const double* own, Vec3& y, double& excess,
                    double* mins, double* ratios_out, Star& star) const {
    const uint32_t n = incident.start[v + 1] - incident.start[v];
    const double cap = o.max_edge_ratio;
    double trial[kMaxValence], trial_ratios[kMaxValence];
    const auto take = [&](Vec3 z) {
      double e = 0;
      bool fits = true;
      for (uint32_t i = 0; i < n && fits; ++i) {
        trial_ratios[i] = star.at(i).edge_ratio(z);
        fits = trial_ratios[i] <= std::max(cap, own[i]);
        e += std::max(0.0, trial_ratios[i] - cap);
      }
      if (!fits || !(e < excess - 1e-9 * (excess + 1))) return false;
      if (evaluate(v, z, floor, kInf, visit.worst, star, trial).min == -kInf || !keeps_certificates(v, z)) return false;
      excess = e;
      std::copy_n(trial, n, mins);
      std::copy_n(trial_ratios, n, ratios_out);
      return true;
    };
    return compass(v, y, kSearchStart * visit.length, take, [&] { return !(excess > 0); });
  }

  // One sweep; returns the vertices moved.
  std::size_t sweep(const std::vector<std::vector<uint32_t>>& classes, std::size_t& rejected) {
    std::size_t moved = 0;
    std::vector<uint32_t> active;
    std::vector<Vec3> cand;
    std::vector<Vec3> to_project;
    std::vector<uint8_t> accepted;
    std::vector<Visit> visits;
    std::vector<uint8_t> wanted;
    for (const std::vector<uint32_t>& cls : classes) {
      // Which vertices of the colour to visit, in parallel (each reads only sj and its own flags),
      // then listed in colour order.
      wanted.resize(cls.size());
      parallel_chunks(cls.size(), 256, [&](std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
          const uint32_t v = cls[i];
          wanted[i] = 0;
          if (!dirty[v]) continue;
          double lo = kInf;
          for (uint32_t k = incident.start[v]; k < incident.start[v + 1]; ++k)
            lo = std::min(lo, sj[incident.items[k] / 8]);
          if (ratios) {
            // The edge-ratio phase: vertices with a hex above the cap (not a feature vertex still
            // on its way to its target; one on it slides along its curve).
            bool above = false;
            for (uint32_t k = incident.start[v]; k < incident.start[v + 1]; ++k)
              above = above || ratio[incident.items[k] / 8] > o.max_edge_ratio;
            wanted[i] = above && !snapping(v);
            continue;
          }
          // In the second phase an interior vertex is visited only near the hexes the search
          // aims at: the mean was the first phase's work, and visiting every vertex below
          // active_below again took most of the second phase's time (docs/optimize.md). A
          // surface vertex not yet on the surface, or a feature vertex not yet on its target, is
          // visited until a move puts it there.
          const bool interior = searching && !(flags[v] & (kOnSurface | kBesideSurface));
          wanted[i] = lo < (interior ? o.search_active_below : o.active_below) || unplaced(v) || snapping(v);
        }
      });
      active.clear();
      for (std::size_t i = 0; i < cls.size(); ++i)
        if (wanted[i]) active.push_back(cls[i]);
      if (active.empty()) continue;
      cand.resize(active.size() * kCandidates);
      visits.resize(active.size());
      parallel_chunks(active.size(), 16, [&](std::size_t b, std::size_t e) {
        for (std::size_t a = b; a < e; ++a) candidates(active[a], &cand[a * kCandidates], visits[a]);
      });
      // Surface vertices' candidates onto the surface, in one batch.
      to_project.clear();
      for (std::size_t a = 0; a < active.size(); ++a) {
        const int n = projected_count(active[a]);
        for (int k = 0; k < n; ++k)
          if (is_finite(cand[a * kCandidates + k])) to_project.push_back(cand[a * kCandidates + k]);
      }
      if (!to_project.empty()) {
        project_to_surface(*surface, to_project);
        std::size_t next = 0;
        for (std::size_t a = 0; a < active.size(); ++a) {
          const int n = projected_count(active[a]);
          for (int k = 0; k < n; ++k)
            if (is_finite(cand[a * kCandidates + k])) cand[a * kCandidates + k] = to_project[next++];
        }
      }
      accepted.assign(active.size(), 0);
      parallel_chunks(active.size(), 16, [&](std::size_t b, std::size_t e) {
        const auto star = std::make_unique<Star>();
        for (std::size_t a = b; a < e; ++a) {
          accepted[a] = ratios ? ratio_move(active[a], &cand[a * kCandidates], visits[a], *star)
                               : try_move(active[a], &cand[a * kCandidates], visits[a], *star);
        }
      });
      // A refused vertex waits until a neighbour moves; a move wakes every vertex of its hexes. In
      // parallel: no vertex of a colour is a corner of another's hexes, so a refused vertex is
      // written by its own visit alone and the wake-ups all write 1 (the same on any thread).
      parallel_chunks(active.size(), 64, [&](std::size_t b, std::size_t e) {
        for (std::size_t a = b; a < e; ++a) {
          const uint32_t v = active[a];
          if (!accepted[a]) {
            dirty[v] = 0;
            continue;
          }
          for (uint32_t k = incident.start[v]; k < incident.start[v + 1]; ++k)
            for (uint32_t w : j.hexes[incident.items[k] / 8])
              std::atomic_ref<uint8_t>(dirty[w]).store(1, std::memory_order_relaxed);
        }
      });
      for (std::size_t a = 0; a < active.size(); ++a) (accepted[a] ? moved : rejected) += 1;
    }
    return moved;
  }

  bool try_move(uint32_t v, const Vec3* cand, const Visit& visit, Star& star) {
    star.gather(j, incident, v);
    const Vec3 x = j.x[v];
    const Local& now = visit.now;
    const uint32_t worst = visit.worst;
    const uint32_t b = incident.start[v], e = incident.start[v + 1];
    double now_ratio = 0;
    for (uint32_t k = b; k < e; ++k) now_ratio = std::max(now_ratio, ratio[incident.items[k] / 8]);
    const double cap = std::max(now_ratio, o.max_edge_ratio);
    // Each hex's scaled Jacobian and edge ratio at the candidate taken, for place().
    double mins[kQualityCandidates][kMaxValence], ratios[kMaxValence];
    // A feature vertex not yet on its target first tries to get there (all the way, half, a
    // quarter): the first step that keeps the minimum, every certificate and the cap is taken.
    double target_distance = kInf;
    if (snapping(v)) {
      for (const int k : {kTarget, kApproach, kApproach + 1}) {
        const Vec3 y = cand[k];
        if (!is_finite(y) || y == x || !(evaluate(v, y, now.min, cap, 0, star, mins[0]).min > -kInf) ||
            !keeps_certificates(v, y))
          continue;
        place(v, y, reaches_target(v, y), mins[0]);
        return true;
      }
      target_distance = squared_norm(cand[kTarget] - x);
    }
    // Each candidate is compared with the best so far (a higher minimum, or the same minimum
    // and a higher mean; slot 0, a surface vertex put onto the surface where it is, also when it
    // keeps the minimum; any other move must gain more than rounding), so the options kept are
    // ever better; the best of them that keeps every certificate and the edge-ratio cap is taken.
    struct Option {
      Local l;
      int k;
    };
    Option options[kQualityCandidates];
    int n = 0;
    Local best = now;
    for (int k = 0; k < kQualityCandidates; ++k) {
      const Vec3 y = cand[k];
      if (!is_finite(y) || y == x) continue;
      // Never away from the target (the feature would blur).
      if (target_distance < kInf && features.nearest(y, target[v]).squared_distance > target_distance) continue;
      const Local l = evaluate(v, y, best.min, kInf, worst, star, mins[n]);
      if (l.min == -kInf) continue;
      const bool gain = n == 0 ? l.gains_over(now) : l.min > best.min || (l.min == best.min && l.sum > best.sum);
      if (gain || (k == 0 && n == 0)) {
        options[n++] = {l, k};
        best = l;
      }
    }
    int chosen = -1;
    for (int i = n - 1; i >= 0 && chosen < 0; --i) {
      const Vec3 y = cand[options[i].k];
      if (keeps_certificates(v, y) && within_ratio(v, y, cap, star, ratios)) chosen = i;
    }
    const Vec3 y = chosen >= 0 ? cand[options[chosen].k] : x;
    const Local l = chosen >= 0 ? options[chosen].l : now;
    // A surface vertex that a projected candidate puts on the surface takes it (fidelity first).
    if (searching && l.min < kSearchBelow && searches(v) && !(chosen >= 0 && unplaced(v))) {
      double found_mins[kMaxValence];
      Vec3 z = y;
      if (search(v, cand[0], visit, cap, star, z, l, found_mins)) {
        place(v, z, false, found_mins, star.ratios.data(), false);
        return true;
      }
    }
    if (chosen < 0) return false;
    place(v, y, reaches_target(v, y), mins[chosen], ratios);
    return true;
  }

  // Vertices that search (try_move): free vertices, those on a face or edge of the box, and
  // surface vertices not yet on the surface (the search keeps them no farther from it); not
  // those on the surface (every position would need a projection) nor feature vertices.
  bool searches(uint32_t v) const {
    if (flags[v] & (kFixed | kFeature)) return false;
    return !(flags[v] & kOnSurface) || unplaced(v);
  }

  // The compass search of try_move from `y` (where the candidates left v, measured `l`): true
  // when it found a better position, then in `y`, with its hexes' scaled Jacobians in `out` and
  // edge ratios in star.ratios. Every step taken keeps every certificate and the edge-ratio
  // cap, and gains as a candidate must; a surface vertex not on the surface stays within the ball
  // around its closest point `foot` through where it is, so it gets no farther from the surface.
  bool search(uint32_t v, Vec3 foot, const Visit& visit, double cap, Star& star, Vec3& y, Local l, double* out) const {
    const Vec3 x = j.x[v];
    const bool ball = unplaced(v);
    const double radius2 = squared_norm(x - foot);
    if (ball && !is_finite(foot)) return false;
    const uint32_t n = incident.start[v + 1] - incident.start[v];
    double mins[kMaxValence], ratios[kMaxValence];
    const auto take = [&](Vec3 z) {
      if (ball && squared_norm(z - foot) > radius2) return false;
      const Local m = evaluate(v, z, l.min, kInf, visit.worst, star, mins);
      if (m.min == -kInf) return false;
      if (!m.gains_over(l) || !keeps_certificates(v, z) || !within_ratio(v, z, cap, star, ratios)) return false;
      l = m;
      std::copy_n(mins, n, out);
      std::copy_n(ratios, n, star.ratios.data());
      return true;
    };
    return compass(v, y, kSearchStart * visit.length, take, [] { return false; });
  }

  // The compass walk of both searches: from `y`, the first of the 14 directions at `step` (a box
  // vertex keeps its locked coordinates) whose point `take` accepts is where y goes; the step
  // halves when none is; at most kSearchRounds rounds and kSearchHalvings halvings, or until
  // `done`. True when y moved.
  template <class Take, class Done>
  bool compass(uint32_t v, Vec3& y, double step, Take&& take, Done&& done) const {
    bool found = false;
    for (int round = 0, halvings = 0; round < kSearchRounds && halvings <= kSearchHalvings && !done(); ++round) {
      bool gained = false;
      for (const Vec3& dir : kCompass) {
        Vec3 d = step * dir;
        for (int a = 0; a < 3; ++a)
          if (locked[v] >> a & 1) d[a] = 0;
        if (d == Vec3{}) continue;
        const Vec3 z = y + d;
        if (!take(z)) continue;
        y = z;
        gained = found = true;
        break;
      }
      if (!gained) {
        step *= 0.5;
        ++halvings;
      }
    }
    return found;
  }

  // Whether every hex of v keeps its edge ratio at most `cap` with v at y; `out` gets them.
  bool within_ratio(uint32_t v, Vec3 y, double cap, Star& star, double* out) const {
    const uint32_t n = incident.start[v + 1] - incident.start[v];
    for (uint32_t i = 0; i < n; ++i) {
      out[i] = star.at(i).edge_ratio(y);
      if (out[i] > cap) return false;
    }
    return true;
  }

  // Moves v to y (on the surface; on its target, if `arrives`) and records its hexes'
  // scaled Jacobians `mins` and edge ratios `ratios` there (by offset; measured when the move
  // was chosen, ratios also here when not given). Certified hexes were re-certified before.
  void place(uint32_t v, Vec3 y, bool arrives, const double* mins, const double* ratios = nullptr,
             bool projected = true) {
    j.x[v] = y;
    if (projected && surface && (flags[v] & kOnSurface)) flags[v] |= kPlaced;
    if (arrives) flags[v] |= kSnapped;
    const uint32_t b = incident.start[v], n = incident.start[v + 1] - b;
    for (uint32_t i = 0; i < n; ++i) {
      const uint32_t h = incident.items[b + i] / 8;
      sj[h] = mins[i];
      if (ratios) ratio[h] = ratios[i];
      else ratio[h] = edge_ratio(corners_of(j.x, j.hexes[h]));
      if (!certified[h]) certified[h] = bernstein_certified(corners_of(j.x, j.hexes[h]));
    }
  }

  // Starts the edge-ratio phase; `pair_min` is the pair's minimum scaled Jacobian now.
  void begin_ratios(double pair_min) {
    ratios = true;
    ratio_floor = std::max(pair_min, kSearchBelow);
    std::fill(dirty.begin(), dirty.end(), uint8_t(1));
  }

  // The sum over the hexes of their edge ratio's excess over the cap (in hex order).
  double ratio_excess() const {
    double e = 0;
    for (double r : ratio) e += std::max(0.0, r - o.max_edge_ratio);
    return e;
  }

  struct Summary {
    double min = kInf, sum = 0, max_ratio = 0;
    std::size_t certified = 0, below = 0, count = 0, worst = 0, above = 0;
    void join(Summary&& r) {
      above += r.above;
      if (r.min < min) min = r.min, worst = r.worst;
      sum += r.sum;
      max_ratio = std::max(max_ratio, r.max_ratio);
      certified += r.certified;
      below += r.below;
      count += r.count;
    }
  };

  Summary summarize() const {
    return deterministic_reduce(j.hexes.size(), 4096, Summary{}, [&](std::size_t b, std::size_t e, Summary& s) {
      for (std::size_t h = b; h < e; ++h) {
        const HexQuality q = hex_quality(corners_of(j.x, j.hexes[h]));
        if (q.scaled_jacobian < s.min) s.min = q.scaled_jacobian, s.worst = h;
        s.sum += q.scaled_jacobian;
        s.max_ratio = std::max(s.max_ratio, q.edge_ratio);
        s.certified += q.certified();
        s.below += q.scaled_jacobian < 0.3;
        // Above by more than rounding: a hex taken to the cap exactly may read a few ulps above
        // it here (the fitted torus: 20.0000000000016).
        s.above += q.edge_ratio > o.max_edge_ratio * (1 + 1e-9);
        ++s.count;
      }
    });
  }
};

}  // namespace

OptimizeStats optimize(MeshPair& meshes, const SignedDistance* surface, const OptimizeOptions& options,
                       const TriangleSurface* triangles) {
  const double t0 = now();
  OptimizeStats st;
  const bool pair = !meshes.outside.hexes.empty();
  Joined j = join(meshes);
  st.hexes = j.hexes.size();
  st.vertices = j.x.size();
  if (j.hexes.empty()) return st;
  Optimizer opt(j, surface, triangles, options, meshes.inside, pair);
  st.feature_curves = opt.features.curves();
  st.feature_edges = opt.features.sharp_edges();
  for (std::size_t v = 0; v < j.x.size(); ++v) {
    if ((opt.flags[v] & (kFeature | kFixed)) == kFeature) {
      ++st.feature_vertices;
      ++(opt.features.is_corner(opt.target[v]) ? st.corner_vertices : st.curve_vertices);
    }
    if (opt.flags[v] & kFixed) {
      ++st.fixed_vertices;
    } else if (opt.flags[v] & kOnSurface) {
      ++st.surface_vertices;
    } else if (opt.locked[v]) {
      ++st.box_vertices;
    } else {
      ++st.free_vertices;
    }
  }
  const Optimizer::Summary before = opt.summarize();
  st.min_sj_before = before.min;
  st.mean_sj_before = before.sum / double(before.count);
  st.max_edge_ratio_before = before.max_ratio;
  st.certified_before = before.certified;
  st.below_0_3_before = before.below;
  st.above_edge_ratio_cap_before = before.above;
  const auto classes = opt.colour();
  st.colours = int(classes.size());
  double last_min = before.min, last_mean = st.mean_sj_before;
  std::size_t last_below = before.below;
  int stalls = 0;
  const double ts = now(), cs = cpu_seconds();
  for (int s = 0; s < options.max_sweeps; ++s) {
    const std::size_t moved = opt.sweep(classes, st.moves_rejected);
    st.moves_accepted += moved;
    ++st.sweeps;
    // The minimum from the cached per-hex values (exact: each is recomputed when a corner moves).
    double lo = kInf, sum = 0;
    std::size_t below = 0;
    for (double v : opt.sj) lo = std::min(lo, v), sum += v, below += v < kSearchBelow;
    const double mean = sum / double(opt.sj.size());
    st.min_per_sweep.push_back(lo);
    // In the second phase fewer hexes below kSearchBelow is progress too: the search works on
    // them one cluster at a time, and the minimum rises only once the last one at it has.
    const bool stalled =
        moved == 0 || (lo - last_min < options.tolerance && mean - last_mean < 10 * options.tolerance &&
                       (!opt.searching || below >= last_below));
    stalls = stalled ? stalls + 1 : 0;
    if (stalled) {
      if (!options.search) break;
      // The search's gains come in bursts: it stops after three stalled sweeps in a row.
      if (opt.searching && (moved == 0 || stalls >= 3)) break;
      // The plain sweeps have stalled: on with the search, every vertex visited again.
      if (!opt.searching) {
        st.plain_sweeps = st.sweeps;
        st.plain_sweep_seconds = now() - ts;
        opt.searching = true;
        stalls = 0;
        std::fill(opt.dirty.begin(), opt.dirty.end(), uint8_t(1));
      }
    }
    last_min = lo;
    last_mean = mean;
    last_below = below;
  }
  if (!opt.searching) st.plain_sweeps = st.sweeps, st.plain_sweep_seconds = now() - ts;
  // The third phase (after the search; not in the plain optimiser): the edge ratios above the
  // cap, while the sum of their excess falls by more than a thousandth per sweep.
  if (options.search && options.ratio_sweeps > 0) {
    const double tr = now();
    opt.begin_ratios(*std::min_element(opt.sj.begin(), opt.sj.end()));
    double last_excess = opt.ratio_excess();
    for (int s = 0; s < options.ratio_sweeps && last_excess > 0; ++s) {
      const std::size_t moved = opt.sweep(classes, st.moves_rejected);
      st.moves_accepted += moved;
      ++st.sweeps;
      ++st.ratio_sweeps;
      st.min_per_sweep.push_back(*std::min_element(opt.sj.begin(), opt.sj.end()));
      const double excess = opt.ratio_excess();
      if (moved == 0 || !(excess < (1 - 1e-3) * last_excess)) break;
      last_excess = excess;
    }
    st.ratio_sweep_seconds = now() - tr;
  }
  st.sweep_seconds = now() - ts;
  st.sweep_cpu_seconds = cpu_seconds() - cs;
  const Optimizer::Summary after = opt.summarize();
  st.min_sj_after = after.min;
  st.mean_sj_after = after.sum / double(after.count);
  st.max_edge_ratio_after = after.max_ratio;
  st.certified_after = after.certified;
  st.below_0_3_after = after.below;
  st.above_edge_ratio_cap_after = after.above;
  for (std::size_t v = 0; v < j.x.size(); ++v) st.snapped_vertices += opt.snapped(uint32_t(v));
  for (std::size_t h = 0; h < j.hexes.size(); ++h) {
    if (opt.sj[h] >= 0.3) continue;
    bool fixed = false;
    for (uint32_t v : j.hexes[h]) fixed = fixed || (opt.flags[v] & kFixed);
    st.below_0_3_touching_fixed += fixed;
  }
  // The worst hex and what holds its corners.
  WorstHex& w = st.worst;
  const std::size_t h = after.worst;
  w.region = h < j.inside_hexes ? kInside : kOutside;
  w.hex = h < j.inside_hexes ? h : h - j.inside_hexes;
  const HexCorners c = corners_of(j.x, j.hexes[h]);
  for (const Vec3& p : c) w.centre += p / 8.0;
  const HexQuality q = hex_quality(c);
  w.scaled_jacobian = q.scaled_jacobian;
  w.edge_ratio = q.edge_ratio;
  for (uint32_t v : j.hexes[h]) {
    if (opt.flags[v] & kFixed) ++w.fixed_corners;
    else if (opt.flags[v] & kOnSurface) ++w.surface_corners;
    else if (opt.locked[v]) ++w.box_corners;
  }
  // Back into both meshes: an interface vertex gets the same coordinates in each.
  std::copy_n(j.x.begin(), meshes.inside.points.size(), meshes.inside.points.begin());
  for (std::size_t k = 0; k < meshes.outside.points.size(); ++k) meshes.outside.points[k] = j.x[j.outside_point[k]];
  st.seconds = now() - t0;
  return st;
}

}  // namespace mchex
