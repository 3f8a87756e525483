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
  return weld_bits(a.x) == weld_bits(b.x) && weld_bits(a.y) == weld_bits(b.y) &&
         weld_bits(a.z) == weld_bits(b.z);
}

void check_indices(const TriangleSurface& surface) {
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

// Union-find over triangles; the smaller index becomes the root so the forest (and anything
// derived from it later) does not depend on the order edges are visited.
struct DisjointSets {
  std::vector<uint32_t> parent;
  explicit DisjointSets(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  uint32_t find(uint32_t x) {
    while (parent[x] != x) {
      parent[x] = parent[parent[x]];
      x = parent[x];
    }
    return x;
  }
  void unite(uint32_t a, uint32_t b) {
    a = find(a);
    b = find(b);
    if (a == b) return;
    if (a < b) std::swap(a, b);
    parent[a] = b;
  }
};

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

// One triangle's use of an edge, stored in the bucket of the edge's smaller vertex:
// bits 63..32 the larger vertex, 31..2 the triangle, bit 1 set when the triangle has a repeated
// index (it only connects components), bit 0 set when the triangle runs from smaller to larger.
// Sorting a bucket groups uses of the same edge together, ordered by triangle.
constexpr std::size_t kMaxTriangles = std::size_t{1} << 30;
constexpr uint64_t kCollapsedBit = 2;
constexpr uint64_t kForwardBit = 1;

}  // namespace

std::size_t weld_vertices(TriangleSurface& surface) {
  check_indices(surface);
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

SurfaceReport validate_surface(const TriangleSurface& surface, std::size_t welded_vertices) {
  check_indices(surface);
  const auto& vertices = surface.vertices;
  const auto& triangles = surface.triangles;
  if (triangles.size() >= kMaxTriangles) {
    throw ResourceError("surface: " + std::to_string(triangles.size()) +
                        " triangles is more than the validator supports (2^30)");
  }

  SurfaceReport report;
  report.vertices = vertices.size();
  report.triangles = triangles.size();
  report.welded_vertices = welded_vertices;

  const Box box = surface.bounds();
  const Vec3 origin = box.empty() ? Vec3{} : box.center();
  CompensatedSum six_volume;

  // Pass 1: classify triangles, accumulate the volume and size the edge buckets.
  std::vector<uint8_t> collapsed(triangles.size(), 0);
  std::vector<std::size_t> bucket_start(vertices.size() + 1, 0);
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    const auto [a, b, c] = triangles[t];
    const bool repeated = a == b || b == c || c == a;
    collapsed[t] = repeated;
    const Vec3 va = vertices[a], vb = vertices[b], vc = vertices[c];
    if (repeated || cross(vb - va, vc - va) == Vec3{}) ++report.degenerate_faces;
    if (repeated) {
      // Only its distinct-vertex edges are recorded, for connectivity.
      if (a != b) ++bucket_start[std::min(a, b) + 1];
      if (b != c) ++bucket_start[std::min(b, c) + 1];
      if (c != a) ++bucket_start[std::min(c, a) + 1];
      continue;
    }
    six_volume.add(triple(va - origin, vb - origin, vc - origin));
    ++bucket_start[std::min(a, b) + 1];
    ++bucket_start[std::min(b, c) + 1];
    ++bucket_start[std::min(c, a) + 1];
  }
  report.volume = six_volume.value() / 6.0;
  std::partial_sum(bucket_start.begin(), bucket_start.end(), bucket_start.begin());

  // Pass 2: fill the buckets.
  std::vector<uint64_t> uses(bucket_start.back());
  {
    std::vector<std::size_t> cursor(bucket_start.begin(), bucket_start.end() - 1);
    for (std::size_t t = 0; t < triangles.size(); ++t) {
      const auto& tri = triangles[t];
      const uint64_t flags = (static_cast<uint64_t>(t) << 2) | (collapsed[t] ? kCollapsedBit : 0);
      for (int k = 0; k < 3; ++k) {
        const uint32_t from = tri[k], to = tri[(k + 1) % 3];
        if (from == to) continue;
        const uint32_t lo = std::min(from, to), hi = std::max(from, to);
        uses[cursor[lo]++] = (static_cast<uint64_t>(hi) << 32) | flags | (from < to ? kForwardBit : 0);
      }
    }
  }

  // Pass 3: each run of equal larger-vertex in a bucket is one edge.
  DisjointSets components(triangles.size());
  for (std::size_t lo = 0; lo < vertices.size(); ++lo) {
    const auto first = uses.begin() + static_cast<std::ptrdiff_t>(bucket_start[lo]);
    const auto last = uses.begin() + static_cast<std::ptrdiff_t>(bucket_start[lo + 1]);
    std::sort(first, last);
    for (auto run = first; run != last;) {
      const uint64_t hi = *run >> 32;
      auto run_end = run;
      std::size_t count = 0, forward = 0;
      const auto triangle_of = [](uint64_t use) { return static_cast<uint32_t>((use & 0xffffffffu) >> 2); };
      for (; run_end != last && (*run_end >> 32) == hi; ++run_end) {
        components.unite(triangle_of(*run), triangle_of(*run_end));
        if (*run_end & kCollapsedBit) continue;
        ++count;
        forward += (*run_end & kForwardBit) ? 1 : 0;
      }
      run = run_end;
      if (count == 0) continue;
      ++report.edges;
      if (count == 1) ++report.boundary_edges;
      if (count >= 3) ++report.nonmanifold_edges;
      if (count == 2 && forward != 1) ++report.inconsistent_edges;
    }
  }

  for (std::size_t t = 0; t < triangles.size(); ++t) {
    if (components.find(static_cast<uint32_t>(t)) == t) ++report.components;
  }
  report.closed = report.edges > 0 && report.boundary_edges == 0 && report.nonmanifold_edges == 0;
  report.consistently_oriented = report.closed && report.inconsistent_edges == 0;
  return report;
}

}  // namespace mchex
