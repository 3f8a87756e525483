// Orientation repair: cleaning, consistent orientation per component, outward shells with
// inward cavities, and the self-intersection report (the steps of core/mesh/orientation.h).
#include "core/mesh/orientation.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "core/base/parallel.h"

namespace mchex {
namespace {

using Triangle = std::array<uint32_t, 3>;
constexpr uint32_t kNone = 0xffffffffu;

// The face's vertices sorted: equal for exact duplicates, and the order in which "lowest
// triangle" is meant (it does not change when the input triangles are permuted).
Triangle sorted_key(Triangle t) {
  std::sort(t.begin(), t.end());
  return t;
}

// Whether the face runs as an even permutation of its sorted vertices.
bool even_orientation(const Triangle& t) {
  const int m = t[0] < t[1] ? (t[0] < t[2] ? 0 : 2) : (t[1] < t[2] ? 1 : 2);
  return t[(m + 1) % 3] < t[(m + 2) % 3];
}

void flip(Triangle& t) { std::swap(t[1], t[2]); }

// ---------------------------------------------------------------------------------------------
// Step 1: degenerate and duplicate faces.

// Drops the faces not kept and then the vertices that only they used, keeping the order of the
// rest, so that bounds() is still the surface's. Vertices no face used are left alone.
void remove_faces(TriangleSurface& surface, const std::vector<uint8_t>& keep, OrientationReport& report) {
  auto& triangles = surface.triangles;
  constexpr uint8_t kUsedByRemoved = 1, kUsedByKept = 2;
  std::vector<uint8_t> use(surface.vertices.size(), 0);
  std::size_t out = 0;
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    for (uint32_t v : triangles[t]) use[v] |= keep[t] ? kUsedByKept : kUsedByRemoved;
    if (keep[t]) triangles[out++] = triangles[t];
  }
  if (out == triangles.size()) return;
  triangles.resize(out);

  std::vector<uint32_t> remap(surface.vertices.size(), kNone);
  std::size_t kept = 0;
  for (std::size_t v = 0; v < use.size(); ++v) {
    if (use[v] == kUsedByRemoved) continue;
    remap[v] = static_cast<uint32_t>(kept);
    surface.vertices[kept++] = surface.vertices[v];
  }
  report.orphaned_vertices_removed = surface.vertices.size() - kept;
  if (kept == surface.vertices.size()) return;
  surface.vertices.resize(kept);
  for (auto& tri : triangles) {
    for (uint32_t& v : tri) v = remap[v];
  }
}

void remove_degenerate_and_duplicate_faces(TriangleSurface& surface, OrientationReport& report) {
  auto& triangles = surface.triangles;
  const std::size_t n = triangles.size();
  std::vector<uint8_t> keep(n, 1);
  std::vector<Triangle> keys(n);
  std::vector<uint32_t> order;
  order.reserve(n);
  for (std::size_t t = 0; t < n; ++t) {
    const auto& [a, b, c] = triangles[t];
    if (a == b || b == c || c == a) {
      keep[t] = 0;
      ++report.degenerate_faces_removed;
      continue;
    }
    keys[t] = sorted_key(triangles[t]);
    order.push_back(static_cast<uint32_t>(t));
  }
  parallel_sort(order.begin(), order.end(),
                [&](uint32_t a, uint32_t b) { return keys[a] != keys[b] ? keys[a] < keys[b] : a < b; });

  std::vector<uint32_t> even, odd;
  for (std::size_t g = 0; g < order.size();) {
    std::size_t end = g + 1;
    while (end < order.size() && keys[order[end]] == keys[order[g]]) ++end;
    if (end - g > 1) {
      even.clear();
      odd.clear();
      for (std::size_t i = g; i < end; ++i) (even_orientation(triangles[order[i]]) ? even : odd).push_back(order[i]);
      for (std::size_t i = g; i < end; ++i) keep[order[i]] = 0;
      // Opposite copies cancel pairwise; one face of the orientation left over survives.
      report.cancelled_pairs += std::min(even.size(), odd.size());
      const auto& rest = even.size() > odd.size() ? even : odd;
      if (even.size() != odd.size()) keep[rest.front()] = 1;
      report.duplicate_faces_removed += (end - g) - (even.size() != odd.size() ? 1 : 0);
    }
    g = end;
  }

  remove_faces(surface, keep, report);
  for (const auto& [a, b, c] : triangles) {
    const auto& v = surface.vertices;
    if (cross(v[b] - v[a], v[c] - v[a]) == Vec3{}) ++report.zero_area_faces;
  }
}

// ---------------------------------------------------------------------------------------------
// Step 2: components through manifold edges and their consistent orientation.

struct Components {
  std::vector<uint32_t> of;     // triangle -> component
  KeyGroups groups;             // component c's triangles: groups.items[groups.start[c], groups.start[c + 1])
  std::vector<uint32_t> root;   // the lowest triangle (smallest sorted key)
  std::vector<uint8_t> closed;  // step 3's closed: orientable, each edge used twice, opposite ways
  std::size_t size() const { return root.size(); }
  std::span<const uint32_t> triangles_of(std::size_t c) const {
    return {groups.items.data() + groups.start[c], groups.items.data() + groups.start[c + 1]};
  }
};

// A neighbour across a manifold edge, and whether it traverses the edge the same way.
struct Link {
  uint32_t triangle = kNone;
  bool same_direction = false;
};

// What the edge table says about each triangle and the surface's boundary.
struct EdgeClasses {
  std::vector<std::array<Link, 3>> links;  // in increasing edge order, so walks depend on indices only
  std::vector<uint8_t> open;               // has a boundary edge
  std::vector<std::size_t> nonmanifold;    // edge indices
};

EdgeClasses classify_edges(const TriangleSurface& surface, const SurfaceEdges& edges, OrientationReport& report) {
  const std::size_t n = surface.triangles.size();
  EdgeClasses classes{std::vector<std::array<Link, 3>>(n), std::vector<uint8_t>(n, 0), {}};
  DisjointSets boundary(surface.vertices.size());
  std::vector<uint8_t> on_boundary(surface.vertices.size(), 0);
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const auto uses = edges.uses_of(e);
    if (uses.size() == 2) {
      const bool same = uses[0].forward == uses[1].forward;
      for (auto [from, to] : {std::pair{uses[0], uses[1]}, std::pair{uses[1], uses[0]}}) {
        auto& links = classes.links[from.triangle];
        *std::find_if(links.begin(), links.end(), [](const Link& l) { return l.triangle == kNone; }) = {to.triangle,
                                                                                                        same};
      }
    } else if (uses.size() >= 3) {
      ++report.nonmanifold_edges;
      classes.nonmanifold.push_back(e);
    } else {
      classes.open[uses[0].triangle] = 1;
      ++report.boundary_edges;
      const auto [lo, hi] = edges.vertices[e];
      boundary.unite(lo, hi);
      on_boundary[lo] = on_boundary[hi] = 1;
    }
  }
  for (std::size_t v = 0; v < on_boundary.size(); ++v) {
    if (on_boundary[v] && boundary.find(static_cast<uint32_t>(v)) == v) ++report.boundary_loops;
  }
  return classes;
}

Components group_components(const TriangleSurface& surface, const EdgeClasses& classes) {
  const std::size_t n = surface.triangles.size();
  DisjointSets sets(n);
  for (std::size_t t = 0; t < n; ++t) {
    for (const Link& link : classes.links[t]) {
      if (link.triangle != kNone) sets.unite(static_cast<uint32_t>(t), link.triangle);
    }
  }
  Components comps;
  comps.of.assign(n, kNone);
  std::vector<uint32_t> index_of_root(n, kNone);
  for (std::size_t t = 0; t < n; ++t) {
    const uint32_t r = sets.find(static_cast<uint32_t>(t));
    if (index_of_root[r] == kNone) {
      index_of_root[r] = static_cast<uint32_t>(comps.root.size());
      comps.root.push_back(r);
    }
    comps.of[t] = index_of_root[r];
  }
  // Grouped serially, so each group's order is fixed (decreasing triangle).
  comps.groups = group_by_key(
      comps.root.size(),
      [&](const auto& f) {
        for (std::size_t t = 0; t < n; ++t) f(static_cast<uint32_t>(t));
      },
      [&](uint32_t t) { return comps.of[t]; });
  comps.closed.assign(comps.root.size(), 1);
  for (std::size_t c = 0; c < comps.size(); ++c) {
    uint32_t& root = comps.root[c];
    for (uint32_t t : comps.triangles_of(c)) {
      if (sorted_key(surface.triangles[t]) < sorted_key(surface.triangles[root])) root = t;
      if (classes.open[t]) comps.closed[c] = 0;
    }
  }
  return comps;
}

// The walk of step 2 over one component; returns whether it was orientable.
bool walk_and_flip_minority(TriangleSurface& surface, const EdgeClasses& classes, const Components& comps,
                            std::size_t c, std::vector<int8_t>& parity, std::vector<uint8_t>& was_flipped,
                            OrientationReport& report) {
  const auto members = comps.triangles_of(c);
  bool orientable = true;
  std::size_t odd = 0;
  std::vector<uint32_t> queue(1, comps.root[c]);
  parity[comps.root[c]] = 0;
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const uint32_t t = queue[head];
    odd += static_cast<std::size_t>(parity[t]);
    for (const Link& link : classes.links[t]) {
      if (link.triangle == kNone) continue;
      const auto want = static_cast<int8_t>(parity[t] ^ (link.same_direction ? 1 : 0));
      if (parity[link.triangle] < 0) {
        parity[link.triangle] = want;
        queue.push_back(link.triangle);
      } else if (parity[link.triangle] != want) {
        orientable = false;
      }
    }
  }
  // Flip the minority; a tie keeps the root's orientation (parity 0).
  const int8_t flipped = odd * 2 > members.size() ? 0 : 1;
  for (uint32_t t : members) {
    if (parity[t] != flipped) continue;
    flip(surface.triangles[t]);
    was_flipped[t] = 1;
    ++report.flipped_triangles;
  }
  return orientable;
}

Components orient_consistently(TriangleSurface& surface, OrientationReport& report) {
  const std::size_t n = surface.triangles.size();
  const SurfaceEdges edges = surface_edges(surface);
  const EdgeClasses classes = classify_edges(surface, edges, report);
  Components comps = group_components(surface, classes);
  report.components = comps.size();

  std::vector<int8_t> parity(n, -1);
  std::vector<uint8_t> was_flipped(n, 0);
  for (std::size_t c = 0; c < comps.size(); ++c) {
    if (walk_and_flip_minority(surface, classes, comps, c, parity, was_flipped, report)) continue;
    ++report.nonorientable_components;
    comps.closed[c] = 0;
  }

  // A component that meets a non-manifold edge is still closed there when it uses the edge
  // exactly twice, in opposite directions (two shells touching along an edge are each closed).
  std::vector<std::pair<uint32_t, bool>> by_component;  // (component, forward) of each use
  for (std::size_t e : classes.nonmanifold) {
    by_component.clear();
    for (const EdgeUse& use : edges.uses_of(e)) {
      by_component.push_back({comps.of[use.triangle], use.forward != (was_flipped[use.triangle] != 0)});
    }
    std::sort(by_component.begin(), by_component.end());
    for (std::size_t i = 0; i < by_component.size();) {
      std::size_t end = i + 1;
      while (end < by_component.size() && by_component[end].first == by_component[i].first) ++end;
      if (end - i != 2 || by_component[i].second == by_component[i + 1].second) comps.closed[by_component[i].first] = 0;
      i = end;
    }
  }
  return comps;
}

// ---------------------------------------------------------------------------------------------
// Step 4: self-intersecting pairs, with the pairs of components they join.

double orient(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) { return triple(b - a, c - a, d - a); }

// An edge of s properly crosses t: its ends strictly on opposite sides of t's plane and its
// line strictly inside t's three edges. Edges through a vertex the two share are skipped: off the
// coplanar case they meet t's plane only at that vertex, where the predicate's rounding would
// decide. The sides of s's vertices are computed once, and s entirely on one side (the common
// case for a candidate pair) returns at once.
bool edge_crosses(const TriangleSurface& surface, const Triangle& s, const Triangle& t) {
  const auto& v = surface.vertices;
  const Vec3 &a = v[t[0]], &b = v[t[1]], &c = v[t[2]];
  const std::array<double, 3> side = {orient(a, b, c, v[s[0]]), orient(a, b, c, v[s[1]]), orient(a, b, c, v[s[2]])};
  if ((side[0] > 0 && side[1] > 0 && side[2] > 0) || (side[0] < 0 && side[1] < 0 && side[2] < 0)) return false;
  const auto shared = [&](uint32_t x) { return x == t[0] || x == t[1] || x == t[2]; };
  for (int k = 0; k < 3; ++k) {
    const int l = (k + 1) % 3;
    if (!((side[k] > 0 && side[l] < 0) || (side[k] < 0 && side[l] > 0)) || shared(s[k]) || shared(s[l])) continue;
    const Vec3 &p = v[s[k]], &q = v[s[l]];
    const double x = orient(p, q, a, b), y = orient(p, q, b, c), z = orient(p, q, c, a);
    if ((x > 0 && y > 0 && z > 0) || (x < 0 && y < 0 && z < 0)) return true;
  }
  return false;
}

struct IntersectionCount {
  std::size_t pairs = 0;
  std::vector<uint64_t> component_pairs;  // (smaller << 32) | larger, unsorted
  void join(IntersectionCount&& other) {
    pairs += other.pairs;
    component_pairs.insert(component_pairs.end(), other.component_pairs.begin(), other.component_pairs.end());
  }
};

// Returns the sorted, distinct component pairs that intersect; sets the report's step 4 fields.
std::vector<uint64_t> find_self_intersections(const TriangleSurface& surface, const Components& comps,
                                              OrientationReport& report) {
  const auto& triangles = surface.triangles;
  const std::size_t n = triangles.size();
  if (n > kSelfIntersectionMaxTriangles) return {};

  std::vector<Box> boxes(n);
  Box all;
  double extent = 0;
  for (std::size_t t = 0; t < n; ++t) {
    for (uint32_t v : triangles[t]) boxes[t].extend(surface.vertices[v]);
    if (!is_finite(boxes[t].lo) || !is_finite(boxes[t].hi)) return {};  // no grid can hold it
    all.extend(boxes[t].lo);
    all.extend(boxes[t].hi);
    const Vec3 s = boxes[t].size();
    extent += std::max({s.x, s.y, s.z});
  }
  if (n < 2) {
    report.self_intersection_checked = true;
    return {};
  }
  // Cells about the size of a triangle keep both the entries per triangle and the triangles per
  // cell small; at most 2^20 cells an axis keeps a cell's id in 60 bits.
  constexpr double kMaxCellsPerAxis = double(1 << 20);
  const Vec3 size = all.size();
  if (!is_finite(size)) return {};
  const double cell = std::max({extent / double(n), size.x / kMaxCellsPerAxis, size.y / kMaxCellsPerAxis,
                                size.z / kMaxCellsPerAxis, std::numeric_limits<double>::min()});
  std::array<uint64_t, 3> dims;
  for (int a = 0; a < 3; ++a) dims[a] = std::min<uint64_t>(uint64_t(size[a] / cell) + 1, 1 << 20);
  const auto cell_of = [&](const Vec3& p) {
    std::array<uint64_t, 3> c;
    for (int a = 0; a < 3; ++a)
      c[a] = std::min<uint64_t>(uint64_t(std::max(0.0, (p[a] - all.lo[a]) / cell)), dims[a] - 1);
    return c;
  };
  const auto id = [&](const std::array<uint64_t, 3>& c) { return (c[2] * dims[1] + c[1]) * dims[0] + c[0]; };

  // Grid entries (cell id, triangle), within a budget: a few huge triangles among many small
  // ones could otherwise ask for any number of cells.
  const std::size_t entry_budget = 32 * n + (std::size_t{1} << 20);
  std::size_t entries_needed = 0;
  for (std::size_t t = 0; t < n && entries_needed <= entry_budget; ++t) {
    const auto lo = cell_of(boxes[t].lo), hi = cell_of(boxes[t].hi);
    entries_needed += (hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1);
  }
  if (entries_needed > entry_budget) return {};
  std::vector<std::pair<uint64_t, uint32_t>> entries;
  entries.reserve(entries_needed);
  for (std::size_t t = 0; t < n; ++t) {
    const auto lo = cell_of(boxes[t].lo), hi = cell_of(boxes[t].hi);
    for (uint64_t z = lo[2]; z <= hi[2]; ++z)
      for (uint64_t y = lo[1]; y <= hi[1]; ++y)
        for (uint64_t x = lo[0]; x <= hi[0]; ++x) entries.push_back({id({x, y, z}), static_cast<uint32_t>(t)});
  }
  parallel_sort(entries.begin(), entries.end());

  std::vector<std::size_t> run_start;
  std::size_t candidates = 0;
  for (std::size_t i = 0; i < entries.size();) {
    std::size_t end = i + 1;
    while (end < entries.size() && entries[end].first == entries[i].first) ++end;
    if (end - i > 1) {
      run_start.push_back(i);
      candidates += (end - i) * (end - i - 1) / 2;
    }
    i = end;
  }
  if (candidates > kSelfIntersectionCandidates) return {};
  report.self_intersection_checked = true;

  const auto run_end = [&](std::size_t i) {
    std::size_t end = i + 1;
    while (end < entries.size() && entries[end].first == entries[i].first) ++end;
    return end;
  };
  IntersectionCount found = deterministic_reduce(
      run_start.size(), 64, IntersectionCount{}, [&](std::size_t begin, std::size_t end, IntersectionCount& acc) {
        for (std::size_t r = begin; r < end; ++r) {
          const std::size_t first = run_start[r], last = run_end(first);
          const uint64_t here = entries[first].first;
          for (std::size_t i = first; i < last; ++i) {
            for (std::size_t j = i + 1; j < last; ++j) {
              const uint32_t a = entries[i].second, b = entries[j].second;
              const Box &ba = boxes[a], &bb = boxes[b];
              Vec3 lo;
              bool overlap = true;
              for (int k = 0; k < 3; ++k) {
                overlap = overlap && ba.lo[k] <= bb.hi[k] && bb.lo[k] <= ba.hi[k];
                lo[k] = std::max(ba.lo[k], bb.lo[k]);
              }
              // Each pair is tested once: in the cell of its boxes' common lowest corner.
              if (!overlap || id(cell_of(lo)) != here) continue;
              const Triangle &ta = triangles[a], &tb = triangles[b];
              int shared = 0;
              for (uint32_t x : ta) shared += (x == tb[0] || x == tb[1] || x == tb[2]) ? 1 : 0;
              if (shared >= 2) continue;  // adjacent across an edge
              if (!edge_crosses(surface, ta, tb) && !edge_crosses(surface, tb, ta)) continue;
              ++acc.pairs;
              const uint64_t ca = comps.of[a], cb = comps.of[b];
              if (ca != cb) acc.component_pairs.push_back((std::min(ca, cb) << 32) | std::max(ca, cb));
            }
          }
        }
      });
  report.self_intersecting_pairs = found.pairs;
  auto& pairs = found.component_pairs;
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  return pairs;
}

// ---------------------------------------------------------------------------------------------
// Step 3: closed components outward, cavities inward.

// Winding number of the component's triangles at p: the sum of their solid angles (Van Oosterom
// and Strackee's formula) over 4 pi.
double winding_number(const TriangleSurface& surface, std::span<const uint32_t> members, const Vec3& p) {
  double sum = 0;
  for (uint32_t t : members) {
    const auto& [i, j, k] = surface.triangles[t];
    const Vec3 a = surface.vertices[i] - p, b = surface.vertices[j] - p, c = surface.vertices[k] - p;
    const double la = norm(a), lb = norm(b), lc = norm(c);
    const double below = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb;
    sum += 2 * std::atan2(triple(a, b, c), below);
  }
  return sum / (4 * std::numbers::pi);
}

void orient_outward(TriangleSurface& surface, const Components& comps, const std::vector<uint64_t>& intersecting,
                    OrientationReport& report) {
  std::vector<uint32_t> closed;
  std::vector<Box> boxes(comps.size());
  std::vector<double> volume(comps.size(), 0);
  for (std::size_t c = 0; c < comps.size(); ++c) {
    if (!comps.closed[c]) continue;
    closed.push_back(static_cast<uint32_t>(c));
    for (uint32_t t : comps.triangles_of(c))
      for (uint32_t v : surface.triangles[t]) boxes[c].extend(surface.vertices[v]);
    volume[c] = signed_volume(surface, comps.triangles_of(c), boxes[c].center());
  }
  report.closed_components = closed.size();

  // Candidate (shell, component inside it) pairs: boxes nested, not intersecting each other.
  struct Candidate {
    uint32_t shell, inner;
  };
  std::vector<Candidate> candidates;
  std::size_t terms = 0;
  const std::size_t k = closed.size();
  report.nesting_checked = k * k <= kNestingBudget;
  if (report.nesting_checked) {
    for (uint32_t inner : closed) {
      if (terms > kNestingBudget) break;  // no more candidates: they would not be used
      for (uint32_t shell : closed) {
        if (shell == inner) continue;
        const Box &bs = boxes[shell], &bi = boxes[inner];
        if (!(bs.contains(bi.lo) && bs.contains(bi.hi))) continue;
        const uint64_t key = (uint64_t{std::min(shell, inner)} << 32) | std::max(shell, inner);
        if (std::binary_search(intersecting.begin(), intersecting.end(), key)) continue;
        candidates.push_back({shell, inner});
        terms += comps.triangles_of(shell).size();
      }
    }
    report.nesting_checked = terms <= kNestingBudget;
  }
  std::vector<uint32_t> depth(comps.size(), 0);
  if (report.nesting_checked) {
    std::vector<uint8_t> inside(candidates.size(), 0);
    parallel_for(candidates.size(), [&](std::size_t i) {
      const auto& root = surface.triangles[comps.root[candidates[i].inner]];
      const Vec3 p = (surface.vertices[root[0]] + surface.vertices[root[1]] + surface.vertices[root[2]]) / 3.0;
      inside[i] = std::abs(winding_number(surface, comps.triangles_of(candidates[i].shell), p)) >= 0.5;
    });
    for (std::size_t i = 0; i < candidates.size(); ++i) depth[candidates[i].inner] += inside[i];
  }

  for (uint32_t c : closed) {
    const bool cavity = depth[c] % 2 == 1;
    report.cavities += cavity ? 1 : 0;
    if (volume[c] == 0 || (volume[c] > 0) != cavity) continue;
    ++report.reversed_components;
    for (uint32_t t : comps.triangles_of(c)) flip(surface.triangles[t]);
    report.reversed_triangles += comps.triangles_of(c).size();
  }
}

std::string count(std::size_t n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

}  // namespace

std::string describe(const OrientationReport& r) {
  std::string line =
      count(r.components, "component", "components") + " (" + std::to_string(r.closed_components) + " closed";
  if (r.cavities > 0) line += ", " + count(r.cavities, "cavity", "cavities");
  if (r.nonorientable_components > 0) line += ", " + std::to_string(r.nonorientable_components) + " non-orientable";
  line += "), ";
  line += r.boundary_edges == 0 ? std::string("no boundary")
                                : count(r.boundary_edges, "boundary edge", "boundary edges") + " in " +
                                      count(r.boundary_loops, "loop", "loops");
  line += ", " + (r.nonmanifold_edges == 0 ? std::string("no non-manifold edge")
                                           : count(r.nonmanifold_edges, "non-manifold edge", "non-manifold edges"));
  if (r.zero_area_faces > 0) line += ", " + count(r.zero_area_faces, "zero-area face", "zero-area faces");
  line += ", self-intersections: ";
  line += !r.self_intersection_checked     ? std::string("not checked")
          : r.self_intersecting_pairs == 0 ? std::string("none")
                                           : count(r.self_intersecting_pairs, "pair", "pairs");
  std::vector<std::string> done;
  if (r.degenerate_faces_removed > 0) {
    done.push_back("removed " + count(r.degenerate_faces_removed, "degenerate face", "degenerate faces"));
  }
  if (r.duplicate_faces_removed > 0) {
    done.push_back("removed " + count(r.duplicate_faces_removed, "duplicate face", "duplicate faces") +
                   (r.cancelled_pairs > 0 ? " (" + count(r.cancelled_pairs, "opposite pair", "opposite pairs") + ")"
                                          : std::string()));
  }
  if (r.orphaned_vertices_removed > 0) {
    done.push_back("removed " + count(r.orphaned_vertices_removed, "orphaned vertex", "orphaned vertices"));
  }
  if (r.flipped_triangles > 0) done.push_back("flipped " + count(r.flipped_triangles, "triangle", "triangles"));
  if (r.reversed_components > 0) {
    done.push_back("reversed " + count(r.reversed_components, "component", "components"));
  }
  if (!r.nesting_checked) done.push_back("nesting not checked (all closed components outward)");
  for (std::size_t i = 0; i < done.size(); ++i) line += (i == 0 ? "; " : ", ") + done[i];
  return line;
}

OrientationReport repair_orientation(TriangleSurface& surface) {
  check_surface_indices(surface);  // before anything changes
  check_edge_table_size(surface);
  OrientationReport report;
  remove_degenerate_and_duplicate_faces(surface, report);
  const Components comps = orient_consistently(surface, report);
  const std::vector<uint64_t> intersecting = find_self_intersections(surface, comps, report);
  orient_outward(surface, comps, intersecting, report);
  return report;
}

}  // namespace mchex
