// The MCHex mesher on a uniform grid (Tong & Zhang 2025, Section 5): every cell is classified by
// Marching Cubes 33, cut by the isosurface into 3-regular polyhedra, and each polyhedron is split
// into hexes by midpoint subdivision (Definition 4.3, Theorem 4.1). The hexes of the inside
// polyhedra form the solid's mesh, the others the mesh of the box around it.
//
// Conformity comes from global point keys, never from matching coordinates: each hex corner is
// named by what it is in the grid, so the cells (and the polyhedra of one cell) that share a
// point compute the same key and get the same point id:
//   grid corner       its grid vertex index;
//   crossing          its grid edge (3 * lower vertex + axis); the crossing parameter depends
//                     only on the edge's two values, so every cell around the edge agrees;
//   edge midpoint     the unordered pair of its end points' keys;
//   face centroid     a piece of a cell face: (grid face, lowest grid corner of the piece) -- a
//                     piece always has a corner, and the pieces of one face share no corner;
//                     an isosurface polygon: (cell, lowest crossing of the loop) -- it is
//                     shared by the inside and outside polyhedra of one cell only;
//   volume centre     (cell, polyhedron index): never shared.
// A key's coordinates are those computed the first time it is met (cells in grid order), so a
// shared point is bit-identical wherever it is used and both output meshes take their points
// from the same array (the interface matches exactly, as check_mesh requires).
//
// Known gaps (printed in the statistics, not hidden):
//  - the six tunnel subcases (4.1.2, 6.1.2, 7.4.2, 10.1.2, 12.1.2, 13.5.2) are meshed with
//    their non-tunnel partner's topology (same face chords, the interior not joined); the paper
//    refines those cells locally instead (Section 5, Figure 7), which is not implemented yet;
//  - plain midpoint subdivision without the volume-centre offset the paper uses for cases 12
//    and 14 (Section 5, Figure 6), so some hexes there are not Bernstein-certified.
#pragma once

#include <array>
#include <cstddef>
#include <span>
#include <string_view>

#include "core/grid.h"
#include "core/ro.h"

namespace mchex {

// One slot per core/mc33.h Subcase (kEmpty and the 31); static_assert'ed in mchex_mesher.cpp.
inline constexpr int kMchexCaseSlots = 32;
// The subcase name of a slot ("empty", "1", ..., "13.5.2", "14").
std::string_view mchex_case_name(int slot);

struct MchexStats {
  std::array<std::size_t, kMchexCaseSlots> cases{};  // cells per subcase (index: mc33 Subcase)
  std::size_t tunnel_cells = 0;     // tunnel subcases meshed with the partner's topology
  std::size_t perturbed_values = 0; // grid values moved off zero by the zero rule
  std::size_t expected_hexes = 0;   // sum over cells of 8 + 2 * cut edges
  std::size_t points = 0;           // distinct global points (both meshes together)
};

// Zero rule: a grid value with |f| < zero_tolerance(h) = 1e-10 * h (h the cell size, the SDF
// being a distance) becomes -zero_tolerance(h): "on the surface counts as outside", as in
// core/mc33.h. It is applied once to the vertex array, so every cell sharing the vertex sees the
// same value, and no crossing lands exactly on a corner (the clamp below then keeps it inside).
double zero_tolerance(double cell_size);


// values: the SDF (f > 0 inside) at every grid vertex in UniformGrid::vertex_index order.
// eps in (0, 0.5): crossing parameters are clamped to [eps, 1 - eps] so that no polyhedron has
// a (near-)zero-length edge. Deterministic: a serial loop over the cells in grid order.
// Throws InputError for a bad eps, a values size mismatch or a non-finite value.
MeshPair mesh_mchex(const UniformGrid& grid, std::span<const double> values, double eps,
                    MchexStats* stats = nullptr);

}  // namespace mchex
