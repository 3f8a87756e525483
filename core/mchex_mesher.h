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

#include <span>

#include "core/grid.h"
#include "core/mchex_stats.h"
#include "core/ro.h"

namespace mchex {

// values: the SDF (f > 0 inside) at every grid vertex in UniformGrid::vertex_index order.
// eps in (0, 0.5): crossing parameters are clamped to [eps, 1 - eps] so that no polyhedron has
// a (near-)zero-length edge. Deterministic: a serial loop over the cells in grid order.
// Throws InputError for a bad eps, a values size mismatch or a non-finite value.
MeshPair mesh_mchex(const UniformGrid& grid, std::span<const double> values, double eps,
                    MchexStats* stats = nullptr);

}  // namespace mchex
