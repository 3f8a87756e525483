// MCHex cutting of one cell into 3-regular polyhedra (Tong & Zhang 2025, Section 5: "the
// isosurface will intersect the cell into 3-regular polyhedra, with each being split into hexes
// via midpoint subdivision"; Definition 4.2).
//
// The polyhedra are built generically from a CellClass (core/cutting/mc33.h), not from per-subcase
// tables:
//   vertices  a region's corners, plus the crossing point on every cut edge that leaves one of
//             them, at the Table-1 local point mapped by the cell (on a cell edge the trilinear
//             map is linear, so the point is (1 - s) * corner[a] + s * corner[b]);
//   faces     (a) the pieces of the six cell faces that belong to the region: a face is split by
//             chords joining its crossing points; a face with 4 crossings is ambiguous and its
//             two corners of the sign that CellClass::face_joins names are joined (one hexagon),
//             the two others cut off (two triangles);
//             (b) the isosurface polygons: the chords that bound a region's face pieces close up
//             into loops of crossing points, one polygon per loop. The inside and outside
//             polyhedra on the two sides of a loop list it in opposite orientation.
// Every face is listed counter-clockwise seen from outside its polyhedron. A corner has the 3
// neighbours along its cell edges (or the crossings on them); a crossing has its edge's corner
// and one chord in each of the two cell faces through its edge: every vertex has degree 3, which
// is what Theorem 4.1 needs for midpoint subdivision to give only hexes.
//
// Scope: the 25 non-tunnel subcases and kEmpty. In the 6 tunnel subcases (4.1.2, 6.1.2, 7.4.2,
// 10.1.2, 12.1.2, 13.5.2) the face chords are those of the non-tunnel partner but one region is a
// solid torus, which is no polyhedron of this kind; the paper refines those cells first (Section
// 5, Figure 7), so cut_cell refuses them.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <vector>

#include "core/base/geometry.h"
#include "core/cutting/mc33.h"
#include "core/cutting/polyhedron.h"

namespace mchex {

// Thrown for the tunnel subcases, which need local refinement first.
struct TunnelSubcaseError : std::domain_error {
  using std::domain_error::domain_error;
};

// The polyhedra of one classified cell, one per region in the order of c.regions (kEmpty: the
// cell itself). `corners` are the cell's corners in VTK order. Throws TunnelSubcaseError for a
// tunnel subcase and std::logic_error if the classification is inconsistent with itself (a face
// piece whose corners lie in two regions, a chord that does not close into a loop).
std::vector<Polyhedron> cut_cell(const std::array<Vec3, 8>& corners, const CellClass& c);
// The same into `out`, whose vectors keep their storage (certify cuts millions of cells); on a
// throw its contents are unspecified.
void cut_cell(const std::array<Vec3, 8>& corners, const CellClass& c, std::vector<Polyhedron>& out);

// Signed volume enclosed by the faces (divergence theorem, each face fanned from the mean of its
// vertices, which is exact for planar faces and a consistent choice for warped ones: neighbouring
// polyhedra fan a shared face the same way, so their volumes add up).
double polyhedron_volume(const Polyhedron& p);

}  // namespace mchex
