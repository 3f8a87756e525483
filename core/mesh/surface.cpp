// Welding and topological validation of a triangle surface.
//
// Both run in (near) linear time so that a 1M-triangle input costs well under a second:
// welding uses an open-addressing table keyed on the coordinate bits, and edge counting buckets
// every edge under its smaller vertex (a counting sort) instead of a node-based map.
#include "core/mesh/surface.h"

#include <algorithm>
#include <bit>
#include <limits>
#include <numeric>
#include <string>

#include "core/base/error.h"

namespace mchex {

Box TriangleSurface::bounds() const {
  Box box;
  for (const Vec3& v : vertices) box.extend(v);
  return box;
}

namespace {

constexpr uint32_t kNoIndex = std::numeric_limits<uint32_t>::max();

// Bit pattern of a coordinate with -0 mapped to +0, so that the two zeros weld together while
// every other distinct value (including each NaN payload) stays distinct.
uint64_t weld_bits(double x) { return std::bit_cast<uint64_t>(x == 0.0 ? 0.0 : x); }

uint64_t mix(uint64_t h) {
  // splitmix64 finaliser: spreads nearby coordinates (grid-like models) over the whole table.
  h ^= h >> 30;
  h *= 0xbf58476d1ce4e5b9ULL;
  h ^= h >> 27;
  h *= 0x94d049bb133111ebULL;
  h ^= h >> 31;
  return h;
}

bool same_position(const Vec3& a, const Vec3& b) {
  return weld_bits(a.x) == weld_bits(b.x) && weld_bits(a.y) == weld_bits(b.y) && weld_bits(a.z) == weld_bits(b.z);
}

// Neumaier's compensated sum: a closed mesh's volume is a sum of many terms of both signs that
// cancel, and plain summation loses the digits the caller compares against.
struct CompensatedSum {
  double sum = 0, compensation = 0;
  void add(double x) {
    const double t = sum + x;
    compensation += std::abs(sum) >= std::abs(x) ? (sum - t) + x : (x - t) + sum;
    sum = t;
  }
  double value() const { return sum + compensation; }
};

// Signed volume of triangles index(0), ..., index(count - 1) about `origin`.
template <class Index>
double signed_volume_of(const TriangleSurface& surface, std::size_t count, Index index, Vec3 origin) {
  CompensatedSum six_volume;
  for (std::size_t i = 0; i < count; ++i) {
    const auto [a, b, c] = surface.triangles[index(i)];
    if (a == b || b == c || c == a) continue;
    const auto& v = surface.vertices;
    six_volume.add(triple(v[a] - origin, v[b] - origin, v[c] - origin));
  }
  return six_volume.value() / 6.0;
}

// One triangle's use of an edge, packed for sorting in the bucket of the edge's smaller vertex:
// bits 63..32 the larger vertex, 31..2 the triangle, bit 1 set when the triangle has a repeated
// index, bit 0 set when the triangle runs from smaller to larger. Sorting a bucket groups uses
// of the same edge together, ordered by triangle.
constexpr uint64_t kCollapsedBit = 2;
constexpr uint64_t kForwardBit = 1;

}  // namespace

DisjointSets::DisjointSets(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }

void check_surface_indices(const TriangleSurface& surface) {
  const std::size_t n = surface.vertices.size();
  for (std::size_t t = 0; t < surface.triangles.size(); ++t) {
    for (uint32_t v : surface.triangles[t]) {
      if (v >= n) {
        throw InputError("surface: triangle " + std::to_string(t) + " refers to vertex " + std::to_string(v) +
                         ", but there are only " + std::to_string(n) + " vertices");
      }
    }
  }
}

void check_edge_table_size(const TriangleSurface& surface) {
  if (surface.triangles.size() >= kMaxEdgeTableTriangles) {
    throw ResourceError("surface: " + std::to_string(surface.triangles.size()) +
                        " triangles is more than the validator supports (2^30)");
  }
}

std::size_t weld_vertices(TriangleSurface& surface) {
  check_surface_indices(surface);
  const std::size_t n = surface.vertices.size();
  if (n == 0) return 0;

  std::size_t capacity = 16;
  while (capacity < 2 * n) capacity *= 2;
  std::vector<uint32_t> table(capacity, kNoIndex);  // slot -> index into `welded`
  std::vector<Vec3> welded;
  welded.reserve(n);
  std::vector<uint32_t> remap(n);

  for (std::size_t i = 0; i < n; ++i) {
    const Vec3& v = surface.vertices[i];
    const uint64_t h = mix(weld_bits(v.x) ^ mix(weld_bits(v.y) ^ mix(weld_bits(v.z))));
    std::size_t slot = h & (capacity - 1);
    while (table[slot] != kNoIndex && !same_position(welded[table[slot]], v)) {
      slot = (slot + 1) & (capacity - 1);
    }
    if (table[slot] == kNoIndex) {
      table[slot] = static_cast<uint32_t>(welded.size());
      welded.push_back(v);
    }
    remap[i] = table[slot];
  }

  const std::size_t merged = n - welded.size();
  if (merged == 0) return 0;
  for (auto& tri : surface.triangles) {
    for (uint32_t& v : tri) v = remap[v];
  }
  surface.vertices = std::move(welded);
  return merged;
}

SurfaceEdges surface_edges(const TriangleSurface& surface) {
  check_surface_indices(surface);
  check_edge_table_size(surface);
  const auto& triangles = surface.triangles;

  // Pass 1: size the buckets.
  std::vector<std::size_t> bucket_start(surface.vertices.size() + 1, 0);
  for (const auto& tri : triangles) {
    for (int k = 0; k < 3; ++k) {
      if (tri[k] != tri[(k + 1) % 3]) ++bucket_start[std::min(tri[k], tri[(k + 1) % 3]) + 1];
    }
  }
  std::partial_sum(bucket_start.begin(), bucket_start.end(), bucket_start.begin());

  // Pass 2: fill them.
  std::vector<uint64_t> packed(bucket_start.back());
  {
    std::vector<std::size_t> cursor(bucket_start.begin(), bucket_start.end() - 1);
    for (std::size_t t = 0; t < triangles.size(); ++t) {
      const auto& tri = triangles[t];
      const bool repeated = tri[0] == tri[1] || tri[1] == tri[2] || tri[2] == tri[0];
      const uint64_t flags = (static_cast<uint64_t>(t) << 2) | (repeated ? kCollapsedBit : 0);
      for (int k = 0; k < 3; ++k) {
        const uint32_t from = tri[k], to = tri[(k + 1) % 3];
        if (from == to) continue;
        const uint32_t lo = std::min(from, to), hi = std::max(from, to);
        packed[cursor[lo]++] = (static_cast<uint64_t>(hi) << 32) | flags | (from < to ? kForwardBit : 0);
      }
    }
  }

  // Pass 3: each run of equal larger vertex in a sorted bucket is one edge.
  SurfaceEdges edges;
  edges.uses.reserve(packed.size());
  edges.first_use.reserve(packed.size() / 2 + 1);
  for (std::size_t lo = 0; lo + 1 < bucket_start.size(); ++lo) {
    const auto first = packed.begin() + static_cast<std::ptrdiff_t>(bucket_start[lo]);
    const auto last = packed.begin() + static_cast<std::ptrdiff_t>(bucket_start[lo + 1]);
    std::sort(first, last);
    for (auto use = first; use != last; ++use) {
      const auto hi = static_cast<uint32_t>(*use >> 32);
      if (use == first || (*(use - 1) >> 32) != hi) {
        edges.vertices.push_back({static_cast<uint32_t>(lo), hi});
        edges.first_use.push_back(edges.uses.size());
      }
      edges.uses.push_back(
          {static_cast<uint32_t>((*use & 0xffffffffu) >> 2), (*use & kForwardBit) != 0, (*use & kCollapsedBit) != 0});
    }
  }
  edges.first_use.push_back(edges.uses.size());
  return edges;
}

double signed_volume(const TriangleSurface& surface, std::span<const uint32_t> triangles, Vec3 origin) {
  return signed_volume_of(
      surface, triangles.size(), [&](std::size_t i) { return triangles[i]; }, origin);
}

SurfaceReport validate_surface(const TriangleSurface& surface, std::size_t welded_vertices) {
  const SurfaceEdges edges = surface_edges(surface);
  const auto& vertices = surface.vertices;
  const auto& triangles = surface.triangles;

  SurfaceReport report;
  report.vertices = vertices.size();
  report.triangles = triangles.size();
  report.welded_vertices = welded_vertices;

  for (const auto& [a, b, c] : triangles) {
    const bool repeated = a == b || b == c || c == a;
    if (repeated || cross(vertices[b] - vertices[a], vertices[c] - vertices[a]) == Vec3{}) ++report.degenerate_faces;
  }
  // About the centre of the bounds, to keep far-off models accurate.
  const Box box = surface.bounds();
  report.volume = signed_volume_of(
      surface, triangles.size(), [](std::size_t t) { return t; }, box.empty() ? Vec3{} : box.center());

  DisjointSets components(triangles.size());
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const auto uses = edges.uses_of(e);
    std::size_t count = 0, forward = 0;
    for (const EdgeUse& use : uses) {
      components.unite(uses.front().triangle, use.triangle);
      if (use.collapsed) continue;  // it only connects components
      ++count;
      forward += use.forward ? 1 : 0;
    }
    if (count == 0) continue;
    ++report.edges;
    if (count == 1) ++report.boundary_edges;
    if (count >= 3) ++report.nonmanifold_edges;
    if (count == 2 && forward != 1) ++report.inconsistent_edges;
  }

  for (std::size_t t = 0; t < triangles.size(); ++t) {
    if (components.find(static_cast<uint32_t>(t)) == t) ++report.components;
  }
  report.closed = report.edges > 0 && report.boundary_edges == 0 && report.nonmanifold_edges == 0;
  report.consistently_oriented = report.closed && report.inconsistent_edges == 0;
  return report;
}

}  // namespace mchex
