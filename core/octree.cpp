#include "core/octree.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <stdexcept>
#include <string>

#include <fmt/format.h>
#include <tbb/parallel_sort.h>

#include "core/cell_types.h"
#include "core/error.h"
#include "core/mc33.h"
#include "core/parallel.h"
#include "core/refinement_error.h"

namespace mchex {

// ---- KeySet ------------------------------------------------------------------------------------

namespace {

constexpr std::uint64_t kEmptyKey = ~std::uint64_t{0};

constexpr std::uint64_t mix(std::uint64_t x) {  // splitmix64's finaliser
  x ^= x >> 30;
  x *= 0xbf58476d1ce4e5b9ULL;
  x ^= x >> 27;
  x *= 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

}  // namespace

void KeySet::reserve(std::size_t n) {
  keys_.reserve(n);
  std::size_t cap = 16;
  while (cap < 2 * n) cap *= 2;
  if (cap <= slots_.size()) return;
  std::vector<std::uint64_t> old;
  old.swap(slots_);
  slots_.assign(cap, kEmptyKey);
  for (std::uint64_t k : keys_) {
    std::size_t i = mix(k) & (slots_.size() - 1);
    while (slots_[i] != kEmptyKey) i = (i + 1) & (slots_.size() - 1);
    slots_[i] = k;
  }
}

void KeySet::grow() { reserve(std::max<std::size_t>(16, 2 * keys_.size() + 1)); }

bool KeySet::insert(std::uint64_t key) {
  if (2 * (keys_.size() + 1) > slots_.size()) grow();
  std::size_t i = mix(key) & (slots_.size() - 1);
  while (slots_[i] != kEmptyKey) {
    if (slots_[i] == key) return false;
    i = (i + 1) & (slots_.size() - 1);
  }
  slots_[i] = key;
  keys_.push_back(key);
  return true;
}

bool KeySet::contains(std::uint64_t key) const {
  if (slots_.empty()) return false;
  std::size_t i = mix(key) & (slots_.size() - 1);
  while (slots_[i] != kEmptyKey) {
    if (slots_[i] == key) return true;
    i = (i + 1) & (slots_.size() - 1);
  }
  return false;
}

// ---- Octree ------------------------------------------------------------------------------------

namespace {

std::uint32_t pow3(int n) {
  std::uint32_t p = 1;
  for (int i = 0; i < n; ++i) p *= 3;
  return p;
}

std::uint64_t parent_of(std::uint64_t cell) {
  const auto [i, j, k] = octree_unkey(cell);
  return octree_key(i / 3, j / 3, k / 3);
}

std::vector<std::uint64_t> sorted(std::vector<std::uint64_t> v) {
  std::sort(v.begin(), v.end());
  return v;
}

}  // namespace

Octree::Octree(const Box& cube, int max_depth) : cube_(cube), max_depth_(max_depth) {
  if (max_depth < 0 || max_depth > kMaxAdaptiveDepth)
    throw InputError(fmt::format("--max-depth must be between 0 and {}, got {}", kMaxAdaptiveDepth, max_depth));
  refined_.resize(static_cast<std::size_t>(max_depth));
  marks_.resize(static_cast<std::size_t>(max_depth));
}

std::uint32_t Octree::cells_per_axis(int level) const { return pow3(level); }

bool Octree::is_refined(int level, std::uint64_t cell) const {
  return level < max_depth_ && refined_[level].contains(cell);
}

bool Octree::exists(int level, std::uint64_t cell) const {
  const auto [i, j, k] = octree_unkey(cell);
  const std::uint32_t n = cells_per_axis(level);
  if (i >= n || j >= n || k >= n) return false;
  return level == 0 || refined_[level - 1].contains(parent_of(cell));
}

bool Octree::refine(int level, std::uint64_t cell) {
  if (level >= max_depth_) throw std::logic_error("refining a cell at the deepest level");
  if (!exists(level, cell)) throw std::logic_error("refining a cell whose parent is not refined");
  if (!refined_[level].insert(cell)) return false;
  const auto [i, j, k] = octree_unkey(cell);
  for (int c = 0; c < 8; ++c)
    marks_[level].insert(octree_key(i + kCubeCorners[c][0], j + kCubeCorners[c][1], k + kCubeCorners[c][2]));
  return true;
}

bool Octree::mark(int level, std::uint64_t vertex) {
  if (level >= max_depth_) throw std::logic_error("marking a vertex at the deepest level");
  return marks_[level].insert(vertex);
}

bool Octree::is_marked(int level, std::uint64_t vertex) const {
  return level < max_depth_ && marks_[level].contains(vertex);
}

std::vector<std::uint64_t> Octree::marked_vertices(int level) const {
  if (level >= max_depth_) return {};
  return sorted(marks_[level].keys());
}

std::uint8_t mark_closure(std::uint8_t marks) {
  if (template_for_marks(marks).valid) return marks;
  std::uint8_t best = 0xFF;
  for (int m = 0; m < 256; ++m)
    if ((m & marks) == marks && template_for_marks(static_cast<std::uint8_t>(m)).valid &&
        std::popcount(static_cast<unsigned>(m)) < std::popcount(static_cast<unsigned>(best)))
      best = static_cast<std::uint8_t>(m);
  return best;
}

std::vector<std::uint64_t> Octree::refined_cells(int level) const {
  if (level >= max_depth_) return {};
  return sorted(refined_[level].keys());
}

std::vector<std::uint64_t> Octree::leaves(int level) const {
  std::vector<std::uint64_t> out;
  if (level == 0) {
    if (!is_refined(0, 0)) out.push_back(0);
    return out;
  }
  for (std::uint64_t p : refined_[level - 1].keys()) {
    const auto [pi, pj, pk] = octree_unkey(p);
    for (std::uint32_t c = 0; c < 27; ++c) {
      const std::uint64_t child = octree_key(3 * pi + c % 3, 3 * pj + c / 3 % 3, 3 * pk + c / 9);
      if (!is_refined(level, child)) out.push_back(child);
    }
  }
  return sorted(std::move(out));
}

std::size_t Octree::leaf_count() const {
  std::size_t n = is_refined(0, 0) ? 0 : 1;
  for (int l = 0; l < max_depth_; ++l) n += 26 * refined_[l].size();  // 27 children replace 1
  return n;
}

std::uint8_t Octree::marks(int level, std::uint64_t cell) const {
  if (level >= max_depth_ || marks_[level].size() == 0) return 0;
  const auto [i, j, k] = octree_unkey(cell);
  std::uint8_t m = 0;
  for (int c = 0; c < 8; ++c)
    if (marks_[level].contains(octree_key(i + kCubeCorners[c][0], j + kCubeCorners[c][1], k + kCubeCorners[c][2])))
      m |= static_cast<std::uint8_t>(1u << c);
  return m;
}

// ---- Refinement ----------------------------------------------------------------------------------

namespace {

// Values of the SDF at lattice points keyed by their coordinates in units of the finest
// vertex lattice (3^max_depth per axis).
class ValueStore {
 public:
  double at(std::uint64_t key) const {
    std::size_t i = mix(key) & (slots_.size() - 1);
    while (keys_[i] != key) {
      if (keys_[i] == kEmptyKey) throw std::logic_error("SDF value missing");
      i = (i + 1) & (slots_.size() - 1);
    }
    return slots_[i];
  }
  bool contains(std::uint64_t key) const {
    if (keys_.empty()) return false;
    std::size_t i = mix(key) & (keys_.size() - 1);
    while (keys_[i] != kEmptyKey) {
      if (keys_[i] == key) return true;
      i = (i + 1) & (keys_.size() - 1);
    }
    return false;
  }
  void insert(std::span<const std::uint64_t> keys, std::span<const double> values) {
    std::size_t cap = std::max<std::size_t>(keys_.size(), 16);
    while (cap < 2 * (count_ + keys.size())) cap *= 2;
    if (cap > keys_.size()) {
      std::vector<std::uint64_t> old_keys(cap, kEmptyKey);
      std::vector<double> old_values(cap);
      old_keys.swap(keys_);
      old_values.swap(slots_);
      for (std::size_t s = 0; s < old_keys.size(); ++s)
        if (old_keys[s] != kEmptyKey) put(old_keys[s], old_values[s]);
    }
    for (std::size_t i = 0; i < keys.size(); ++i) put(keys[i], values[i]);
    count_ += keys.size();
  }

 private:
  void put(std::uint64_t key, double v) {
    std::size_t i = mix(key) & (keys_.size() - 1);
    while (keys_[i] != kEmptyKey) i = (i + 1) & (keys_.size() - 1);
    keys_[i] = key;
    slots_[i] = v;
  }
  std::vector<std::uint64_t> keys_;
  std::vector<double> slots_;
  std::size_t count_ = 0;
};

// Position of a point given in integer units (units per cube edge): computed from the integers
// alone, never accumulated, in the same way as UniformGrid::vertex.
double coordinate(double lo, double hi, std::uint64_t t, double units) {
  return double(t) == units ? hi : lo + (hi - lo) * (double(t) / units);
}

Vec3 position(const Box& cube, std::uint64_t key, double units) {
  const auto [x, y, z] = octree_unkey(key);
  return {coordinate(cube.lo.x, cube.hi.x, x, units), coordinate(cube.lo.y, cube.hi.y, y, units),
          coordinate(cube.lo.z, cube.hi.z, z, units)};
}

}  // namespace

Octree refine_octree(const SignedDistance& sdf, const Box& cube, const AdaptiveOptions& options,
                     OctreeStats* stats) {
  if (!(options.threshold > 0) || !std::isfinite(options.threshold))
    throw InputError(fmt::format("--threshold must be a positive number, got {}", options.threshold));
  Octree tree(cube, options.max_depth);
  const int depth = options.max_depth;
  if (stats) stats->levels.assign(static_cast<std::size_t>(depth) + 1, {});
  // Lattice points are keyed in units of the finest level's vertex lattice; the finest level whose
  // child lattice is needed is max_depth (children at max_depth are never evaluated for error).
  const std::uint32_t finest = pow3(depth);
  const double edge = cube.hi.x - cube.lo.x;
  ValueStore values;
  std::vector<std::uint64_t> candidates = {octree_key(0, 0, 0)};
  for (int level = 0; level < depth && !candidates.empty(); ++level) {
    const std::uint32_t step = finest / pow3(level + 1);  // child lattice spacing in finest units
    // One batch: the new child-lattice points of every candidate.
    std::vector<std::uint64_t> keys(candidates.size() * kChildLatticePoints);
    parallel_for(candidates.size(), [&](std::size_t c) {
      const auto [i, j, k] = octree_unkey(candidates[c]);
      for (int p = 0; p < kChildLatticePoints; ++p)
        keys[c * kChildLatticePoints + p] =
            octree_key((3 * i + p % 4) * step, (3 * j + p / 4 % 4) * step, (3 * k + p / 16) * step);
    });
    std::vector<std::uint64_t> fresh = keys;
    tbb::parallel_sort(fresh.begin(), fresh.end());
    fresh.erase(std::unique(fresh.begin(), fresh.end()), fresh.end());
    fresh.erase(std::remove_if(fresh.begin(), fresh.end(), [&](std::uint64_t k) { return values.contains(k); }),
                fresh.end());
    std::vector<Vec3> points(fresh.size());
    parallel_for(fresh.size(), [&](std::size_t p) { points[p] = position(cube, fresh[p], finest); });
    std::vector<double> f(fresh.size());
    sdf.evaluate(points, f);
    for (double v : f)
      if (!std::isfinite(v)) throw InputError("the signed distance is not finite at a grid point");
    values.insert(fresh, f);
    // Errors, in parallel; decisions collected in candidate order.
    const double h = edge / pow3(level);
    std::vector<std::uint8_t> refine(candidates.size());
    parallel_for(candidates.size(), [&](std::size_t c) {
      std::array<double, kChildLatticePoints> v;
      for (int p = 0; p < kChildLatticePoints; ++p) v[p] = values.at(keys[c * kChildLatticePoints + p]);
      refine[c] = refinement_error(v, h) > options.threshold * h;
    });
    std::vector<std::uint64_t> next;
    for (std::size_t c = 0; c < candidates.size(); ++c) {
      if (!refine[c]) continue;
      tree.refine(level, candidates[c]);
      const auto [i, j, k] = octree_unkey(candidates[c]);
      for (std::uint32_t ch = 0; ch < 27; ++ch)
        next.push_back(octree_key(3 * i + ch % 3, 3 * j + ch / 3 % 3, 3 * k + ch / 9));
    }
    if (stats) {
      OctreeLevelStats& s = stats->levels[level];
      s.candidates = candidates.size();
      s.sdf_points = fresh.size();
      s.refined_by_error = next.size() / 27;
    }
    candidates = sorted(std::move(next));
  }
  return tree;
}

// ---- Balancing -----------------------------------------------------------------------------------

namespace {

// The cells of a level whose closed box holds vertex v of the next level (v in that level's
// vertex units: cell q spans [3q, 3q + 3]).
template <class F>
void for_each_cell_holding(std::uint64_t v, std::uint32_t n, F&& f) {
  const auto a = octree_unkey(v);
  std::array<std::array<std::uint32_t, 2>, 3> q{};
  std::array<int, 3> count{};
  for (int d = 0; d < 3; ++d) {
    const std::int64_t lo = std::max<std::int64_t>(0, (std::int64_t(a[d]) + 2) / 3 - 1);
    const std::int64_t hi = std::min<std::int64_t>(std::int64_t(n) - 1, a[d] / 3);
    for (std::int64_t x = lo; x <= hi; ++x) q[d][count[d]++] = static_cast<std::uint32_t>(x);
  }
  for (int x = 0; x < count[0]; ++x)
    for (int y = 0; y < count[1]; ++y)
      for (int z = 0; z < count[2]; ++z) f(octree_key(q[0][x], q[1][y], q[2][z]));
}

}  // namespace

std::size_t balance_octree(Octree& tree, OctreeStats* stats) {
  const int depth = tree.max_depth();
  if (stats && stats->levels.size() < static_cast<std::size_t>(depth) + 1)
    stats->levels.resize(static_cast<std::size_t>(depth) + 1);
  std::size_t total = 0;
  int rounds = 0;
  for (bool changed = true; changed;) {
    changed = false;
    ++rounds;
    // Finest first: what is done for level L only adds marks at L and refinements whose corners
    // are marks at L, which rule (a) carries to L - 1; new leaves at L + 1 wait for the next round.
    for (int level = depth - 1; level >= 0; --level) {
      std::size_t refined_here = 0, marked_here = 0;
      // Rule (a): a leaf holding a mark of the next level refines.
      if (level + 1 < depth) {
        const std::uint32_t n = tree.cells_per_axis(level);
        for (std::uint64_t v : tree.marked_vertices(level + 1))
          for_each_cell_holding(v, n, [&](std::uint64_t q) {
            if (tree.exists(level, q) && tree.refine(level, q)) ++refined_here;
          });
      }
      // Rule (b), repeated: new marks and refinements change the neighbours' patterns.
      for (bool again = true; again;) {
        again = false;
        for (std::uint64_t leaf : tree.leaves(level)) {
          const std::uint8_t m = tree.marks(level, leaf);
          if (template_for_marks(m).valid) continue;
          again = true;
          const std::uint8_t closed = mark_closure(m);
          if (closed == 0xFF) {
            tree.refine(level, leaf);
            ++refined_here;
            continue;
          }
          const auto [i, j, k] = octree_unkey(leaf);
          for (int c = 0; c < 8; ++c)
            if ((closed & ~m) >> c & 1) {
              tree.mark(level, octree_key(i + kCubeCorners[c][0], j + kCubeCorners[c][1], k + kCubeCorners[c][2]));
              ++marked_here;
            }
        }
      }
      if (refined_here || marked_here) changed = true;
      total += refined_here;
      if (stats) {
        stats->levels[level].refined_by_balance += refined_here;
        stats->levels[level].marks_added += marked_here;
      }
    }
  }
  if (stats) {
    stats->balance_rounds += rounds;
    for (int level = 0; level <= depth; ++level) stats->levels[level].leaves = tree.leaves(level).size();
  }
  return total;
}

bool octree_balanced(const Octree& tree, std::string* why) {
  const int depth = tree.max_depth();
  for (int level = 0; level < depth; ++level) {
    KeySet holding;  // leaves of this level with a mark of the next level in their closed box
    for (std::uint64_t v : tree.marked_vertices(level + 1))
      for_each_cell_holding(v, tree.cells_per_axis(level), [&](std::uint64_t q) { holding.insert(q); });
    for (std::uint64_t leaf : tree.leaves(level)) {
      const auto [i, j, k] = octree_unkey(leaf);
      if (holding.contains(leaf)) {
        if (why) *why = fmt::format("leaf ({}, {}, {}) of level {} holds a mark of level {}", i, j, k, level, level + 1);
        return false;
      }
      const std::uint8_t m = tree.marks(level, leaf);
      if (!template_for_marks(m).valid) {
        if (why) *why = fmt::format("leaf ({}, {}, {}) of level {} has marked corners {:#04x}, which no template handles", i, j, k, level, m);
        return false;
      }
    }
  }
  return true;
}

// ---- The complex ------------------------------------------------------------------------------------

AdaptiveGrid build_adaptive_complex(const Octree& tree) {
  const int depth = tree.max_depth();
  const Box& cube = tree.cube();
  const double edge = cube.hi.x - cube.lo.x;
  const std::uint32_t units = 4 * pow3(depth);  // point units per cube edge

  struct Leaf {
    std::uint64_t cell;
    std::uint8_t level;
    TemplateChoice choice;
  };
  std::vector<Leaf> leaves;
  AdaptiveGrid out;
  for (int level = 0; level <= depth; ++level) {
    const auto ls = tree.leaves(level);
    if (!ls.empty()) out.levels = level + 1;
    const std::size_t first = leaves.size();
    leaves.resize(first + ls.size());
    parallel_for(ls.size(), [&](std::size_t i) {
      const std::uint8_t m = tree.marks(level, ls[i]);
      leaves[first + i] = {ls[i], static_cast<std::uint8_t>(level), template_for_marks(m)};
    });
  }
  for (const Leaf& l : leaves) {
    if (!l.choice.valid || (l.level == depth && l.choice.kind != TemplateKind::kCube))
      throw std::logic_error("build_adaptive_complex: the octree is not balanced");
    ++out.leaves_per_template[static_cast<int>(l.choice.kind)];
  }
  // Count, then fill (prefix sum), so that every leaf writes its own range.
  std::vector<std::size_t> offset(leaves.size() + 1, 0);
  for (std::size_t i = 0; i < leaves.size(); ++i)
    offset[i + 1] = offset[i] + template_hexes(leaves[i].choice.kind).size();
  const std::size_t num_cells = offset.back();
  std::vector<std::array<std::uint64_t, 8>> corner_keys(num_cells);
  out.cell_type.resize(num_cells);
  out.cell_level.resize(num_cells);
  out.complex.cell_size.resize(num_cells);
  parallel_for(leaves.size(), [&](std::size_t li) {
    const Leaf& l = leaves[li];
    const auto [i, j, k] = octree_unkey(l.cell);
    const std::uint64_t size = units / pow3(l.level);  // leaf edge in point units
    const std::array<std::uint64_t, 3> origin = {i * size, j * size, k * size};
    const auto hexes = template_hexes(l.choice.kind);
    for (std::size_t h = 0; h < hexes.size(); ++h) {
      const std::size_t cell = offset[li] + h;
      for (int c = 0; c < 8; ++c) {
        const TemplatePoint p = transform_template_point(hexes[h].corners[c], l.choice.rotation);
        std::array<std::uint64_t, 3> q;
        for (int d = 0; d < 3; ++d) q[d] = origin[d] + std::uint64_t(p[d]) * size / kTemplateUnits;
        // The rotation keeps the hex right-handed; its corners move with it.
        corner_keys[cell][c] = octree_key(q[0], q[1], q[2]);
      }
      out.cell_type[cell] = static_cast<std::uint8_t>(template_hex_type(l.choice.kind, static_cast<int>(h)).type);
      const bool child = hexes[h].child;
      out.cell_level[cell] = static_cast<std::uint8_t>(l.level + (child ? 1 : 0));
      out.complex.cell_size[cell] = edge / pow3(l.level + (child ? 1 : 0));
    }
  });
  // Points: distinct keys in sorted order.
  std::vector<std::uint64_t> keys(num_cells * 8);
  parallel_for(num_cells, [&](std::size_t c) {
    for (int i = 0; i < 8; ++i) keys[8 * c + i] = corner_keys[c][i];
  });
  tbb::parallel_sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  out.complex.box = cube;
  out.complex.points.resize(keys.size());
  parallel_for(keys.size(), [&](std::size_t p) { out.complex.points[p] = position(cube, keys[p], units); });
  out.complex.cells.resize(num_cells);
  parallel_for(num_cells, [&](std::size_t c) {
    for (int i = 0; i < 8; ++i)
      out.complex.cells[c][i] = static_cast<std::uint32_t>(
          std::lower_bound(keys.begin(), keys.end(), corner_keys[c][i]) - keys.begin());
  });
  return out;
}

}  // namespace mchex
