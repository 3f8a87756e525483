#include "core/grid/complex_topology.h"

#include <algorithm>
#include <limits>
#include <mutex>
#include <numeric>
#include <stdexcept>
#include <string>

#include "core/base/parallel.h"
#include "core/mesh/cube.h"
#include "core/mesh/hex_faces.h"

namespace mchex {
namespace {

// One entry (cell * 12 + local edge, or cell * 6 + local face) with its point set, ascending.
template <int N>
struct Named {
  std::array<std::uint32_t, N> points;
  std::uint32_t entry;
  // Within a group points[0] is the same for all: the other points, then the entry (the lowest
  // cell first).
  bool operator<(const Named& o) const {
    for (int i = 1; i < N; ++i)
      if (points[i] != o.points[i]) return points[i] < o.points[i];
    return entry < o.entry;
  }
};

// Numbers the distinct point sets of the entries 0 .. entries - 1 (points_of(entry): N point
// ids, ascending). Ids follow the order of (point set, entry), so they depend on the complex alone,
// never on the thread count. After counting, size(count) is called once; then name(id, first,
// last) once per set, on any thread, [first, last) its entries ascending (the first names the
// lowest cell).
//
// How: the entries grouped by their lowest point (core/base/parallel.h group_by_key), each group
// (the edges or faces that start at one point, a few dozen entries) sorted in place. Only the
// 4-byte entries are stored: the earlier array of 16- or 24-byte sort records, copied by the
// sort, was most of this function's time, fresh pages costing more than sorting on the
// development VM.
template <int N, class PointsOf, class Size, class Name>
void name_sets(std::size_t entries, std::size_t num_points, const PointsOf& points_of, const Size& size,
               const Name& name) {
  KeyGroups g = group_by_key(
      num_points, [&](auto&& f) { parallel_for(entries, [&](std::size_t i) { f(static_cast<std::uint32_t>(i)); }); },
      [&](std::uint32_t i) { return points_of(i)[0]; });
  // first_id[p + 1]: the sets of group p, then their exclusive scan from first_id[0] = 0.
  std::vector<std::uint32_t> first_id(num_points + 1, 0);
  parallel_chunks(num_points, 4096, [&](std::size_t b, std::size_t e) {
    std::vector<Named<N>> named;
    for (std::size_t p = b; p < e; ++p) {
      named.clear();
      for (std::uint32_t i = g.start[p]; i < g.start[p + 1]; ++i) named.push_back({points_of(g.items[i]), g.items[i]});
      std::sort(named.begin(), named.end());
      std::uint32_t sets = 0;
      for (std::size_t i = 0; i < named.size(); ++i) {
        sets += i == 0 || named[i].points != named[i - 1].points;
        g.items[g.start[p] + i] = named[i].entry;
      }
      first_id[p + 1] = sets;
    }
  });
  std::inclusive_scan(first_id.begin(), first_id.end(), first_id.begin());
  size(first_id[num_points]);
  parallel_chunks(num_points, 4096, [&](std::size_t b, std::size_t e) {
    for (std::size_t p = b; p < e; ++p) {
      const std::uint32_t* items = g.items.data();
      std::uint32_t id = first_id[p];
      for (std::uint32_t i = g.start[p]; i < g.start[p + 1];) {
        const auto set = points_of(items[i]);
        std::uint32_t j = i + 1;
        while (j < g.start[p + 1] && points_of(items[j]) == set) ++j;
        name(id++, items + i, items + j);
        i = j;
      }
    }
  });
}

}  // namespace

ComplexTopology build_topology(const HexComplex& complex) {
  const std::size_t n = complex.cells.size();
  const std::size_t num_points = complex.points.size();
  ComplexTopology t;

  // Entries are numbered in 32 bits (core/base/parallel.h group_by_key).
  if (12 * n > std::numeric_limits<std::uint32_t>::max())
    throw std::length_error("hex complex: " + std::to_string(n) + " cells are over 357,913,941");
  parallel_for(n, [&](std::size_t c) {
    const CellCorners& p = complex.cells[c];
    for (int i = 0; i < 8; ++i)
      if (p[i] >= num_points)
        throw std::invalid_argument("hex complex: cell " + std::to_string(c) + " names point " + std::to_string(p[i]) +
                                    " of " + std::to_string(num_points));
    for (int i = 0; i < 8; ++i)
      for (int j = i + 1; j < 8; ++j)
        if (p[i] == p[j])
          throw std::invalid_argument("hex complex: cell " + std::to_string(c) + " repeats point " +
                                      std::to_string(p[i]));
  });
  t.cell_edges.resize(n);
  t.cell_faces.resize(n);

  name_sets<2>(
      12 * n, num_points,
      [&](std::uint32_t entry) {
        const CellCorners& p = complex.cells[entry / 12];
        const std::uint32_t a = p[kCubeEdges[entry % 12][0]], b = p[kCubeEdges[entry % 12][1]];
        return std::array<std::uint32_t, 2>{std::min(a, b), std::max(a, b)};
      },
      [&](std::size_t count) {
        // Sized once: grown entry by entry the arrays would be faulted in and copied several times.
        t.edge_points.resize(count);
        t.edge_owner.resize(count);
      },
      [&](std::uint32_t id, const std::uint32_t* first, const std::uint32_t* last) {
        const CellCorners& p = complex.cells[*first / 12];
        const std::uint32_t a = p[kCubeEdges[*first % 12][0]], b = p[kCubeEdges[*first % 12][1]];
        t.edge_points[id] = {std::min(a, b), std::max(a, b)};
        t.edge_owner[id] = *first / 12;
        for (const std::uint32_t* s = first; s != last; ++s) t.cell_edges[*s / 12][*s % 12] = id;
      });

  // A face shared by more than two cells is reported by its lowest point, the smallest such: a
  // group is one thread's and is scanned in sorted order, so the report is the same on any
  // thread count (the first crowded face of the sorted order, as before).
  std::mutex crowded_mutex;
  std::uint32_t crowded_point = std::numeric_limits<std::uint32_t>::max();
  std::size_t crowded_cells = 0;
  name_sets<4>(
      6 * n, num_points,
      [&](std::uint32_t entry) {
        const CellCorners& p = complex.cells[entry / 6];
        std::array<std::uint32_t, 4> q;
        for (int i = 0; i < 4; ++i) q[i] = p[kHexFaces[entry % 6][i]];
        std::sort(q.begin(), q.end());
        return q;
      },
      [&](std::size_t count) {
        t.face_points.resize(count);
        t.face_owner.resize(count);
        t.face_cells.resize(count);
      },
      [&](std::uint32_t id, const std::uint32_t* first, const std::uint32_t* last) {
        const std::uint32_t cell = *first / 6;
        const int local = static_cast<int>(*first % 6);
        // Cyclic order from the owner cell's face, rotated to start at the lowest point and turned
        // towards its lower neighbour: independent of which cell lists it.
        std::array<std::uint32_t, 4> q;
        for (int k = 0; k < 4; ++k) q[k] = complex.cells[cell][kHexFaces[local][k]];
        std::rotate(q.begin(), std::min_element(q.begin(), q.end()), q.end());
        if (q[3] < q[1]) std::swap(q[1], q[3]);
        t.face_points[id] = q;
        t.face_owner[id] = cell;
        for (const std::uint32_t* s = first; s != last; ++s) t.cell_faces[*s / 6][*s % 6] = id;
        const auto cells = static_cast<std::size_t>(last - first);
        t.face_cells[id] = static_cast<std::uint8_t>(std::min<std::size_t>(cells, 255));
        if (cells > 2) {
          const std::lock_guard lock(crowded_mutex);
          if (q[0] < crowded_point) {
            crowded_point = q[0];
            crowded_cells = cells;
          }
        }
      });
  if (crowded_cells > 0)
    throw std::invalid_argument("hex complex: a face is shared by " + std::to_string(crowded_cells) + " cells (point " +
                                std::to_string(crowded_point) + ")");
  return t;
}

}  // namespace mchex
