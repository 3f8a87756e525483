// Adaptive 3-refinement of the padded cube (Tong & Zhang 2025, Section 3 and Algorithm 1, lines
// 1-6): an octree whose cells split into 27 children, refined where the paper's feature-sensitive
// error says the parent's trilinear interpolant misplaces the surface; then balanced so that the
// vertex-based 3-refinement templates (core/grid/templates.h) turn its leaves into a conforming hex
// grid with no hanging node, made of the cell types of core/grid/cell_types.h.
//
// Refinement (refine_octree). Level by level from the root: the children of the cells refined at
// the level above are the candidates; the SDF is evaluated in ONE batch per level at the child
// lattices of the candidates (the 4 x 4 x 4 lattice of core/grid/refinement_error.h: the corners of
// their 27 children), points shared between cells deduplicated by a sort of their integer
// lattice coordinates, so each point is evaluated once and every cell sees the same bit-identical
// value. A candidate is refined when both
//   (1) the surface can pass through it (cell_may_hold_surface: its sampled values do not prove
//       it surface-free), and
//   (2) refinement_error(its 64 values, h) > T * h_min, h_min = cube edge / 3^max_depth.
// (1) makes refinement follow the surface. The paper's error alone also fires where the SDF is
// not smooth: its kinks on the medial axis, far from the surface, where |grad f| jumps; refined
// there, they went to max_depth and balancing spread them (a sphere's centre, a torus's core
// circle, a box's medial planes), which the mesh does not need: a cell the surface misses is
// never cut, whatever its error.
// (2) is the paper's error, a distance (how far the parent's trilinear isosurface lies from its
// 27 children's), held to T finest cells. T is therefore RELATIVE TO THE FINEST CELL SIZE:
// --max-depth sets the resolution, T the accuracy asked of coarser cells in units of it. At 0.05
// (the paper's batch run) a curved surface refines to within one level of max_depth, a surface
// that the trilinear interpolant already places well (planes, gentle curvature) stays coarse, and
// the inside mesh's fidelity (IoU) matches the uniform grid of the finest cell size. (Relative to
// each cell's own size, the test stopped smooth surfaces at a level set by their curvature, well
// above max_depth, and lost fidelity against that uniform grid.)
// Candidates whose 8 corners already prove them surface-free (the first test of
// cell_may_hold_surface, on values sampled with the parent's lattice) are not sampled at all.
//
// The values are kept (Octree::sampled_value): the complex reuses them at its points, so the
// pipeline evaluates the SDF once per point; only points never sampled (template points, children
// of cells that balancing refined) need one more batch (evaluate_unsampled).
//
// Balancing (balance_octree): MODERATE balance (Tong & Zhang, "Element-Saving Hexahedral
// 3-Refinement Templates"): leaves that share a face or an edge, whole or in part, differ by at
// most one level; leaves that meet only at a vertex may differ by more. A leaf of level L that
// shares a face or an edge with a refined cell of level L + 1 (whose children are two levels
// finer) is refined, to a fixed point. Refinements only ever grow and never pass max_depth, so the
// loop ends. Nothing else is needed: the marks are the corners of the refined cells (Octree::refine
// sets them), a leaf's corner is marked exactly when a finer leaf touches it, and the complete
// template set (core/grid/templates.h) has a template for all 256 markings, concave edges and
// corners included, so a refined region stays within a layer of the cells its error chose instead
// of filling its bounding box (the standard set's cost, paper Section 7). Why the grid conforms:
// core/grid/templates.h and docs/templates.md.
//
// The complex (build_adaptive_complex): every leaf replaced by its template. Points on a leaf's
// boundary are keyed by exact integer coordinates at a common resolution, 60 * 3^max_depth units
// per cube edge (template boundary points are sixtieths of a leaf, and a leaf of level L spans
// 60 * 3^(max_depth - L) units), and computed from those integers, so one point has one id and
// bit-identical coordinates whichever cell produced it. A template's inner points belong to its
// leaf alone: they get their own ids and coordinates from the leaf's integer origin and the
// template's 1/14400 units. Point ids follow the sorted keys (a radix sort, the dedupe; inner
// points after the shared ones in the order of their leaves) and cells follow the leaves in
// (level, key) order: the complex is the same on any number of threads.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/base/geometry.h"
#include "core/grid/hex_complex.h"
#include "core/grid/refinement_error.h"
#include "core/grid/templates.h"
#include "core/sdf/sdf.h"

namespace mchex {

// Deepest adaptive level: 60 * 3^9 = 1,180,980 point units per axis fit the 21-bit key fields.
inline constexpr int kMaxAdaptiveDepth = 9;

struct AdaptiveOptions {
  double threshold = 0.05;  // refine while error > threshold * finest cell size (see above)
  int max_depth = 5;        // 0 .. kMaxAdaptiveDepth
  // >= 0: the error tests (threshold, volume_threshold) refine only cells above this level, and
  // the threshold is in units of ITS cell size; the levels below it, to max_depth, are left to
  // the surface test and to refine_leaves_at_points (the fitted grid's measured rounds). -1: max_depth.
  int error_depth = -1;
  // > 0: a cell is also refined when its error times its area, error x h^2, exceeds
  // volume_threshold x the cube's volume (the volume the parent's isosurface misplaces, held to a
  // fraction of the box; see refine_octree). 0: the distance test alone.
  double volume_threshold = 0;
  // > 0 with surface_samples (points on the input surface): a cell holding a sample p is also
  // refined when the distance from p to the cell's own trilinear isosurface, estimated as
  // |phi(p)| / |grad phi(p)| with phi the trilinear interpolant of its 8 corner values, exceeds
  // surface_tolerance (a length): the input-to-mesh side of the Hausdorff distance, which the
  // refinement error, measured at lattice points, misses at sharp tips and edges and on parts
  // thinner than the lattice. The span must outlive refine_octree.
  double surface_tolerance = 0;
  std::span<const Vec3> surface_samples = {};
};

// The error a cell may have: options.threshold * (cube edge / 3^max_depth).
double adaptive_tolerance(const Box& cube, const AdaptiveOptions& options);

// Whether the zero level set can pass through the closed cube of edge `size` whose child lattice
// has these values (core/grid/refinement_error.h layout). False only when it cannot: |f| is at most the
// distance to the surface (exact for the analytic shapes and the triangle SDF; a lower bound in
// the two-holed solid's junction), so the surface misses the ball of radius |f(p)| around a
// lattice point p, and a cube of edge s is covered by the balls around its 8 corners when the
// smallest |f| exceeds half its diagonal (every point of the cube lies within s sqrt(3) / 2 of
// its nearest corner, the centre being the farthest) or the largest |f| exceeds the whole diagonal.
// Tested on the whole cell's 8 corners (refine_octree knows them before sampling the lattice, so
// a cell cleared there is never sampled), then on each of its 27 sub-cubes; the corners of a test
// must also have one sign and none be zero (an open surface's SDF can change sign away from the
// surface). Conservative: a cell within about sqrt(3) / 6 of its size of the surface may be kept.
bool cell_may_hold_surface(const std::array<double, kChildLatticePoints>& values, double size);

// A set of 64-bit keys (open addressing, linear probing); the key ~0 is reserved.
class KeySet {
 public:
  bool insert(std::uint64_t key);  // true when new
  bool contains(std::uint64_t key) const;
  std::size_t size() const { return keys_.size(); }
  const std::vector<std::uint64_t>& keys() const { return keys_; }  // insertion order
  void reserve(std::size_t n);

 private:
  void grow();
  std::vector<std::uint64_t> slots_;
  std::vector<std::uint64_t> keys_;
};

// Cell (i, j, k) of a level, or a lattice vertex (i, j, k) of a level, as one key.
constexpr std::uint64_t octree_key(std::uint64_t i, std::uint64_t j, std::uint64_t k) {
  return i | (j << 21) | (k << 42);
}
constexpr std::array<std::uint32_t, 3> octree_unkey(std::uint64_t key) {
  return {static_cast<std::uint32_t>(key & 0x1FFFFF), static_cast<std::uint32_t>((key >> 21) & 0x1FFFFF),
          static_cast<std::uint32_t>(key >> 42)};
}

class Octree {
 public:
  Octree(const Box& cube, int max_depth);

  const Box& cube() const { return cube_; }
  int max_depth() const { return max_depth_; }
  std::uint32_t cells_per_axis(int level) const;

  // A cell exists when it is the root or its parent is refined.
  bool exists(int level, std::uint64_t cell) const;
  bool is_refined(int level, std::uint64_t cell) const;
  // Refines an existing leaf (level < max_depth) and marks its 8 corners; returns false if it
  // already was refined.
  bool refine(int level, std::uint64_t cell);
  // Refined cells of a level (level < max_depth), sorted by key.
  std::vector<std::uint64_t> refined_cells(int level) const;
  // Leaves of a level, by their parents in the order those were refined (deterministic, unsorted).
  std::vector<std::uint64_t> leaves(int level) const;
  std::size_t leaf_count() const;
  // Marked corners of a cell: bit c <=> its corner c (VTK order) is marked.
  std::uint8_t marks(int level, std::uint64_t cell) const;

  // SDF values sampled by refine_octree, per level (keys sorted, in finest-lattice units:
  // 3^max_depth per cube edge). sampled_value finds one by its finest-lattice key.
  void record_samples(int level, std::vector<std::uint64_t> keys, std::vector<double> values);
  bool sampled_value(std::uint64_t finest_key, double* value) const;

 private:
  struct LevelSamples {
    std::vector<std::uint64_t> keys;
    std::vector<double> values;
  };
  Box cube_;
  int max_depth_;
  std::vector<KeySet> refined_;  // per level 0 .. max_depth - 1
  std::vector<KeySet> marks_;    // per level 0 .. max_depth - 1, vertex keys
  std::vector<LevelSamples> samples_;
};

struct OctreeLevelStats {
  std::size_t candidates = 0;  // cells that could refine (children of refined cells)
  std::size_t sampled = 0;     // candidates whose corners did not rule the surface out
  std::size_t sdf_points = 0;  // distinct new points in this level's batch
  std::size_t refined_by_error = 0;
  std::size_t refined_by_balance = 0;
  std::size_t leaves = 0;  // after balancing
};
struct OctreeStats {
  std::vector<OctreeLevelStats> levels;
  int balance_rounds = 0;
};

// Error-driven refinement; throws InputError for a bad threshold or depth.
Octree refine_octree(const SignedDistance& sdf, const Box& cube, const AdaptiveOptions& options,
                     OctreeStats* stats = nullptr);

// Refines until the tree is moderately balanced (above); returns the cells it refined.
std::size_t balance_octree(Octree& tree, OctreeStats* stats = nullptr);

// Whether the tree is moderately balanced; `why` names the first leaf that is not.
bool octree_balanced(const Octree& tree, std::string* why = nullptr);

struct AdaptiveGrid {
  HexComplex complex;
  std::vector<std::uint8_t> cell_type;   // index into cell_types() per cell
  std::vector<std::uint8_t> cell_level;  // octree level of the cube the cell came from
  std::array<std::size_t, kNumTemplates> leaves_per_template{};
  int levels = 0;  // deepest level with a leaf, + 1
  // The SDF at every point where refine_octree sampled it (bit for bit the value a new evaluation
  // at that point gives: same integer key, same coordinates); NaN at the points listed in
  // `unsampled` until set_unsampled_values / evaluate_unsampled fills them.
  std::vector<double> values;
  std::vector<std::uint32_t> unsampled;  // ascending point ids
};

// The leaves replaced by their templates. Throws std::logic_error for an unbalanced tree.
AdaptiveGrid build_adaptive_complex(const Octree& tree);

// The run-time remedy for a cut cell whose polyhedron no certificate covers (docs/templates.md,
// "Certification"): refines the octree leaves that `cells` of `grid` (built from `tree`) came from
// and rebalances; returns the leaves refined. Leaves at max_depth are single hexes, the cube type,
// which certify proves for every subcase, so a cell can always be refined until it certifies.
std::size_t refine_leaves_of_cells(Octree& tree, const AdaptiveGrid& grid, std::span<const std::uint32_t> cells);

// Refines the leaf that holds each point (a point on a face between leaves goes to the leaf above
// it, by floor; points outside the cube are ignored; leaves at max_depth stay) and rebalances;
// returns the leaves refined, balancing included. The fitted grid's measured rounds
// (core/pipeline/pipeline.cpp) refine so where the mesh lies farther from the input than the target.
// min_points: a leaf is refined only when at least this many of the points fall in it.
std::size_t refine_leaves_at_points(Octree& tree, std::span<const Vec3> points, std::size_t min_points = 1);

// The level of the leaf that holds p (a point on a face between leaves goes to the leaf above it,
// by floor, as refine_leaves_at_points has it); -1 outside the cube.
int leaf_level_at(const Octree& tree, Vec3 p);

// The dedupe behind the SDF batches and the complex's points: the distinct values of `keys`
// (each below 2^key_bits), ascending, and index_of[i] = the index of keys[i] among them. A stable
// LSD radix sort, parallel in fixed chunks: the same result on any number of threads.
std::vector<std::uint64_t> sorted_distinct(std::vector<std::uint64_t> keys, int key_bits,
                                           std::span<std::uint32_t> index_of);

// The points of `unsampled`, in its order, for one SDF batch on any backend; then their values,
// in the same order (InputError for a non-finite one). evaluate_unsampled does both with `sdf`.
std::vector<Vec3> unsampled_points(const AdaptiveGrid& grid);
void set_unsampled_values(AdaptiveGrid& grid, std::span<const double> values);
void evaluate_unsampled(AdaptiveGrid& grid, const SignedDistance& sdf);

}  // namespace mchex
