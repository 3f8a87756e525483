// The MCHex mesher (Tong & Zhang 2025, Section 5): every cell of a conforming hex complex (a
// uniform grid, or the adaptive grid after its templates) is classified by Marching Cubes 33,
// cut by the isosurface into 3-regular polyhedra, and each polyhedron is split into hexes by
// midpoint subdivision (Definition 4.3, Theorem 4.1). The hexes of the inside polyhedra form the
// solid's mesh, the others the mesh of the box around it.
//
// Conformity comes from names, never from matching coordinates. Every hex corner is one of:
//   a grid point          its point id;
//   on a grid edge        (edge id, slot): slot 1 the crossing, slots 0 / 2 the midpoints of the
//                         parts from the edge's lower / higher point id to it (an uncut edge has
//                         slot 0 only, its midpoint); the crossing parameter depends only on the
//                         edge's two values, so every cell around the edge agrees;
//   on a grid face        (face id, slot): slots 0..3 the centroid of the face piece whose
//                         lowest-ranked corner has that rank in the face's canonical order
//                         (core/grid/complex_topology.h), slots 4..7 the midpoint of the isosurface
//                         chord across the face, by its lower-ranked face edge;
//   inside the cell       the centroid of an isosurface polygon, the volume centre of a
//                         polyhedron: the cell's own, shared by its inside and outside polyhedra.
// Edges and faces are numbered once (build_topology), so cells resolve these names by index
// arithmetic. The cells run in parallel, in fixed chunks; a shared point's coordinates are
// written by its owner (the lowest cell around its edge or face) only, so the output is the same
// byte for byte whatever the thread count.
//
// The subcases whose polyhedra midpoint subdivision cannot certify, the six tunnel subcases among
// them, are cut as their local refinement's leaves (core/cutting/local_refinement.h, paper Figure 7):
// their inner points and everything on the faces between the leaves are the cell's own points.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string_view>
#include <vector>

#include "core/grid/grid.h"
#include "core/grid/hex_complex.h"
#include "core/mesh/hex_mesh.h"

namespace mchex {

// One slot per core/cutting/mc33.h Subcase (kEmpty and the 31); static_assert'ed in mchex_mesher.cpp.
inline constexpr int kMchexCaseSlots = 32;
// The subcase name of a slot ("empty", "1", ..., "13.5.2", "14").
std::string_view mchex_case_name(int slot);

struct MchexStats {
  std::array<std::size_t, kMchexCaseSlots> cases{};  // cells per subcase (index: mc33 Subcase)
  std::size_t refined_cells = 0;                     // cells cut as their local refinement (paper Figure 7)
  std::size_t refined_cells_two_levels = 0;
  std::size_t perturbed_values = 0;       // grid values moved off zero by the zero rule
  std::size_t expected_hexes = 0;         // sum over cells of local_refinement_hexes(subcase)
  std::size_t moved_centres = 0;          // polyhedra whose volume centre core/cutting/repair.h moved
  std::size_t uncertified_polyhedra = 0;  // polyhedra with a hex not certified even so
  // The cells those polyhedra came from, ascending, each once: what the pipeline's remedy refines
  // (core/pipeline/remedy.h). Empty in every run measured so far; the guarantee does not rest on it.
  std::vector<std::uint32_t> uncertified_cells;
  std::size_t points = 0;  // distinct global points (both meshes together)
  // Exact crossings (MchexCrossings::field): the cut edges whose zero was searched, the field
  // evaluations that took (batches of one point per edge still open), and the largest |f| left
  // at a crossing taken, relative to its edge's length.
  std::size_t exact_crossings = 0, crossing_batches = 0;
  double crossing_residual = 0;
  // Wall time of the stages: numbering the complex's edges and faces, cutting + subdividing the
  // cells (parallel), and assembling the two meshes from the chunks.
  double seconds_topology = 0, seconds_crossings = 0, seconds_cells = 0, seconds_assembly = 0;
};

// Zero rule: a grid value with |f| < zero_tolerance(h) = 1e-10 * h (h the smallest cell size of
// the complex, the SDF being a distance) becomes -zero_tolerance(h): "on the surface counts as
// outside", as in core/mc33.h. It is applied once to the point values, so every cell sharing a
// point sees the same value, and no crossing lands exactly on a corner.
double zero_tolerance(double cell_size);
// The tolerance the mesher uses for a complex: zero_tolerance of its smallest cell size (of the
// box's diagonal when the complex has no cell sizes).
double zero_tolerance_of(const HexComplex& complex);

// The zero rule applied to a copy of `values` (the SDF at the complex's points): the values every
// cell is classified from. A device that classifies for the mesher (core/device/backend.h
// classify_cells) is given these. Throws InputError for a size mismatch or a non-finite value;
// `perturbed` (optional) counts the values moved.
std::vector<double> apply_zero_rule(const HexComplex& complex, std::span<const double> values,
                                    std::size_t* perturbed = nullptr);

// A device's MC33 classification of the same values after the zero rule (core/device/backend.h
// classify_cells), handed to the mesher so that the device's work is used and checked rather
// than trusted: subcases[i] is cell i's core/cutting/mc33.h Subcase, hex_offsets the exclusive prefix sum
// of local_refinement_hexes(subcase) over the cells (cells + 1 entries; the count on a general
// cell, an upper bound: the device does not see the shapes, and an affine cell of 11 or 14 is cut
// directly into fewer). Either may be empty. A cell whose subcase differs from the host's
// classify(), or a chunk whose subcase count differs from the device's, is a std::logic_error
// naming the cell(s): a backend that disagrees with core is a bug, never a silently different mesh.
struct DeviceClassification {
  std::span<const std::uint8_t> subcases;
  std::span<const std::uint64_t> hex_offsets;
};

// The SDF at a batch of points (the run's backend: every backend gives the same values).
using SdfBatch = std::function<void(std::span<const Vec3>, std::span<double>)>;

// Where a cut edge's crossing lies. By default where the linear interpolation of the edge's two
// values is zero (Marching Cubes; the paper's Eq. 6), which depends on the two values alone. With
// `field` (the field the values came from, at any points: the SDF batch of the run's backend),
// the crossing is the field's own zero on the edge, found by bracketed secant steps (Illinois)
// from the linear one: the point where the grid edge meets the input's facets, as the MCHex
// prototype computes it and as Awad et al. cut their cells. The interpolated crossing misses it
// most near a sharp edge, where the distance to the nearest facet stops being linear along the
// grid edge (docs/pipeline.md, "Exact crossings"). Either depends only on the edge (its two ends
// and the field), so every cell around it agrees; edges inside a locally refined cell keep the
// linear rule.
struct MchexCrossings {
  SdfBatch field;
};

// What a search of crossings did: edges searched, batches of `field`, the largest |f| left at a
// crossing relative to its edge's length.
struct CrossingSearch {
  std::size_t edges = 0, batches = 0;
  double residual = 0;
};

// The search of MchexCrossings: for each edge e of `which` (every edge when empty), t[e] = where
// the field is zero on the segment points[edges[e][0]] -> points[edges[e][1]] (0 at the first),
// bracketed secant steps with the Illinois rule (the end kept twice in a row has its value
// halved) from the linear crossing, in batches of one point per edge still open, until |f| is
// below 1e-9 of the edge's length or the bracket below 1e-12; NaN where the values (after the
// zero rule with `tiny`: a point on the surface counts as outside) have one sign. Each edge's
// steps depend on its own values alone, so the result does not depend on the threads or the
// order of `which`. `stats` (optional) accumulates.
void search_crossings(std::span<const Vec3> points, std::span<const std::array<std::uint32_t, 2>> edges,
                      std::span<const double> values, double tiny, const SdfBatch& field,
                      std::span<const std::uint32_t> which, std::span<double> t, CrossingSearch* stats = nullptr);

// values: the SDF (f > 0 inside) at every point of the complex.
// eps in (0, 0.5): crossing parameters are clamped to [eps, 1 - eps] so that no polyhedron has
// a (near-)zero-length edge. Deterministic for any thread count.
// Throws InputError for a bad eps, a values size mismatch or a non-finite value.
MeshPair mesh_mchex(const HexComplex& complex, std::span<const double> values, double eps, MchexStats* stats = nullptr,
                    const DeviceClassification& device = {}, const MchexCrossings& crossings = {});
// The uniform grid (values in UniformGrid::vertex_index order) through uniform_complex().
MeshPair mesh_mchex(const UniformGrid& grid, std::span<const double> values, double eps, MchexStats* stats = nullptr);

}  // namespace mchex
