#include "core/grid/complex_topology.h"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>

#include "core/base/parallel.h"
#include "core/mesh/cube.h"
#include "core/mesh/hex_faces.h"

namespace mchex {
namespace {

struct EdgeEntry {
  std::uint64_t key;   // (low point << 32) | high point
  std::uint64_t slot;  // cell * 12 + local edge: the sort's tie-break puts the lowest cell first
  bool operator<(const EdgeEntry& o) const { return key != o.key ? key < o.key : slot < o.slot; }
};

struct FaceEntry {
  std::array<std::uint32_t, 4> sorted;  // the face's points, ascending: its name
  std::uint64_t slot;                   // cell * 6 + local face
  bool operator<(const FaceEntry& o) const {
    // Element by element (std::array's != is a memcmp call, which cost more than the sort's
    // own work here); the same lexicographic order.
    for (int i = 0; i < 4; ++i)
      if (sorted[i] != o.sorted[i]) return sorted[i] < o.sorted[i];
    return slot < o.slot;
  }
};

// Sorts v as std::sort would (the entries' own order, every key distinct): grouped by the
// entry's lowest point, its first sort key (group_by_key), then each group alone. A group holds
// the few edges or faces that start at one point, so this costs a fraction of a comparison sort
// over all of them (12 and 6 entries per cell); the group sort also removes the thread-dependent
// order inside a group.
template <class Entry, class LowPoint>
void sort_by_lowest_point(std::vector<Entry>& v, std::size_t num_points, const LowPoint& low) {
  const KeyGroups g = group_by_key(
      num_points, [&](auto&& f) { parallel_for(v.size(), [&](std::size_t i) { f(static_cast<std::uint32_t>(i)); }); },
      [&](std::uint32_t i) { return low(v[i]); });
  std::vector<Entry> out(v.size());
  parallel_for(v.size(), [&](std::size_t j) { out[j] = v[g.items[j]]; });
  parallel_chunks(num_points, 4096, [&](std::size_t b, std::size_t e) {
    for (std::size_t p = b; p < e; ++p) std::sort(out.begin() + g.start[p], out.begin() + g.start[p + 1]);
  });
  v = std::move(out);
}

}  // namespace

ComplexTopology build_topology(const HexComplex& complex) {
  const std::size_t n = complex.cells.size();
  ComplexTopology t;
  t.cell_edges.resize(n);
  t.cell_faces.resize(n);

  // Entries are numbered in 32 bits (core/base/parallel.h group_by_key).
  if (12 * n > std::numeric_limits<std::uint32_t>::max())
    throw std::length_error("hex complex: " + std::to_string(n) + " cells are over 357,913,941");
  std::vector<EdgeEntry> edges(12 * n);
  std::vector<FaceEntry> faces(6 * n);
  parallel_for(n, [&](std::size_t c) {
    const CellCorners& p = complex.cells[c];
    for (int i = 0; i < 8; ++i)
      if (p[i] >= complex.points.size())
        throw std::invalid_argument("hex complex: cell " + std::to_string(c) + " names point " + std::to_string(p[i]) +
                                    " of " + std::to_string(complex.points.size()));
    for (int i = 0; i < 8; ++i)
      for (int j = i + 1; j < 8; ++j)
        if (p[i] == p[j])
          throw std::invalid_argument("hex complex: cell " + std::to_string(c) + " repeats point " +
                                      std::to_string(p[i]));
    for (int e = 0; e < 12; ++e) {
      std::uint64_t a = p[kCubeEdges[e][0]], b = p[kCubeEdges[e][1]];
      if (a > b) std::swap(a, b);
      edges[12 * c + e] = {(a << 32) | b, 12 * c + e};
    }
    for (int f = 0; f < 6; ++f) {
      std::array<std::uint32_t, 4> q;
      for (int i = 0; i < 4; ++i) q[i] = p[kHexFaces[f][i]];
      std::sort(q.begin(), q.end());
      faces[6 * c + f] = {q, 6 * c + f};
    }
  });
  sort_by_lowest_point(edges, complex.points.size(), [](const EdgeEntry& e) { return e.key >> 32; });
  sort_by_lowest_point(faces, complex.points.size(), [](const FaceEntry& f) { return f.sorted[0]; });

  // Sized once: grown entry by entry the arrays would be faulted in and copied several times.
  std::size_t num_edges = 0, num_faces = 0;
  for (std::size_t i = 0; i < edges.size(); ++i) num_edges += i == 0 || edges[i].key != edges[i - 1].key;
  for (std::size_t i = 0; i < faces.size(); ++i) num_faces += i == 0 || faces[i].sorted != faces[i - 1].sorted;
  t.edge_points.reserve(num_edges);
  t.edge_owner.reserve(num_edges);
  t.face_points.reserve(num_faces);
  t.face_owner.reserve(num_faces);
  t.face_cells.reserve(num_faces);
  for (std::size_t i = 0; i < edges.size();) {
    const auto id = static_cast<std::uint32_t>(t.edge_points.size());
    t.edge_points.push_back({static_cast<std::uint32_t>(edges[i].key >> 32), static_cast<std::uint32_t>(edges[i].key)});
    t.edge_owner.push_back(static_cast<std::uint32_t>(edges[i].slot / 12));
    std::size_t j = i;
    for (; j < edges.size() && edges[j].key == edges[i].key; ++j)
      t.cell_edges[edges[j].slot / 12][edges[j].slot % 12] = id;
    i = j;
  }
  for (std::size_t i = 0; i < faces.size();) {
    const auto id = static_cast<std::uint32_t>(t.face_points.size());
    const std::uint64_t cell = faces[i].slot / 6;
    const int local = static_cast<int>(faces[i].slot % 6);
    // Cyclic order from the owner cell's face, rotated to start at the lowest point and turned
    // towards its lower neighbour: independent of which cell lists it.
    std::array<std::uint32_t, 4> q;
    for (int k = 0; k < 4; ++k) q[k] = complex.cells[cell][kHexFaces[local][k]];
    std::rotate(q.begin(), std::min_element(q.begin(), q.end()), q.end());
    if (q[3] < q[1]) std::swap(q[1], q[3]);
    t.face_points.push_back(q);
    t.face_owner.push_back(static_cast<std::uint32_t>(cell));
    std::size_t j = i;
    for (; j < faces.size() && faces[j].sorted == faces[i].sorted; ++j)
      t.cell_faces[faces[j].slot / 6][faces[j].slot % 6] = id;
    if (j - i > 2)
      throw std::invalid_argument("hex complex: a face is shared by " + std::to_string(j - i) + " cells (point " +
                                  std::to_string(q[0]) + ")");
    t.face_cells.push_back(static_cast<std::uint8_t>(j - i));
    i = j;
  }
  return t;
}

}  // namespace mchex
