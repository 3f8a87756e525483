// Volume-centre offsets (Tong & Zhang 2025, Section 5 and Section 8, Equation 14 and Table 3):
// for the polyhedra whose plain midpoint subdivision is not certified, the volume centre (the one
// point that all of a polyhedron's hexes share) is moved by an offset vector v in the cell's
// parametric space: centre = X(u_c + v), with u_c the mean of the polyhedron's vertices in
// parametric coordinates (the paper's "barycentric coordinates of the volume centre", e.g.
// ((5+s1+s6)/10, (3+s10+s11)/10, (4+s3+s7)/10) for its Figure 6 "Case 12") and X the cell's
// trilinear map (Eq. 7-8). Only this interior point moves, so the hexes still tile the polyhedron
// and their volumes still add up to its volume.
//
// Which polyhedra: the paper's "Case 12" is MC33 case 11 here (tests/test_polyhedra.cpp says how
// the volume centres identify it) and 14 is its mirror image: each has two 10-vertex, 7-face
// polyhedra (docs/mc33.md), and all four are images of ONE polyhedron under the 48
// cube symmetries - the region of corners {0,1,5,6} of case 11's representative (in 11 and 14
// a region's polyhedron depends on its corners alone: no face of either case is ambiguous).
//
// The rule (ours, found by solving the Eq. 14 problem on this code; the paper's own numbers are
// in its supplementary notebooks, not in its text): a constant offset cannot certify that
// polyhedron even on the unit cube with crossings in [eps, 1 - eps] (the best constant leaves a
// Bernstein coefficient of -1.9e-2 (edge-scaled) at the extreme crossings), so the offset is an
// affine function of the polyhedron's 6 crossing parameters,
//     v_i(s) = a_i0 + sum_j a_ij (s_j - 1/2),   i = x, y, z,  j over its 6 cut edges,
// the paper's piecewise-constant Table 3 made continuous. tests/test_volume_centre_offset.cpp
// holds the search that found the coefficients (DISABLED_, it takes minutes) and the certificate.
//
// Where it certifies: on affine cells (parallelepipeds: the unit cube and its images, which the
// certificate cannot tell apart, Theorem 5.2). On the transition cells of the 3-refinement
// templates no offset can: for some crossings and rotations no position of the centre at all
// makes every hex positive (the tests give a Farkas certificate of that on the node cell), so
// there core/cutting/local_refinement.h refines 11 and 14 as before (cell_shape below decides). That
// route is not certified on transition cells either (`mchex-gpu certify` reports negative
// coefficients there for 11 and 14 through refinement, as for several direct subcases).
// The uniform grid's cells are all affine, so there every 11 and 14 cell is cut with 20 hexes.
#pragma once

#include <array>
#include <cstdint>
#include <optional>

#include "core/base/geometry.h"
#include "core/cutting/mc33.h"
#include "core/cutting/polyhedron.h"

namespace mchex {

// The one table: the offset rule of one polyhedron on the unit cube; every polyhedron of the
// listed subcases whose region is an image of `region_corners` under a cube symmetry takes it
// through that symmetry.
struct VolumeCentreOffsetRule {
  std::array<Subcase, 2> subcases{};
  std::uint8_t region_corners = 0;                      // bit c <=> cell corner c (VTK order)
  std::array<std::uint8_t, 6> edges{};                  // the crossings s_j, as Table-1 edges (0-based)
  std::array<std::array<double, 7>, 3> coefficients{};  // [axis][0: constant, 1 + j: s_j - 1/2]
};
const VolumeCentreOffsetRule& volume_centre_offset_rule();

// Parametric coordinates (in [0,1]^3) of a cell point: a corner, or the crossing on an edge at
// the class's crossing parameter (Table 1: (1 - s) * corner[a] + s * corner[b]).
Vec3 cell_point_parameter(CellPointKey k, const CellClass& c);
// The cell's trilinear map (paper Eq. 7-8) at parametric point u.
Vec3 trilinear_point(const std::array<Vec3, 8>& corners, const Vec3& u);
// The mean of the polyhedron's vertices in parametric coordinates (u_c above).
Vec3 parametric_volume_centre(const Polyhedron& p, const CellClass& c);

// The rule evaluated on the rule's own polyhedron for crossings s (Table-1 order, 0-based).
Vec3 rule_offset(const VolumeCentreOffsetRule& rule, const std::array<double, 12>& s);

// The offset of the polyhedron of the region with these corners of this classified cell, in the
// CELL's parametric coordinates, or nullopt where there is none (the plain vertex mean).
std::optional<Vec3> volume_centre_offset(const CellClass& c, std::uint8_t region_corners);

// A displacement in the parametric coordinates of a symmetry's image moved back into the
// coordinates it came from (kCubeSymmetries index; reflections included).
Vec3 offset_to_cell(const Vec3& image_offset, int symmetry);

// Affine cells (X affine: a parallelepiped, e.g. every cell of a uniform grid and the child
// cubes of the templates) against the rest (the templates' transition hexes, local refinement's
// frustums): the four non-affine coefficients of the trilinear map are zero to 1e-9 of the
// cell's size.
enum class CellShape : std::uint8_t { kAffine, kGeneral };
CellShape cell_shape(const std::array<Vec3, 8>& corners);

}  // namespace mchex
