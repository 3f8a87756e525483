// Adaptive 3-refinement of the padded cube (Tong & Zhang 2025, Section 3 and Algorithm 1, lines
// 1-6): an octree whose cells split into 27 children, refined where the paper's feature-sensitive
// error says the parent's trilinear interpolant misplaces the surface; then balanced so that the
// standard 3-refinement templates (core/templates.h) turn its leaves into a conforming hex grid
// with no hanging node, made of the paper's 9 basic cell types (core/cell_types.h).
//
// Refinement (refine_octree). Level by level from the root: every cell of the level is a
// candidate while the level is below max_depth; the SDF is evaluated in ONE batch per level at
// the corners of all candidates' 27 children (the 4 x 4 x 4 lattice of core/refinement_error.h),
// points shared between cells deduplicated by their integer lattice coordinates, so each is
// evaluated once and every cell sees the same bit-identical value. A candidate is refined when
//     refinement_error(its 64 values, h) > threshold * h,
// h its edge length: the threshold is RELATIVE TO THE CELL SIZE. refinement_error is a distance
// (how far the parent's isosurface lies from the children's), so the test reads "the parent
// misplaces the surface by more than threshold of its own size". It is dimensionless, so one value
// suits a model of any size and scale; 0.05 (the paper's batch run) refines a smooth surface until
// cells are about a fifth of its radius of curvature (the trilinear error of a surface of radius
// R is about 0.2 h^2 / R) and refines creases and the SDF's own kinks (the medial axis, where
// |grad f| jumps) down to max_depth.
//
// Balancing (balance_octree). A MARK on a vertex of level L says that the cells of level L
// around it continue the finer level there: every corner of a refined cell is marked, and a leaf
// whose marked corners form a pattern no template handles gets more marks, the fewest that make
// one (Schneiders' marking closure, as in the vanilla code of
// CMU-CBML/Element-Saving-Hexahedral-3-Refinement-Templates): three corners of a face, or two
// opposite corners of a face, mark the whole face; a pattern in no face (two opposite corners
// of the cell, marks on two faces, ...) refines the leaf, which marks all 8 of its corners. To a
// fixed point, for every leaf c of level L:
//   (a) no mark of level L + 1 lies in c's closed box (it would put a fine point on c's
//       boundary): the leaves touching c are at most one level finer, and the fine cubes a
//       template continues into c never meet a finer cell;
//   (b) c's marked corners form a template's pattern: none, one corner, the two corners of an
//       edge, the four of a face (template_for_marks).
// Marks and refinements only ever grow, and never beyond max_depth (a rule is only broken next to
// a mark of the leaf's own level or the next, and marks of level L exist only below max_depth),
// so the loop ends. Each face's pattern then depends only on its 4 corners' marks, which both
// cells sharing it see alike: the complex conforms.
//
// The complex (build_adaptive_complex): every leaf replaced by its template. Points are keyed by
// exact integer coordinates at a common resolution, 4 * 3^max_depth units per cube edge (template
// points are twelfths of a leaf, and a leaf above max_depth has 4 * 3^(max_depth - L) units, a
// multiple of 12), and computed from those integers, so one point has one id and bit-identical
// coordinates whichever cell produced it. Point ids follow the sorted keys and cells follow the
// leaves in (level, key) order: the complex is the same on any number of threads.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/geometry.h"
#include "core/hex_complex.h"
#include "core/sdf.h"
#include "core/templates.h"

namespace mchex {

// Deepest adaptive level: 4 * 3^10 = 236,196 point units per axis fit the 21-bit key fields.
inline constexpr int kMaxAdaptiveDepth = 10;

struct AdaptiveOptions {
  double threshold = 0.05;  // refine while error > threshold * (cell edge length)
  int max_depth = 5;        // 0 .. kMaxAdaptiveDepth
};

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
  // Marks vertex (i, j, k) of a level (< max_depth); returns false if it already was marked.
  bool mark(int level, std::uint64_t vertex);
  bool is_marked(int level, std::uint64_t vertex) const;
  std::vector<std::uint64_t> marked_vertices(int level) const;  // sorted
  // Refined cells of a level (level < max_depth), sorted by key.
  std::vector<std::uint64_t> refined_cells(int level) const;
  // Leaves of a level, sorted by key.
  std::vector<std::uint64_t> leaves(int level) const;
  std::size_t leaf_count() const;
  // Marked corners of a cell: bit c <=> its corner c (VTK order) is marked.
  std::uint8_t marks(int level, std::uint64_t cell) const;

 private:
  Box cube_;
  int max_depth_;
  std::vector<KeySet> refined_;  // per level 0 .. max_depth - 1
  std::vector<KeySet> marks_;    // per level 0 .. max_depth - 1, vertex keys
};

// The fewest marks that contain `marks` and have a template (0xFF where only refinement does).
std::uint8_t mark_closure(std::uint8_t marks);

struct OctreeLevelStats {
  std::size_t candidates = 0;          // cells whose error was evaluated
  std::size_t sdf_points = 0;          // distinct new points in this level's batch
  std::size_t refined_by_error = 0;
  std::size_t refined_by_balance = 0;
  std::size_t marks_added = 0;         // by the closure, beyond the refined cells' corners
  std::size_t leaves = 0;              // after balancing
};
struct OctreeStats {
  std::vector<OctreeLevelStats> levels;
  int balance_rounds = 0;
};

// Error-driven refinement; throws InputError for a bad threshold or depth.
Octree refine_octree(const SignedDistance& sdf, const Box& cube, const AdaptiveOptions& options,
                     OctreeStats* stats = nullptr);

// Refines until rules (a) and (b) above hold for every leaf; returns the cells it refined.
std::size_t balance_octree(Octree& tree, OctreeStats* stats = nullptr);

// Whether rules (a) and (b) hold; `why` names the first leaf that breaks one.
bool octree_balanced(const Octree& tree, std::string* why = nullptr);

struct AdaptiveGrid {
  HexComplex complex;
  std::vector<std::uint8_t> cell_type;   // index into cell_types() per cell
  std::vector<std::uint8_t> cell_level;  // octree level of the cube the cell came from
  std::array<std::size_t, kNumTemplateKinds> leaves_per_template{};
  int levels = 0;  // deepest level with a leaf, + 1
};

// The leaves replaced by their templates. Throws std::logic_error for an unbalanced tree.
AdaptiveGrid build_adaptive_complex(const Octree& tree);

}  // namespace mchex
