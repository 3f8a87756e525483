#include "core/pipeline/regions.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <numeric>
#include <optional>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/base/error.h"
#include "core/base/parallel.h"
#include "core/mesh/quality.h"
#include "core/sdf/sdf.h"
#include "core/sdf/winding_number.h"

namespace mchex {
namespace {

// One bit per region in a word: what the labelling carries per hex.
constexpr std::size_t kMaxRegions = 64;

// Whether each point lies in the solid. A region's surface is closed and (after repair)
// consistently oriented, where the nearest feature's pseudonormal decides exactly; it costs a
// quarter of the winding number's time on points near the surface, as most of these are.
// Under --no-repair the solid's own rule decides.
std::vector<std::uint8_t> inside_flags(const Solid& solid, std::span<const Vec3> points) {
  std::vector<std::uint8_t> in(points.size());
  std::vector<double> v(points.size());
  const auto& sdf = static_cast<const SurfaceSdf&>(solid.sdf());
  if (solid.facts().surface.consistently_oriented) sdf.evaluate_pseudonormal(points, v);
  else sdf.evaluate(points, v);
  for (std::size_t i = 0; i < v.size(); ++i) in[i] = v[i] > 0;
  return in;
}

// The arrangement cell of each point: bit j set where region j (input order) holds it.
std::vector<std::uint64_t> arrangement_bits(const RegionSet& regions, std::span<const Vec3> points) {
  std::vector<std::uint64_t> bits(points.size(), 0);
  for (std::size_t j = 0; j < regions.size(); ++j) {
    const std::vector<std::uint8_t> in = inside_flags(regions.region(j), points);
    for (std::size_t i = 0; i < points.size(); ++i) bits[i] |= std::uint64_t{in[i]} << j;
  }
  return bits;
}

int32_t label_of(std::uint64_t bits, const std::vector<int>& priority) {
  for (int r : priority)
    if (bits >> r & 1) return r + 1;
  return 0;
}

// The points of a span by their exact coordinates (+0 and -0 one point, as weld_vertices has
// them): an open-addressing table of indices into the span, filled in parallel (a slot is taken
// by compare-and-swap) and 4 bytes a slot, since the labelling indexes millions of points and a
// table of whole keys filled in turn cost half its time (measured: 1.7 s of 3.6 s on 4.4 M
// hexes). Linear probing never empties a slot, so every copy of a point lies between its home
// slot and the next empty one, whatever order the threads took them in: find returns the
// lowest index among them, the same on any thread count.
class PointTable {
 public:
  static constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();
  explicit PointTable(std::span<const Vec3> points) : points_(points) {
    std::size_t size = 16;
    while (size < 2 * points.size()) size *= 2;
    slots_ = std::make_unique<std::atomic<uint32_t>[]>(size);
    mask_ = size - 1;
    parallel_for(size, [&](std::size_t i) { slots_[i].store(kNone, std::memory_order_relaxed); });
    parallel_for(points.size(), [&](std::size_t p) {
      for (std::size_t i = hash(key_of(points[p])) & mask_;; i = (i + 1) & mask_) {
        uint32_t expected = kNone;
        if (slots_[i].compare_exchange_strong(expected, uint32_t(p), std::memory_order_relaxed)) return;
      }
    });
  }
  // The lowest index of a point equal to p, or kNone.
  uint32_t find(Vec3 p) const {
    const Key k = key_of(p);
    uint32_t found = kNone;
    for (std::size_t i = hash(k) & mask_;; i = (i + 1) & mask_) {
      const uint32_t at = slots_[i].load(std::memory_order_relaxed);
      if (at == kNone) return found;
      if (key_of(points_[at]) == k) found = std::min(found, at);
    }
  }

 private:
  struct Key {
    std::uint64_t w[3];
    bool operator==(const Key&) const = default;
  };
  static Key key_of(Vec3 p) {
    Key k;
    const double c[3] = {p.x + 0.0, p.y + 0.0, p.z + 0.0};
    std::memcpy(k.w, c, sizeof c);
    return k;
  }
  // splitmix64's finaliser over the three words: coordinates of a lattice share their low bits.
  static std::uint64_t mix(std::uint64_t z) {
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  static std::size_t hash(const Key& k) { return std::size_t(mix(mix(mix(k.w[0]) ^ k.w[1]) ^ k.w[2])); }
  std::span<const Vec3> points_;
  std::unique_ptr<std::atomic<uint32_t>[]> slots_;
  std::size_t mask_ = 0;
};

// Cells of a uniform grid (edge `cell`, anchored at the origin) as one word: 21 bits an axis,
// offset to keep negative indices apart. Indices past that range wrap; a wrapped key only merges
// far cells into one bucket, where the exact tests that follow sort them out.
std::int64_t cell_index(double x, double cell) { return std::int64_t(std::floor(x / cell)); }
std::uint64_t cell_key(std::int64_t x, std::int64_t y, std::int64_t z) {
  constexpr std::int64_t kOffset = std::int64_t{1} << 20, kMask = (std::int64_t{1} << 21) - 1;
  return std::uint64_t((x + kOffset) & kMask) | std::uint64_t((y + kOffset) & kMask) << 21 |
         std::uint64_t((z + kOffset) & kMask) << 42;
}
// Every cell a box covers.
template <class F>
void for_cells(const Box& box, double cell, F&& f) {
  for (std::int64_t z = cell_index(box.lo.z, cell); z <= cell_index(box.hi.z, cell); ++z)
    for (std::int64_t y = cell_index(box.lo.y, cell); y <= cell_index(box.hi.y, cell); ++y)
      for (std::int64_t x = cell_index(box.lo.x, cell); x <= cell_index(box.hi.x, cell); ++x) f(cell_key(x, y, z));
}

Box triangle_box(const TriangleSurface& s, const std::array<uint32_t, 3>& t) {
  Box b;
  for (uint32_t v : t) b.extend(s.vertices[v]);
  return b;
}

bool boxes_overlap(const Box& a, const Box& b) {
  return a.lo.x <= b.hi.x && b.lo.x <= a.hi.x && a.lo.y <= b.hi.y && b.lo.y <= a.hi.y && a.lo.z <= b.hi.z &&
         b.lo.z <= a.hi.z;
}

// Where triangle p's plane is crossed by triangle t: the one or two points of t on it (its
// vertices on the plane, and the crossings of the edges whose ends lie strictly on either side),
// with the ends' signed distances `d`. Fewer than two points: t only touches the plane.
int plane_cut(const std::array<Vec3, 3>& t, const std::array<double, 3>& d, std::array<Vec3, 2>& cut) {
  int n = 0;
  for (int k = 0; k < 3 && n < 2; ++k) {
    const int l = (k + 1) % 3;
    if (d[k] == 0) cut[n++] = t[k];
    if (n < 2 && ((d[k] < 0 && d[l] > 0) || (d[k] > 0 && d[l] < 0)))
      cut[n++] = t[k] + (d[k] / (d[k] - d[l])) * (t[l] - t[k]);
  }
  return n;
}

// The segment two triangles share when they cross (the overlap, along their planes' common line,
// of each one's cut by the other's plane); nothing when they miss or only touch.
std::optional<Segment> triangles_cross(const std::array<Vec3, 3>& a, const std::array<Vec3, 3>& b) {
  const Vec3 na = cross(a[1] - a[0], a[2] - a[0]), nb = cross(b[1] - b[0], b[2] - b[0]);
  std::array<double, 3> da, db;
  for (int k = 0; k < 3; ++k) da[k] = dot(nb, a[k] - b[0]), db[k] = dot(na, b[k] - a[0]);
  // Each must have corners strictly on both sides of the other's plane: triangles that only touch
  // (shells sharing an edge or a face, one lying on the other) do not cross.
  const auto both_sides = [](const std::array<double, 3>& d) {
    return std::min({d[0], d[1], d[2]}) < 0 && std::max({d[0], d[1], d[2]}) > 0;
  };
  if (!both_sides(da) || !both_sides(db)) return std::nullopt;
  std::array<Vec3, 2> ca, cb;
  if (plane_cut(a, da, ca) < 2 || plane_cut(b, db, cb) < 2) return std::nullopt;
  const Vec3 line = cross(na, nb);
  double a0 = dot(line, ca[0]), a1 = dot(line, ca[1]), b0 = dot(line, cb[0]), b1 = dot(line, cb[1]);
  if (a0 > a1) std::swap(a0, a1), std::swap(ca[0], ca[1]);
  if (b0 > b1) std::swap(b0, b1), std::swap(cb[0], cb[1]);
  if (std::max(a0, b0) > std::min(a1, b1)) return std::nullopt;
  return Segment{a0 >= b0 ? ca[0] : cb[0], a1 <= b1 ? ca[1] : cb[1]};
}

double squared_distance_to_segment(Vec3 p, const Segment& s) {
  return squared_norm(p - closest_on_segment(p, s[0], s[1]));
}

}  // namespace

RegionSet::RegionSet(std::span<const SolidSource> sources, StageClock& clock, bool quiet, const SolidOptions& options,
                     std::span<const int> order) {
  if (sources.size() < 2) throw InputError("several regions need at least two input surfaces");
  if (sources.size() > kMaxRegions)
    throw InputError(fmt::format("at most {} regions, got {}", kMaxRegions, sources.size()));
  for (const SolidSource& s : sources)
    if (s.path.empty() && !s.surface) throw InputError("every region is a surface file (a built-in shape is not)");
  for (const SolidSource& s : sources) {
    solids_.push_back(std::make_unique<Solid>(s, clock, quiet, options));
    const SolidFacts& f = solids_.back()->facts();
    // After repair a closed shell faces outward: its volume is what it encloses.
    enclosed_.push_back(std::abs(f.surface.volume));
    if (!(enclosed_.back() > 0) || !f.surface.closed)
      throw InputError(f.name + ": a region needs a closed surface that encloses a volume (" +
                       std::to_string(f.surface.boundary_edges) + " boundary edges, volume " +
                       fmt::format("{:.3g}", f.surface.volume) + ")");
  }
  const int k = int(sources.size());
  if (!order.empty()) {
    std::vector<int> sorted(order.begin(), order.end());
    std::sort(sorted.begin(), sorted.end());
    std::vector<int> expected(k);
    std::iota(expected.begin(), expected.end(), 1);
    if (sorted != expected)
      throw InputError(
          fmt::format("--region-order must list each of the regions 1..{} once, got {}", k, fmt::join(order, ",")));
    for (int r : order) priority_.push_back(r - 1);
  } else {
    priority_.resize(k);
    std::iota(priority_.begin(), priority_.end(), 0);
    std::stable_sort(priority_.begin(), priority_.end(), [&](int a, int b) { return enclosed_[a] < enclosed_[b]; });
  }

  clock.run("regions", [&] {
    for (const auto& s : solids_) {
      const TriangleSurface& t = *s->surface();
      const auto base = uint32_t(combined_.vertices.size());
      combined_.vertices.insert(combined_.vertices.end(), t.vertices.begin(), t.vertices.end());
      for (auto tri : t.triangles) combined_.triangles.push_back({tri[0] + base, tri[1] + base, tri[2] + base});
    }
    weld_vertices(combined_);
    // A face two touching regions share is crossed twice, so the parity does not change across it:
    // of k equal faces, k mod 2 stay, and the parity field's surface is the shells' union's.
    // Touching regions are then told apart by their labels alone (docs/regions.md). Faces in order
    // of their sorted corners.
    std::vector<uint32_t> order(combined_.triangles.size());
    std::iota(order.begin(), order.end(), 0u);
    auto sorted = [&](uint32_t t) {
      std::array<uint32_t, 3> c = combined_.triangles[t];
      std::sort(c.begin(), c.end());
      return c;
    };
    std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
      const auto ca = sorted(a), cb = sorted(b);
      return ca != cb ? ca < cb : a < b;
    });
    std::vector<uint8_t> drop(order.size(), 0);
    for (std::size_t i = 0, j; i < order.size(); i = j) {
      for (j = i + 1; j < order.size() && sorted(order[j]) == sorted(order[i]);) ++j;
      if (j - i < 2) continue;
      shared_faces_ += (j - i) / 2;
      for (std::size_t k = i + (j - i) % 2; k < j; ++k) drop[order[k]] = 1;
    }
    std::vector<std::array<uint32_t, 3>> kept;
    kept.reserve(combined_.triangles.size() - 2 * shared_faces_);
    for (std::size_t t = 0; t < drop.size(); ++t)
      if (!drop[t]) kept.push_back(combined_.triangles[t]);
    combined_.triangles = std::move(kept);
    for (std::size_t i = 0; i < solids_.size(); ++i)
      for (std::size_t j = i + 1; j < solids_.size(); ++j) {
        const std::vector<Segment> s = crossing_segments(*solids_[i]->surface(), *solids_[j]->surface());
        junctions_.insert(junctions_.end(), s.begin(), s.end());
      }
  });
}

std::string RegionSet::name() const {
  std::string n;
  for (const auto& s : solids_) n += (n.empty() ? "" : " + ") + s->facts().name;
  return n;
}

MeshPair label_regions(const MeshPair& parity, std::span<const Vec3> grid_points, const RegionSet& regions,
                       RegionStats* stats) {
  const HexMesh& odd = parity.inside;
  const HexMesh& even = parity.outside;
  const std::size_t n_odd = odd.hexes.size(), n = n_odd + even.hexes.size();
  auto corners = [&](std::size_t h) { return h < n_odd ? odd.corners(h) : even.corners(h - n_odd); };

  // Midpoint subdivision gives each hex exactly one corner of its polyhedron: where that is a grid
  // point, the hex lies in the grid point's arrangement cell, so the k winding numbers are taken
  // once per grid point rather than per hex; the others (a crossing, or a local refinement's inner
  // point, as their corner) take their centroid's.
  constexpr uint32_t kNone = PointTable::kNone;
  const PointTable grid_index(grid_points);
  auto grid_ids = [&](const HexMesh& m) {
    std::vector<uint32_t> g(m.points.size());
    parallel_for(m.points.size(), [&](std::size_t i) { g[i] = grid_index.find(m.points[i]); });
    return g;
  };
  const std::vector<uint32_t> odd_grid = grid_ids(odd), even_grid = grid_ids(even);
  std::vector<uint32_t> source(n, kNone);  // the grid point a hex takes its cell from
  parallel_for(n, [&](std::size_t h) {
    const Hex& hex = h < n_odd ? odd.hexes[h] : even.hexes[h - n_odd];
    const std::vector<uint32_t>& g = h < n_odd ? odd_grid : even_grid;
    for (uint32_t v : hex)
      if (g[v] != kNone) source[h] = g[v];
  });
  std::vector<uint8_t> used(grid_points.size(), 0);
  for (uint32_t g : source)
    if (g != kNone) used[g] = 1;
  // The points to measure: the grid points in use, then the centroids of the other hexes.
  std::vector<Vec3> at;
  std::vector<uint32_t> slot(grid_points.size(), kNone);
  for (std::size_t i = 0; i < grid_points.size(); ++i)
    if (used[i]) slot[i] = uint32_t(at.size()), at.push_back(grid_points[i]);
  std::vector<uint32_t> hex_slot(n);
  for (std::size_t h = 0; h < n; ++h) {
    if (source[h] != kNone) {
      hex_slot[h] = slot[source[h]];
      continue;
    }
    Vec3 c{0, 0, 0};
    for (const Vec3& p : corners(h)) c = c + p;
    hex_slot[h] = uint32_t(at.size());
    at.push_back((1.0 / 8) * c);
  }
  const std::vector<std::uint64_t> measured = arrangement_bits(regions, at);
  std::vector<std::uint64_t> bits(n);
  for (std::size_t h = 0; h < n; ++h) bits[h] = measured[hex_slot[h]];

  // A point on the other side of the true shell than MCHex put its hex (a centroid between the
  // interface and the shell, a grid point the zero rule moved off it): the nearest shell's bit is
  // the wrong one.
  std::vector<std::size_t> wrong;
  for (std::size_t h = 0; h < n; ++h)
    if ((std::popcount(bits[h]) % 2 == 1) != (h < n_odd)) wrong.push_back(h);
  if (!wrong.empty()) {
    std::vector<Vec3> p(wrong.size());
    for (std::size_t i = 0; i < wrong.size(); ++i) p[i] = at[hex_slot[wrong[i]]];
    std::vector<double> nearest(wrong.size(), std::numeric_limits<double>::infinity()), d(wrong.size());
    std::vector<int> which(wrong.size(), 0);
    for (std::size_t j = 0; j < regions.size(); ++j) {
      static_cast<const SurfaceSdf&>(regions.region(j).sdf()).distance(p, d);
      for (std::size_t i = 0; i < wrong.size(); ++i)
        if (d[i] < nearest[i]) nearest[i] = d[i], which[i] = int(j);
    }
    for (std::size_t i = 0; i < wrong.size(); ++i) bits[wrong[i]] ^= std::uint64_t{1} << which[i];
  }

  // One point set: the odd mesh's points, then the even mesh's that the odd one does not have
  // (the first of equal ones, in even order), each even point mapped to its place in it.
  std::vector<Vec3> points = odd.points;
  std::vector<uint32_t> even_to(even.points.size()), even_first(even.points.size());
  {
    const PointTable odd_index(odd.points), even_index(even.points);
    parallel_for(even.points.size(), [&](std::size_t i) {
      even_to[i] = odd_index.find(even.points[i]);
      even_first[i] = even_index.find(even.points[i]);
    });
  }
  for (std::size_t i = 0; i < even.points.size(); ++i) {
    if (even_to[i] != kNone) continue;
    if (even_first[i] != i) {
      even_to[i] = even_to[even_first[i]];
      continue;
    }
    even_to[i] = uint32_t(points.size());
    points.push_back(even.points[i]);
  }

  const int32_t outside_label = int32_t(regions.size() + 1);
  std::vector<Hex> in_hexes, out_hexes;
  std::vector<int32_t> in_labels;
  RegionStats s;
  s.regions.resize(regions.size());
  for (std::size_t j = 0; j < regions.size(); ++j) {
    s.regions[j].name = regions.region(j).facts().name;
    s.regions[j].enclosed_volume = regions.enclosed_volumes()[j];
  }
  // Labels and volumes in parallel, summed in hex order below (the same sums as one pass).
  std::vector<int32_t> labels(n);
  std::vector<double> volumes(n);
  parallel_for(n, [&](std::size_t h) {
    labels[h] = label_of(bits[h], regions.priority());
    if (labels[h] != 0) volumes[h] = hex_volume(corners(h));
  });
  const std::size_t n_out = std::size_t(std::count(labels.begin(), labels.end(), 0));
  in_hexes.reserve(n - n_out);
  in_labels.reserve(n - n_out);
  out_hexes.reserve(n_out);
  for (std::size_t h = 0; h < n; ++h) {
    Hex hex = h < n_odd ? odd.hexes[h] : even.hexes[h - n_odd];
    if (h >= n_odd)
      for (uint32_t& v : hex) v = even_to[v];
    const int32_t label = labels[h];
    if (label == 0) {
      out_hexes.push_back(hex);
      ++s.outside_hexes;
      continue;
    }
    in_hexes.push_back(hex);
    in_labels.push_back(label);
    RegionStats::Region& r = s.regions[label - 1];
    ++r.hexes;
    r.volume += volumes[h];
  }
  MeshPair out{compact_mesh(points, std::move(in_hexes), 0), compact_mesh(points, std::move(out_hexes), outside_label)};
  out.inside.region = std::move(in_labels);
  for (int r : regions.priority()) s.priority.push_back(r + 1);
  s.shared_faces = regions.shared_faces();
  s.junction_segments = regions.junctions().size();
  s.flipped = wrong.size();
  if (stats) *stats = std::move(s);
  return out;
}

std::vector<TriangleSurface> split_shells(const TriangleSurface& surface) {
  const std::size_t n = surface.triangles.size();
  // Every triangle's three edges as (low vertex, high vertex, triangle), sorted: equal edges run
  // together.
  std::vector<std::array<uint32_t, 3>> edges;
  edges.reserve(3 * n);
  for (uint32_t t = 0; t < n; ++t)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = surface.triangles[t][k], b = surface.triangles[t][(k + 1) % 3];
      edges.push_back({std::min(a, b), std::max(a, b), t});
    }
  std::sort(edges.begin(), edges.end());
  std::vector<uint32_t> parent(n);
  std::iota(parent.begin(), parent.end(), 0u);
  auto root = [&](uint32_t t) {
    while (parent[t] != t) t = parent[t] = parent[parent[t]];
    return t;
  };
  for (std::size_t i = 0, j; i < edges.size(); i = j) {
    for (j = i + 1; j < edges.size() && edges[j][0] == edges[i][0] && edges[j][1] == edges[i][1];) ++j;
    if (j - i != 2) continue;
    const uint32_t a = root(edges[i][2]), b = root(edges[i + 1][2]);
    parent[std::max(a, b)] = std::min(a, b);  // the root is the component's first triangle
  }
  // Triangles by shell, shells by first triangle; then each shell's vertices renumbered in
  // first-use order through one array, reset after each shell (O(V + T) whatever the count).
  constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();
  std::vector<uint32_t> shell_of(n, kNone);
  std::vector<std::vector<uint32_t>> members;
  for (uint32_t t = 0; t < n; ++t) {
    const uint32_t r = root(t);
    if (shell_of[r] == kNone) shell_of[r] = uint32_t(members.size()), members.emplace_back();
    members[shell_of[r]].push_back(t);
  }
  std::vector<TriangleSurface> shells(members.size());
  std::vector<uint32_t> local(surface.vertices.size(), kNone);
  for (std::size_t m = 0; m < members.size(); ++m) {
    TriangleSurface& s = shells[m];
    std::vector<uint32_t> used;
    for (const uint32_t t : members[m]) {
      std::array<uint32_t, 3> tri{};
      for (int k = 0; k < 3; ++k) {
        const uint32_t v = surface.triangles[t][k];
        if (local[v] == kNone)
          local[v] = uint32_t(s.vertices.size()), s.vertices.push_back(surface.vertices[v]), used.push_back(v);
        tri[k] = local[v];
      }
      s.triangles.push_back(tri);
    }
    for (const uint32_t v : used) local[v] = kNone;
  }
  return shells;
}

std::vector<Segment> crossing_segments(const TriangleSurface& a, const TriangleSurface& b) {
  if (a.triangles.empty() || b.triangles.empty()) return {};
  // b's triangles in a grid of cells about their mean size (each in every cell its box covers),
  // so each of a's triangles meets only the few of b's around it.
  std::vector<Box> b_boxes(b.triangles.size());
  Box b_all;
  double extent = 0;
  for (std::size_t t = 0; t < b.triangles.size(); ++t) {
    b_boxes[t] = triangle_box(b, b.triangles[t]);
    b_all.extend(b_boxes[t].lo);
    b_all.extend(b_boxes[t].hi);
    const Vec3 e = b_boxes[t].size();
    extent += std::max({e.x, e.y, e.z});
  }
  // At most about 2^20 cells a side over b: a few huge triangles among small ones stay bounded.
  const double cell = std::max(
      {extent / double(b.triangles.size()), b_all.diagonal() / double(1 << 20), std::numeric_limits<double>::min()});
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> grid;
  for (std::size_t t = 0; t < b.triangles.size(); ++t)
    for_cells(b_boxes[t], cell, [&](std::uint64_t key) { grid[key].push_back(std::uint32_t(t)); });

  std::vector<std::vector<Segment>> found(a.triangles.size());
  parallel_for(a.triangles.size(), [&](std::size_t t) {
    const Box box = triangle_box(a, a.triangles[t]);
    if (!boxes_overlap(box, b_all)) return;
    std::vector<std::uint32_t> near;
    for_cells(box, cell, [&](std::uint64_t key) {
      const auto it = grid.find(key);
      if (it != grid.end()) near.insert(near.end(), it->second.begin(), it->second.end());
    });
    std::sort(near.begin(), near.end());
    near.erase(std::unique(near.begin(), near.end()), near.end());
    std::array<Vec3, 3> ta;
    for (int k = 0; k < 3; ++k) ta[k] = a.vertices[a.triangles[t][k]];
    for (std::uint32_t u : near) {
      if (!boxes_overlap(box, b_boxes[u])) continue;
      std::array<Vec3, 3> tb;
      for (int k = 0; k < 3; ++k) tb[k] = b.vertices[b.triangles[u][k]];
      if (const auto s = triangles_cross(ta, tb)) found[t].push_back(*s);
    }
  });
  std::vector<Segment> all;
  for (auto& f : found) all.insert(all.end(), f.begin(), f.end());
  return all;
}

JunctionLift::JunctionLift(std::span<const Segment> curves, std::vector<double> radii)
    : curves_(curves), radii_(std::move(radii)) {
  if (radii_.size() != curves.size()) throw std::invalid_argument("JunctionLift: one radius per segment");
  if (!std::all_of(radii_.begin(), radii_.end(), [](double r) { return r > 0; }))
    throw std::invalid_argument("JunctionLift: every radius must be positive");
  if (curves.empty()) return;
  min_radius_ = *std::min_element(radii_.begin(), radii_.end());
  max_radius_ = *std::max_element(radii_.begin(), radii_.end());
  // Cells no smaller than the largest radius (a point's reach spans at most 3 an axis) nor than
  // the segments' mean extent (a segment spans a few cells, however small the radius).
  std::vector<Box> boxes(curves.size());
  double extent = 0;
  for (std::size_t i = 0; i < curves.size(); ++i) {
    boxes[i].extend(curves[i][0]);
    boxes[i].extend(curves[i][1]);
    const Vec3 e = boxes[i].size();
    extent += std::max({e.x, e.y, e.z});
  }
  cell_ = std::max(max_radius_, extent / double(curves.size()));
  for (std::size_t i = 0; i < curves.size(); ++i)
    for_cells(boxes[i], cell_, [&](std::uint64_t key) { cells_[key].push_back(std::uint32_t(i)); });
}

template <class F>
void JunctionLift::for_segments_within(Vec3 p, double reach, F&& f) const {
  const Vec3 r{reach, reach, reach};
  Box box;
  box.extend(p - r);
  box.extend(p + r);
  for_cells(box, cell_, [&](std::uint64_t key) {
    const auto it = cells_.find(key);
    if (it != cells_.end())
      for (std::uint32_t s : it->second) f(s, squared_distance_to_segment(p, curves_[s]));
  });
}

std::vector<std::uint8_t> JunctionLift::near(std::span<const Vec3> points, double factor) const {
  std::vector<std::uint8_t> out(points.size(), 0);
  if (cells_.empty()) return out;
  parallel_for(points.size(), [&](std::size_t i) {
    for_segments_within(points[i], factor * max_radius_, [&](std::uint32_t s, double d2) {
      if (d2 < factor * factor * radii_[s] * radii_[s]) out[i] = 1;
    });
  });
  return out;
}

std::size_t JunctionLift::lift(std::span<const Vec3> points, std::span<double> values) const {
  if (cells_.empty()) return 0;
  std::vector<std::uint8_t> changed(points.size(), 0);
  parallel_for(points.size(), [&](std::size_t i) {
    // The field is the distance to the nearest shell, so only a point nearer than a radius to
    // a shell can be nearer than that to a curve on it.
    if (!(std::abs(values[i]) < max_radius_)) return;
    double lift = 0;
    for_segments_within(points[i], max_radius_, [&](std::uint32_t s, double d2) {
      if (d2 < radii_[s] * radii_[s]) lift = std::max(lift, radii_[s] - std::sqrt(d2));
    });
    if (lift > 0) values[i] += lift, changed[i] = 1;
  });
  return std::size_t(std::count(changed.begin(), changed.end(), std::uint8_t{1}));
}

}  // namespace mchex
