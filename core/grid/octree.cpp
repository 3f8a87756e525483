#include "core/grid/octree.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <stdexcept>
#include <string>

#include <fmt/format.h>

#include "core/base/error.h"
#include "core/base/parallel.h"
#include "core/grid/cell_types.h"
#include "core/grid/refinement_error.h"
#include "core/mesh/cube.h"

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
  return out;
}

std::size_t Octree::leaf_count() const {
  // Each refinement replaces one leaf by 27, from the root alone: 1 + 26 per refined cell.
  std::size_t n = 1;
  for (int l = 0; l < max_depth_; ++l) n += 26 * refined_[l].size();
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

// ---- Sorting and sampling ------------------------------------------------------------------------

namespace {

// Stable LSD radix sort by key(element) < 2^bits: 8-bit digits, each pass counted and scattered in
// parallel over a fixed number of chunks, so the result does not depend on the thread count.
template <class T, class Key>
void radix_sort(std::vector<T>& v, int bits, Key&& key) {
  const std::size_t n = v.size();
  constexpr int kDigit = 8;
  constexpr std::size_t kBuckets = std::size_t{1} << kDigit;
  const std::size_t chunks = std::clamp<std::size_t>(n / 32768, 1, 64);
  std::vector<T> tmp(n);
  std::vector<std::size_t> hist(chunks * kBuckets);
  auto lo = [&](std::size_t c) { return n * c / chunks; };
  for (int shift = 0; shift < bits; shift += kDigit) {
    parallel_chunks(chunks, 1, [&](std::size_t b, std::size_t e) {
      for (std::size_t c = b; c < e; ++c) {
        std::size_t* h = &hist[c * kBuckets];
        std::fill(h, h + kBuckets, 0);
        for (std::size_t i = lo(c); i < lo(c + 1); ++i) ++h[(key(v[i]) >> shift) & (kBuckets - 1)];
      }
    });
    std::size_t sum = 0;
    for (std::size_t d = 0; d < kBuckets; ++d)
      for (std::size_t c = 0; c < chunks; ++c) {
        const std::size_t t = hist[c * kBuckets + d];
        hist[c * kBuckets + d] = sum;
        sum += t;
      }
    parallel_chunks(chunks, 1, [&](std::size_t b, std::size_t e) {
      for (std::size_t c = b; c < e; ++c) {
        std::size_t* h = &hist[c * kBuckets];
        for (std::size_t i = lo(c); i < lo(c + 1); ++i) tmp[h[(key(v[i]) >> shift) & (kBuckets - 1)]++] = v[i];
      }
    });
    v.swap(tmp);
  }
}

// The distinct keys of a sorted sequence (key(i), slot(i)), i < n, in order, and index_of[slot]
// = its key's index among them. Parallel in fixed chunks: each counts its run starts, a scan
// places them.
template <class KeyAt, class SlotAt>
std::vector<std::uint64_t> distinct_runs(std::size_t n, KeyAt&& key, SlotAt&& slot, std::span<std::uint32_t> index_of) {
  const std::size_t chunks = std::clamp<std::size_t>(n / 32768, 1, 64);
  auto lo = [&](std::size_t c) { return n * c / chunks; };
  std::vector<std::size_t> first(chunks + 1, 0);
  parallel_chunks(chunks, 1, [&](std::size_t b, std::size_t e) {
    for (std::size_t c = b; c < e; ++c)
      for (std::size_t i = lo(c); i < lo(c + 1); ++i) first[c + 1] += i == 0 || key(i) != key(i - 1);
  });
  for (std::size_t c = 0; c < chunks; ++c) first[c + 1] += first[c];
  std::vector<std::uint64_t> out(first[chunks]);
  parallel_chunks(chunks, 1, [&](std::size_t b, std::size_t e) {
    for (std::size_t c = b; c < e; ++c) {
      std::size_t next = first[c];
      for (std::size_t i = lo(c); i < lo(c + 1); ++i) {
        if (i == 0 || key(i) != key(i - 1)) out[next++] = key(i);
        index_of[slot(i)] = static_cast<std::uint32_t>(next - 1);
      }
    }
  });
  return out;
}

}  // namespace

std::vector<std::uint64_t> sorted_distinct(std::vector<std::uint64_t> keys, int key_bits,
                                           std::span<std::uint32_t> index_of) {
  const std::size_t n = keys.size();
  if (index_of.size() != n || n > std::numeric_limits<std::uint32_t>::max() || key_bits < 1 || key_bits > 64 ||
      (key_bits < 64 && std::any_of(keys.begin(), keys.end(), [&](std::uint64_t k) { return k >> key_bits; })))
    throw std::logic_error("sorted_distinct: one index per key, fewer than 2^32 keys, each below 2^key_bits");
  const int slot_bits = std::bit_width(n);
  if (key_bits + slot_bits <= 64) {
    // Key and position in one word: half the memory traffic of a separate index array.
    parallel_for(n, [&](std::size_t i) { keys[i] = keys[i] << slot_bits | i; });
    radix_sort(keys, key_bits, [&](std::uint64_t w) { return w >> slot_bits; });
    const std::uint64_t mask = (std::uint64_t{1} << slot_bits) - 1;
    return distinct_runs(
        n, [&](std::size_t i) { return keys[i] >> slot_bits; }, [&](std::size_t i) { return keys[i] & mask; },
        index_of);
  }
  struct Pair {
    std::uint64_t key;
    std::uint32_t slot;
  };
  std::vector<Pair> pairs(n);
  parallel_for(n, [&](std::size_t i) { pairs[i] = {keys[i], static_cast<std::uint32_t>(i)}; });
  keys = {};
  radix_sort(pairs, key_bits, [](const Pair& p) { return p.key; });
  return distinct_runs(
      n, [&](std::size_t i) { return pairs[i].key; }, [&](std::size_t i) { return pairs[i].slot; }, index_of);
}

namespace {

// Points of a lattice with `units` steps per cube edge, packed densely as x + w (y + w z),
// w = units + 1: the order of (z, y, x), as octree_key, in as few bits as the radix sort needs.
struct PackedLattice {
  std::uint64_t w;
  int bits;
  explicit PackedLattice(std::uint64_t units) : w(units + 1), bits(std::bit_width(w * w * w - 1)) {}
  std::uint64_t pack(std::uint64_t x, std::uint64_t y, std::uint64_t z) const { return x + w * (y + w * z); }
  std::uint64_t to_octree_key(std::uint64_t p) const { return octree_key(p % w, p / w % w, p / (w * w)); }
};

// Position of a point given in integer units (units per cube edge): computed from the integers
// alone, never accumulated, in the same way as UniformGrid::vertex. A point of the finest vertex
// lattice (3^max_depth units) and the same point in the complex's units (4 * 3^max_depth) get the
// same coordinates bit for bit: t / u and 4t / 4u are the same correctly rounded quotient.
double coordinate(double lo, double hi, std::uint64_t t, double units) {
  return double(t) == units ? hi : lo + (hi - lo) * (double(t) / units);
}

Vec3 position(const Box& cube, std::uint64_t key, double units) {
  const auto [x, y, z] = octree_unkey(key);
  return {coordinate(cube.lo.x, cube.hi.x, x, units), coordinate(cube.lo.y, cube.hi.y, y, units),
          coordinate(cube.lo.z, cube.hi.z, z, units)};
}

// The 27 sub-cubes of the child lattice, by their lowest lattice point.
constexpr int kSubCubes = 27;

// Whether balls of radius |f| around the 8 corners of a cube of edge `edge` cover it, all values
// of one sign: see cell_may_hold_surface.
bool corners_clear(const std::array<double, 8>& f, double edge) {
  const bool positive = f[0] > 0;
  double lo = std::numeric_limits<double>::infinity(), hi = 0;
  for (double v : f) {
    if (v == 0 || (v > 0) != positive) return false;
    lo = std::min(lo, std::fabs(v));
    hi = std::max(hi, std::fabs(v));
  }
  // Rounded up by a few ulps of the products so that a value equal to the bound never clears.
  const double diagonal = edge * std::sqrt(3.0) * (1 + 1e-12);
  return lo > 0.5 * diagonal || hi > diagonal;
}

}  // namespace

bool cell_may_hold_surface(const std::array<double, kChildLatticePoints>& f, double size) {
  std::array<double, 8> c;
  for (int i = 0; i < 8; ++i) c[i] = f[child_lattice_index(3 * (i & 1), 3 * (i >> 1 & 1), 3 * (i >> 2))];
  if (corners_clear(c, size)) return false;
  for (int s = 0; s < kSubCubes; ++s) {
    const int a = s % 3, b = s / 3 % 3, d = s / 9;
    for (int i = 0; i < 8; ++i) c[i] = f[child_lattice_index(a + (i & 1), b + (i >> 1 & 1), d + (i >> 2))];
    if (!corners_clear(c, size / 3)) return true;
  }
  // Every sub-cube clear; one sign in each, and they share corners, so one sign overall.
  return false;
}

int error_depth(const AdaptiveOptions& options) {
  return options.error_depth >= 0 ? std::min(options.error_depth, options.max_depth) : options.max_depth;
}

double adaptive_tolerance(const Box& cube, const AdaptiveOptions& options) {
  return options.threshold * (cube.hi.x - cube.lo.x) / pow3(error_depth(options));
}

void Octree::record_samples(int level, std::vector<std::uint64_t> keys, std::vector<double> values) {
  if (level < 0 || level >= max_depth_ || keys.size() != values.size() || !std::is_sorted(keys.begin(), keys.end()))
    throw std::logic_error("Octree::record_samples: bad level or unsorted keys");
  if (samples_.size() < static_cast<std::size_t>(max_depth_)) samples_.resize(static_cast<std::size_t>(max_depth_));
  samples_[level] = {std::move(keys), std::move(values)};
}

bool Octree::sampled_value(std::uint64_t finest_key, double* value) const {
  if (samples_.empty()) return false;
  // Level L's batch holds child-lattice points of spacing 3^(D-1-L) that are not on the coarser
  // spacing (those were the candidates' corners, sampled a level earlier); level 0's also holds
  // the root's corners. So the 3-adic valuation of the coordinates names the one level to search.
  const auto t = octree_unkey(finest_key);
  int v = max_depth_;
  for (std::uint32_t x : t) {
    int e = 0;
    for (; x != 0 && x % 3 == 0 && e < v; x /= 3) ++e;
    if (x != 0) v = std::min(v, e);
  }
  const int level = std::max(0, max_depth_ - 1 - v);
  const LevelSamples& s = samples_[level];
  const auto it = std::lower_bound(s.keys.begin(), s.keys.end(), finest_key);
  if (it == s.keys.end() || *it != finest_key) return false;
  *value = s.values[it - s.keys.begin()];
  return true;
}

// ---- Refinement ----------------------------------------------------------------------------------

namespace {

// The trilinear interpolant of a cell's 8 corner values at t in [0,1]^3 and its gradient (per unit
// of the cell).
void trilinear(const std::array<double, 8>& f, Vec3 t, double* phi, Vec3* grad) {
  *phi = 0;
  *grad = {};
  for (int c = 0; c < 8; ++c) {
    const double wx = (c & 1) ? t.x : 1 - t.x, wy = (c >> 1 & 1) ? t.y : 1 - t.y, wz = (c >> 2) ? t.z : 1 - t.z;
    const double sx = (c & 1) ? 1 : -1, sy = (c >> 1 & 1) ? 1 : -1, sz = (c >> 2) ? 1 : -1;
    *phi += f[c] * wx * wy * wz;
    grad->x += f[c] * sx * wy * wz;
    grad->y += f[c] * wx * sy * wz;
    grad->z += f[c] * wx * wy * sz;
  }
}

// The surface-sample test of AdaptiveOptions::surface_tolerance at one level: each live sample
// finds its candidate (the child of a refined parent that holds it; a point on a cell boundary
// goes to the cell above it, by floor) and flags it when the candidate's trilinear isosurface
// lies farther than the tolerance from the sample, by |phi| / |grad phi|. `live` keeps the
// samples whose candidate is refined after this level's decisions, in their order.
void refine_at_surface_samples(const Box& cube, int level, double h, const std::vector<std::uint64_t>& parents,
                               const std::vector<std::uint32_t>& active_mask,
                               const std::vector<std::array<double, 8>>& cell_corners, const AdaptiveOptions& options,
                               std::vector<std::uint32_t>& live, std::vector<std::uint8_t>& refine) {
  const bool root = level == 0;
  const std::uint32_t cells = pow3(level);
  // Parent key -> group, by a sorted copy of the keys.
  std::vector<std::pair<std::uint64_t, std::uint32_t>> group_of(parents.size());
  for (std::size_t g = 0; g < parents.size(); ++g) group_of[g] = {parents[g], static_cast<std::uint32_t>(g)};
  std::sort(group_of.begin(), group_of.end());
  constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> cand_of(live.size(), kNone);
  std::vector<std::uint8_t> flagged(refine.size(), 0);
  const double tolerance = options.surface_tolerance / h;  // in units of the cell
  parallel_for(live.size(), [&](std::size_t s) {
    const Vec3 p = options.surface_samples[live[s]];
    std::array<std::uint32_t, 3> cell;
    Vec3 t;
    for (int a = 0; a < 3; ++a) {
      const double u = (p[a] - cube.lo[a]) / h;
      cell[a] = static_cast<std::uint32_t>(std::clamp(std::floor(u), 0.0, double(cells - 1)));
      t[a] = std::clamp(u - double(cell[a]), 0.0, 1.0);
    }
    std::size_t cand = 0;
    if (!root) {
      const std::uint64_t parent = octree_key(cell[0] / 3, cell[1] / 3, cell[2] / 3);
      const auto it = std::lower_bound(group_of.begin(), group_of.end(), std::make_pair(parent, std::uint32_t{0}));
      if (it == group_of.end() || it->first != parent) return;
      const int c = int(cell[0] % 3 + 3 * (cell[1] % 3) + 9 * (cell[2] % 3));
      if (!(active_mask[it->second] >> c & 1)) return;  // surface-free by its corners: not sampled
      cand = std::size_t{it->second} * 27 + c;
    }
    cand_of[s] = static_cast<std::uint32_t>(cand);
    double phi;
    Vec3 grad;
    trilinear(cell_corners[cand], t, &phi, &grad);
    const double g = norm(grad);
    const double distance = g > 0 ? std::abs(phi) / g : (phi != 0 ? std::numeric_limits<double>::infinity() : 0.0);
    if (distance > tolerance) std::atomic_ref<std::uint8_t>(flagged[cand]).store(1, std::memory_order_relaxed);
  });
  for (std::size_t c = 0; c < refine.size(); ++c) refine[c] |= flagged[c];
  std::size_t kept = 0;
  for (std::size_t s = 0; s < live.size(); ++s)
    if (cand_of[s] != kNone && refine[cand_of[s]]) live[kept++] = live[s];
  live.resize(kept);
}

}  // namespace

Octree refine_octree(const SignedDistance& sdf, const Box& cube, const AdaptiveOptions& options, OctreeStats* stats) {
  if (!(options.threshold > 0) || !std::isfinite(options.threshold))
    throw InputError(fmt::format("--threshold must be a positive number, got {}", options.threshold));
  if (!(options.volume_threshold >= 0) || !std::isfinite(options.volume_threshold))
    throw InputError(fmt::format("--volume-threshold must be a non-negative number, got {}", options.volume_threshold));
  Octree tree(cube, options.max_depth);
  const int depth = options.max_depth;
  if (stats) stats->levels.assign(static_cast<std::size_t>(depth) + 1, {});
  // Lattice points are keyed in units of the finest level's vertex lattice; the finest level whose
  // child lattice is needed is max_depth (children at max_depth are never evaluated for error).
  const std::uint32_t finest = pow3(depth);
  const PackedLattice packed(finest);
  const double edge = cube.hi.x - cube.lo.x;
  const double tolerance = adaptive_tolerance(cube, options);
  const double volume_tolerance = options.volume_threshold * edge * edge * edge;
  const int error_levels = error_depth(options);

  // Candidates come as groups of 27 siblings, the children of a cell refined at the level above
  // (child c at x = c % 3, y = c / 3 % 3, z = c / 9), or the root alone; each with its 8 corner
  // values, sampled with its parent's lattice. A group's child lattices together form a
  // (3n + 1)^3 lattice, n children per axis; it emits each point its active children need once
  // (the sort then merges what neighbouring groups share), which saves the sort most of the 56
  // keys per cell that sharing faces and edges repeats.
  std::vector<std::uint64_t> parents = {};  // the refined cells whose children are the candidates
  // The surface samples still inside a refined cell (the others' leaves are final).
  std::vector<std::uint32_t> live;
  if (options.surface_tolerance > 0) {
    if (options.surface_samples.size() > std::numeric_limits<std::uint32_t>::max())
      throw ResourceError("too many surface samples for the adaptive refinement");
    live.resize(options.surface_samples.size());
    std::iota(live.begin(), live.end(), 0u);
  }
  std::vector<std::array<double, 8>> corners(1);
  for (int level = 0; level < depth; ++level) {
    const bool root = level == 0;
    const std::size_t groups = root ? 1 : parents.size();
    if (groups == 0) break;
    const int n = root ? 1 : 3, w = 3 * n + 1;
    const std::size_t num_candidates = groups * n * n * n;
    const double h = edge / pow3(level);
    const std::uint32_t step = finest / pow3(level + 1);  // child lattice spacing in finest units
    auto candidate = [&](std::size_t g, int c) {
      if (root) return octree_key(0, 0, 0);
      const auto [i, j, k] = octree_unkey(parents[g]);
      return octree_key(3 * i + c % 3, 3 * j + c / 3 % 3, 3 * k + c / 9);
    };
    // Candidates whose corners alone show that no surface passes through them stay leaves
    // without sampling their lattice (cell_may_hold_surface's first test); the others' lattice
    // points, less the corners (sampled a level above; the root has none), are this level's batch.
    using Mask = std::array<std::uint64_t, 16>;  // bit a + w (b + w c) of the group's lattice
    std::vector<Mask> need(groups);
    std::vector<std::uint32_t> active_mask(groups);  // bit c: child c is sampled
    std::vector<std::size_t> key_offset(groups + 1, 0);
    parallel_for(groups, [&](std::size_t g) {
      Mask m{};
      std::uint32_t act = 0;
      for (int c = 0; c < n * n * n; ++c) {
        if (!root && corners_clear(corners[g * 27 + c], h)) continue;
        act |= 1u << c;
        const int x = 3 * (c % n), y = 3 * (c / n % n), z = 3 * (c / (n * n));
        for (int p = 0; p < kChildLatticePoints; ++p) {
          const int a = p % 4, b = p / 4 % 4, d = p / 16;
          if (!root && a % 3 == 0 && b % 3 == 0 && d % 3 == 0) continue;
          const int bit = (x + a) + w * ((y + b) + w * (z + d));
          m[bit / 64] |= std::uint64_t{1} << (bit % 64);
        }
      }
      std::size_t count = 0;
      for (std::uint64_t word : m) count += static_cast<std::size_t>(std::popcount(word));
      need[g] = m;
      active_mask[g] = act;
      key_offset[g + 1] = count;
    });
    for (std::size_t g = 0; g < groups; ++g) key_offset[g + 1] += key_offset[g];
    if (key_offset.back() > std::numeric_limits<std::uint32_t>::max())
      throw ResourceError("the adaptive refinement samples too many points at one level");
    // The group's lattice point -> its index among the group's emitted keys.
    auto rank_table = [&](std::size_t g, std::array<std::uint16_t, 1000>& rank) {
      std::uint16_t r = 0;
      for (int bit = 0; bit < w * w * w; ++bit) {
        rank[bit] = r;
        r = static_cast<std::uint16_t>(r + (need[g][bit / 64] >> (bit % 64) & 1));
      }
    };
    // One batch: every group's keys, deduplicated by a sort.
    std::vector<std::uint64_t> keys(key_offset.back());
    parallel_for(groups, [&](std::size_t g) {
      const auto [i, j, k] = root ? std::array<std::uint32_t, 3>{0, 0, 0} : octree_unkey(parents[g]);
      std::size_t out = key_offset[g];
      for (int bit = 0; bit < w * w * w; ++bit)
        if (need[g][bit / 64] >> (bit % 64) & 1)
          keys[out++] =
              packed.pack((9 * i + bit % w) * step, (9 * j + bit / w % w) * step, (9 * k + bit / (w * w)) * step);
    });
    std::vector<std::uint32_t> id(keys.size());  // a group's key -> its point's index in `fresh`
    std::vector<std::uint64_t> fresh = sorted_distinct(std::move(keys), packed.bits, id);
    parallel_for(fresh.size(), [&](std::size_t p) { fresh[p] = packed.to_octree_key(fresh[p]); });
    std::vector<Vec3> points(fresh.size());
    parallel_for(fresh.size(), [&](std::size_t p) { points[p] = position(cube, fresh[p], finest); });
    std::vector<double> f(fresh.size());
    if (!points.empty()) sdf.evaluate(points, f);
    points = {};
    for (double v : f)
      if (!std::isfinite(v)) throw InputError("the signed distance is not finite at a grid point");
    // Decisions, in parallel; each refined candidate's 64 values kept for its children's corners.
    // Not zeroed (only sampled candidates' arrays are written, and only refined ones read).
    std::unique_ptr<std::array<double, kChildLatticePoints>[]> lattice(
        new std::array<double, kChildLatticePoints>[num_candidates]);
    std::vector<std::uint8_t> refine(num_candidates, 0);
    parallel_chunks(groups, 16, [&](std::size_t gb, std::size_t ge) {
      std::array<std::uint16_t, 1000> rank;
      for (std::size_t g = gb; g < ge; ++g) {
        rank_table(g, rank);
        for (int c = 0; c < n * n * n; ++c) {
          if (!(active_mask[g] >> c & 1)) continue;
          const std::size_t cand = g * n * n * n + c;
          std::array<double, kChildLatticePoints>& v = lattice[cand];
          const int x = 3 * (c % n), y = 3 * (c / n % n), z = 3 * (c / (n * n));
          for (int p = 0; p < kChildLatticePoints; ++p) {
            const int a = p % 4, b = p / 4 % 4, d = p / 16;
            if (!root && a % 3 == 0 && b % 3 == 0 && d % 3 == 0) {
              v[p] = corners[cand][(a / 3) | (b / 3) << 1 | (d / 3) << 2];
              continue;
            }
            v[p] = f[id[key_offset[g] + rank[(x + a) + w * ((y + b) + w * (z + d))]]];
          }
          if (!cell_may_hold_surface(v, h)) continue;
          const double e = refinement_error(v, h);
          refine[cand] =
              level < error_levels && (e > tolerance || (volume_tolerance > 0 && e * h * h > volume_tolerance));
        }
      }
    });
    id = {};
    if (!live.empty()) {
      // AdaptiveOptions::surface_tolerance, at the samples still in refined cells. corners[cand]
      // holds every candidate's corner values but the root's, which only its lattice has.
      if (root)
        for (int c = 0; c < 8; ++c)
          corners[0][c] = lattice[0][child_lattice_index(3 * (c & 1), 3 * (c >> 1 & 1), 3 * (c >> 2))];
      refine_at_surface_samples(cube, level, h, parents, active_mask, corners, options, live, refine);
    }
    std::vector<std::uint64_t> next;
    std::vector<std::array<double, 8>> next_corners;
    std::size_t sampled = 0;
    for (std::size_t g = 0; g < groups; ++g) sampled += static_cast<std::size_t>(std::popcount(active_mask[g]));
    for (std::size_t cand = 0; cand < num_candidates; ++cand) {
      if (!refine[cand]) continue;
      const std::uint64_t cell = candidate(cand / (n * n * n), static_cast<int>(cand % (n * n * n)));
      tree.refine(level, cell);
      next.push_back(cell);
      for (int ch = 0; ch < 27; ++ch) {
        const int x = ch % 3, y = ch / 3 % 3, z = ch / 9;
        std::array<double, 8>& cv = next_corners.emplace_back();
        for (int c = 0; c < 8; ++c)
          cv[c] = lattice[cand][child_lattice_index(x + (c & 1), y + (c >> 1 & 1), z + (c >> 2))];
      }
    }
    if (stats) {
      OctreeLevelStats& s = stats->levels[level];
      s.candidates = num_candidates;
      s.sampled = sampled;
      s.sdf_points = fresh.size();
      s.refined_by_error = next.size();
    }
    tree.record_samples(level, std::move(fresh), std::move(f));
    parents = std::move(next);
    corners = std::move(next_corners);
  }
  return tree;
}

// ---- Balancing -----------------------------------------------------------------------------------

namespace {

// The cells of level L that share a face or an edge, whole or in part, with cell q of level L + 1
// (in L + 1 units q spans [q, q + 1] per axis, a cell p of level L spans [3p, 3p + 3]): per axis the
// cell containing q's span (overlap of length 1) or, when q touches a side of it, the cell beyond
// (overlap of length 0); the boxes share a face or an edge when at least one axis overlaps by 1,
// a vertex only when none does.
template <class F>
void for_each_coarser_edge_neighbour(std::uint64_t q, std::uint32_t n, F&& f) {
  const auto a = octree_unkey(q);
  std::array<std::array<std::uint32_t, 2>, 3> cell{};
  std::array<std::array<bool, 2>, 3> full{};
  std::array<int, 3> count{};
  for (int d = 0; d < 3; ++d) {
    const std::uint32_t p = a[d] / 3;
    cell[d][count[d]] = p;
    full[d][count[d]++] = true;
    if (a[d] % 3 == 0 && p > 0) {
      cell[d][count[d]] = p - 1;
      full[d][count[d]++] = false;
    } else if (a[d] % 3 == 2 && p + 1 < n) {
      cell[d][count[d]] = p + 1;
      full[d][count[d]++] = false;
    }
  }
  for (int x = 0; x < count[0]; ++x)
    for (int y = 0; y < count[1]; ++y)
      for (int z = 0; z < count[2]; ++z)
        if (full[0][x] || full[1][y] || full[2][z]) f(octree_key(cell[0][x], cell[1][y], cell[2][z]));
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
    // Finest first: refining at level L only adds refined cells at L, which the rule carries to
    // L - 1 in the same sweep; their children (new leaves of L + 1) are checked the next round.
    for (int level = depth - 2; level >= 0; --level) {
      std::size_t refined_here = 0;
      const std::uint32_t n = tree.cells_per_axis(level);
      for (std::uint64_t q : tree.refined_cells(level + 1))
        for_each_coarser_edge_neighbour(q, n, [&](std::uint64_t p) {
          if (tree.exists(level, p) && tree.refine(level, p)) ++refined_here;
        });
      if (refined_here) changed = true;
      total += refined_here;
      if (stats) stats->levels[level].refined_by_balance += refined_here;
    }
  }
  if (stats) {
    stats->balance_rounds += rounds;
    // 27 children replace each refined cell.
    std::size_t above = 1;
    for (int level = 0; level <= depth; ++level) {
      const std::size_t refined = level < depth ? tree.refined_cells(level).size() : 0;
      stats->levels[level].leaves = above - refined;
      above = 27 * refined;
    }
  }
  return total;
}

bool octree_balanced(const Octree& tree, std::string* why) {
  const int depth = tree.max_depth();
  for (int level = 0; level + 1 < depth; ++level)
    for (std::uint64_t q : tree.refined_cells(level + 1)) {
      bool ok = true;
      std::uint64_t bad = 0;
      for_each_coarser_edge_neighbour(q, tree.cells_per_axis(level), [&](std::uint64_t p) {
        if (ok && tree.exists(level, p) && !tree.is_refined(level, p)) {
          ok = false;
          bad = p;
        }
      });
      if (!ok) {
        if (why) {
          const auto [i, j, k] = octree_unkey(bad);
          *why = fmt::format("leaf ({}, {}, {}) of level {} shares a face or an edge with leaves of level {}", i, j, k,
                             level, level + 2);
        }
        return false;
      }
    }
  return true;
}

// ---- The complex ------------------------------------------------------------------------------------

namespace {

// Every template in every rotation with its corners already moved, as distinct points (boundary
// points first, then inner ones) and each hex corner's index there.
constexpr std::size_t kMaxTemplatePoints = 128;  // the largest template (14) has 108

struct RotatedTemplate {
  std::vector<TemplatePoint> points;
  std::size_t boundary = 0;  // points[0, boundary) lie on the leaf's boundary
  std::vector<std::array<std::uint8_t, 8>> corners;
};
struct RotatedTemplates {
  std::array<std::array<RotatedTemplate, kNumCubeRotations>, kNumTemplates> rotated;
  std::array<std::vector<std::uint8_t>, kNumTemplates> type;   // cell_types() index per hex
  std::array<std::vector<std::uint8_t>, kNumTemplates> child;  // 1: a child cube (next level)
};

const RotatedTemplates& rotated_templates() {
  static const RotatedTemplates t = [] {
    RotatedTemplates t;
    for (int k = 0; k < kNumTemplates; ++k) {
      const auto hexes = template_hexes(k);
      for (std::size_t h = 0; h < hexes.size(); ++h) {
        t.type[k].push_back(static_cast<std::uint8_t>(template_hex_type(k, static_cast<int>(h)).type));
        t.child[k].push_back(hexes[h].child ? 1 : 0);
      }
      for (int r = 0; r < kNumCubeRotations; ++r) {
        RotatedTemplate& rt = t.rotated[k][r];
        std::vector<TemplatePoint> inner;
        for (const TemplateHex& h : hexes)
          for (const TemplatePoint& c : h.corners) {
            const TemplatePoint p = transform_template_point(c, r);
            std::vector<TemplatePoint>& list = on_leaf_boundary(p) ? rt.points : inner;
            if (std::find(list.begin(), list.end(), p) == list.end()) list.push_back(p);
          }
        rt.boundary = rt.points.size();
        rt.points.insert(rt.points.end(), inner.begin(), inner.end());
        if (rt.points.size() > kMaxTemplatePoints) throw std::logic_error("a template with too many points");
        for (const TemplateHex& h : hexes) {
          std::array<std::uint8_t, 8>& c = rt.corners.emplace_back();
          // The rotation keeps the hex right-handed; its corners move with it.
          for (int i = 0; i < 8; ++i) {
            const TemplatePoint p = transform_template_point(h.corners[i], r);
            c[i] = static_cast<std::uint8_t>(std::find(rt.points.begin(), rt.points.end(), p) - rt.points.begin());
          }
        }
      }
    }
    return t;
  }();
  return t;
}

constexpr int kSingleTemplate = 0;  // id 1: the leaf itself

}  // namespace

// The leaves come in groups, the 27 children of each refined cell (or the root alone when it is
// not refined). Each group emits its distinct boundary keys: one per used point of the children's
// 4 x 4 x 4 lattice for its single-hex leaves, each template leaf's own boundary points; the sort
// merges what groups share. Inner template points need no key: they are the leaf's alone.
AdaptiveGrid build_adaptive_complex(const Octree& tree) {
  const int depth = tree.max_depth();
  const Box& cube = tree.cube();
  const double edge = cube.hi.x - cube.lo.x;
  const std::uint32_t units = kTemplateBoundaryUnits * pow3(depth);  // point units per cube edge
  const PackedLattice packed(units);
  const RotatedTemplates& rt = rotated_templates();

  struct Group {
    std::uint64_t first_child;            // the lowest child's cell key at `level`
    std::uint8_t level;                   // of the children
    std::uint8_t n;                       // children per axis: 3, or 1 for the unrefined root
    std::array<std::uint16_t, 27> child;  // template * 24 + rotation, or kRefined
    std::uint64_t lattice = 0;            // bit a + (n + 1) (b + (n + 1) c): a corner of a single-hex leaf
  };
  // Beyond every template * 24 + rotation (the largest is 359).
  constexpr std::uint16_t kRefined = 0xFFFF;
  static_assert(kNumTemplates * kNumCubeRotations < kRefined);
  std::vector<Group> groups;
  if (!tree.is_refined(0, 0)) groups.push_back({0, 0, 1, {}, 0});
  for (int level = 1; level <= depth; ++level)
    for (std::uint64_t p : tree.refined_cells(level - 1)) {
      const auto [i, j, k] = octree_unkey(p);
      groups.push_back({octree_key(3 * i, 3 * j, 3 * k), static_cast<std::uint8_t>(level), 3, {}, 0});
    }
  // Pass 1: each group's templates, cells, keys and inner points.
  std::vector<std::size_t> cell_offset(groups.size() + 1, 0), key_offset(groups.size() + 1, 0),
      inner_offset(groups.size() + 1, 0);
  std::vector<std::uint8_t> bad(groups.size(), 0);
  parallel_for(groups.size(), [&](std::size_t g) {
    Group& gr = groups[g];
    const auto [i0, j0, k0] = octree_unkey(gr.first_child);
    const int n = gr.n, w = n + 1;
    std::size_t cells = 0, keys = 0, inner = 0;
    for (int c = 0; c < n * n * n; ++c) {
      const int x = c % n, y = c / n % n, z = c / (n * n);
      const std::uint64_t cell = octree_key(i0 + x, j0 + y, k0 + z);
      if (tree.is_refined(gr.level, cell)) {
        gr.child[c] = kRefined;
        continue;
      }
      const TemplateChoice choice = template_for_marks(tree.marks(gr.level, cell));
      if (gr.level == depth && choice.t != kSingleTemplate) bad[g] = 1;
      gr.child[c] = static_cast<std::uint16_t>(choice.t * kNumCubeRotations + choice.rotation);
      if (choice.t == kSingleTemplate) {
        ++cells;
        for (int q = 0; q < 8; ++q)
          gr.lattice |= std::uint64_t{1} << ((x + kCubeCorners[q][0]) +
                                             w * ((y + kCubeCorners[q][1]) + w * (z + kCubeCorners[q][2])));
      } else {
        const RotatedTemplate& t = rt.rotated[choice.t][choice.rotation];
        cells += t.corners.size();
        keys += t.boundary;
        inner += t.points.size() - t.boundary;
      }
    }
    cell_offset[g + 1] = cells;
    key_offset[g + 1] = keys + static_cast<std::size_t>(std::popcount(gr.lattice));
    inner_offset[g + 1] = inner;
  });
  if (std::find(bad.begin(), bad.end(), 1) != bad.end())
    throw std::logic_error("build_adaptive_complex: a leaf at the deepest level has marks");
  AdaptiveGrid out;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    cell_offset[g + 1] += cell_offset[g];
    key_offset[g + 1] += key_offset[g];
    inner_offset[g + 1] += inner_offset[g];
    out.levels = std::max(out.levels, groups[g].level + 1);
    for (int c = 0; c < groups[g].n * groups[g].n * groups[g].n; ++c)
      if (groups[g].child[c] != kRefined) ++out.leaves_per_template[groups[g].child[c] / kNumCubeRotations];
  }
  const std::size_t num_cells = cell_offset.back(), num_keys = key_offset.back(), num_inner = inner_offset.back();
  if (num_keys + num_inner > std::numeric_limits<std::uint32_t>::max())
    throw ResourceError(
        fmt::format("the adaptive grid would have {} cells, more than this program indexes", num_cells));
  // Pass 2: keys, inner points, and each cell corner's slot: a key slot below num_keys, an inner
  // point's index + num_keys above.
  std::vector<std::uint64_t> keys(num_keys);
  std::vector<Vec3> inner_points(num_inner);
  out.complex.cells.resize(num_cells);
  out.cell_type.resize(num_cells);
  out.cell_level.resize(num_cells);
  out.complex.cell_size.resize(num_cells);
  const double inner_units = double(units) * kTemplateUnits;
  parallel_for(groups.size(), [&](std::size_t g) {
    const Group& gr = groups[g];
    const auto [i0, j0, k0] = octree_unkey(gr.first_child);
    const int n = gr.n, w = n + 1;
    const std::uint64_t size = units / pow3(gr.level);  // child edge in point units
    // p * size / 14400 is exact on the boundary: p is a multiple of 240 there and size a multiple
    // of 60 (a leaf at max_depth is a single hex, p in {0, 14400}).
    auto at = [size](int p) { return std::uint64_t(p) * size / kTemplateUnits; };
    std::size_t key = key_offset[g], inner = inner_offset[g], cell = cell_offset[g];
    std::array<std::uint8_t, 64> rank;  // of each used lattice point among them
    for (int b = 0; b < w * w * w; ++b) {
      rank[b] = static_cast<std::uint8_t>(key - key_offset[g]);
      if (gr.lattice >> b & 1)
        keys[key++] = packed.pack((i0 + b % w) * size, (j0 + b / w % w) * size, (k0 + b / (w * w)) * size);
    }
    const double child_size = edge / pow3(gr.level);
    for (int c = 0; c < n * n * n; ++c) {
      if (gr.child[c] == kRefined) continue;
      const int x = c % n, y = c / n % n, z = c / (n * n);
      const int t_id = gr.child[c] / kNumCubeRotations;
      if (t_id == kSingleTemplate) {
        for (int q = 0; q < 8; ++q) {
          const int b = (x + kCubeCorners[q][0]) + w * ((y + kCubeCorners[q][1]) + w * (z + kCubeCorners[q][2]));
          out.complex.cells[cell][q] = static_cast<std::uint32_t>(key_offset[g] + rank[b]);
        }
        out.cell_type[cell] = rt.type[t_id][0];
        out.cell_level[cell] = gr.level;
        out.complex.cell_size[cell] = child_size;
        ++cell;
        continue;
      }
      const RotatedTemplate& t = rt.rotated[t_id][gr.child[c] % kNumCubeRotations];
      const std::uint64_t o[3] = {(i0 + x) * size, (j0 + y) * size, (k0 + z) * size};
      std::array<std::uint32_t, kMaxTemplatePoints> slot;  // per template point
      for (std::size_t p = 0; p < t.points.size(); ++p) {
        const TemplatePoint& q = t.points[p];
        if (p < t.boundary) {
          slot[p] = static_cast<std::uint32_t>(key);
          keys[key++] = packed.pack(o[0] + at(q[0]), o[1] + at(q[1]), o[2] + at(q[2]));
        } else {
          // Exact integers over units * 14400 per axis, rounded once, as `position` does.
          auto t = [&](int d) { return o[d] * kTemplateUnits + size * std::uint64_t(q[d]); };
          inner_points[inner] = {coordinate(cube.lo.x, cube.hi.x, t(0), inner_units),
                                 coordinate(cube.lo.y, cube.hi.y, t(1), inner_units),
                                 coordinate(cube.lo.z, cube.hi.z, t(2), inner_units)};
          slot[p] = static_cast<std::uint32_t>(num_keys + inner++);
        }
      }
      for (std::size_t h = 0; h < t.corners.size(); ++h, ++cell) {
        for (int q = 0; q < 8; ++q) out.complex.cells[cell][q] = slot[t.corners[h][q]];
        out.cell_type[cell] = rt.type[t_id][h];
        const int level = gr.level + rt.child[t_id][h];
        out.cell_level[cell] = static_cast<std::uint8_t>(level);
        out.complex.cell_size[cell] = edge / pow3(level);
      }
    }
  });
  // Key slots -> point ids, points in key order; inner points after them.
  std::vector<std::uint32_t> point_of(num_keys);
  const std::vector<std::uint64_t> points = sorted_distinct(std::move(keys), packed.bits, point_of);
  const std::size_t shared = points.size();
  parallel_for(num_cells, [&](std::size_t c) {
    for (std::uint32_t& q : out.complex.cells[c])
      q = q < num_keys ? point_of[q] : static_cast<std::uint32_t>(shared + (q - num_keys));
  });
  point_of = {};
  // Their SDF values where the refinement sampled them (core/grid/octree.h).
  out.complex.box = cube;
  out.complex.points.resize(shared + num_inner);
  out.values.assign(shared + num_inner, std::numeric_limits<double>::quiet_NaN());
  std::vector<std::uint8_t> sampled(shared);
  constexpr std::uint32_t kFine = kTemplateBoundaryUnits;  // point units per finest-lattice step
  parallel_for(shared, [&](std::size_t p) {
    const std::uint64_t key = packed.to_octree_key(points[p]);
    out.complex.points[p] = position(cube, key, units);
    const auto [x, y, z] = octree_unkey(key);
    double v = std::numeric_limits<double>::quiet_NaN();
    if (x % kFine == 0 && y % kFine == 0 && z % kFine == 0 &&
        tree.sampled_value(octree_key(x / kFine, y / kFine, z / kFine), &v))
      sampled[p] = 1;
    out.values[p] = v;
  });
  std::copy(inner_points.begin(), inner_points.end(), out.complex.points.begin() + static_cast<std::ptrdiff_t>(shared));
  for (std::size_t p = 0; p < shared; ++p)
    if (!sampled[p]) out.unsampled.push_back(static_cast<std::uint32_t>(p));
  for (std::size_t p = shared; p < shared + num_inner; ++p) out.unsampled.push_back(static_cast<std::uint32_t>(p));
  return out;
}

namespace {

// The key of the level-`level` cell that holds x: a point on a cell boundary goes to the cell
// above it (by floor), and the cube's far faces to the last cell.
std::uint64_t key_at(const Box& cube, int level, const Vec3& x) {
  const double edge = cube.hi.x - cube.lo.x, n = pow3(level);
  auto index = [&](int a) {
    return static_cast<std::uint64_t>(std::clamp(std::floor((x[a] - cube.lo[a]) / edge * n), 0.0, n - 1));
  };
  return octree_key(index(0), index(1), index(2));
}

}  // namespace

std::size_t refine_leaves_of_cells(Octree& tree, const AdaptiveGrid& grid, std::span<const std::uint32_t> cells) {
  std::size_t refined = 0;
  for (std::uint32_t c : cells) {
    // The cell's vertex average lies inside its leaf (the template's hexes tile the leaf); the
    // uniform template's children sit one level below theirs.
    Vec3 centre{0, 0, 0};
    for (std::uint32_t p : grid.complex.cells.at(c)) centre = centre + grid.complex.points[p] / 8.0;
    for (int level = grid.cell_level[c]; level >= std::max(0, grid.cell_level[c] - 1); --level) {
      const std::uint64_t key = key_at(tree.cube(), level, centre);
      if (!tree.exists(level, key) || tree.is_refined(level, key)) continue;
      if (level < tree.max_depth() && tree.refine(level, key)) ++refined;
      break;
    }
  }
  if (refined) balance_octree(tree);
  return refined;
}

int leaf_level_at(const Octree& tree, Vec3 p) {
  const Box& cube = tree.cube();
  for (int a = 0; a < 3; ++a)
    if (!(p[a] >= cube.lo[a] && p[a] <= cube.hi[a])) return -1;
  int level = 0;
  while (level < tree.max_depth() && tree.is_refined(level, key_at(cube, level, p))) ++level;
  return level;
}

std::size_t refine_leaves_at_points(Octree& tree, std::span<const Vec3> points, std::size_t min_points) {
  const Box& cube = tree.cube();
  // The leaves first (level, key), then refined in sorted order: the same tree however the points
  // are ordered or repeated.
  std::vector<std::uint64_t> leaves(points.size(), ~std::uint64_t{0});
  parallel_for(points.size(), [&](std::size_t i) {
    const Vec3 p = points[i];
    const int level = leaf_level_at(tree, p);
    // Cell indices are below 3^9 < 2^15, so a key is below 2^57 and the level fits above it.
    if (level >= 0 && level < tree.max_depth()) leaves[i] = (std::uint64_t(level) << 60) | key_at(cube, level, p);
  });
  std::sort(leaves.begin(), leaves.end());
  std::size_t refined = 0;
  for (std::size_t i = 0, j = 0; i < leaves.size(); i = j) {
    while (j < leaves.size() && leaves[j] == leaves[i]) ++j;
    const std::uint64_t l = leaves[i];
    if (l == ~std::uint64_t{0} || j - i < min_points) continue;
    if (tree.refine(int(l >> 60), l & ((std::uint64_t{1} << 60) - 1))) ++refined;
  }
  if (refined) refined += balance_octree(tree);
  return refined;
}

std::vector<Vec3> unsampled_points(const AdaptiveGrid& grid) {
  std::vector<Vec3> out(grid.unsampled.size());
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = grid.complex.points[grid.unsampled[i]];
  return out;
}

void set_unsampled_values(AdaptiveGrid& grid, std::span<const double> values) {
  if (values.size() != grid.unsampled.size())
    throw std::logic_error("set_unsampled_values: one value per unsampled point");
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i])) throw InputError("the signed distance is not finite at a grid point");
    grid.values[grid.unsampled[i]] = values[i];
  }
  grid.unsampled.clear();
}

void evaluate_unsampled(AdaptiveGrid& grid, const SignedDistance& sdf) {
  const std::vector<Vec3> points = unsampled_points(grid);
  std::vector<double> values(points.size());
  if (!points.empty()) sdf.evaluate(points, values);
  set_unsampled_values(grid, values);
}

}  // namespace mchex
