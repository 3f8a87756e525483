// Orientation repair of a triangle surface before meshing.
//
// The mesher's inside/outside comes from the surface's orientation (the reference SDF takes its
// sign from the angle-weighted pseudonormal, core/sdf/sdf.h), and real "closed" models are often
// oriented inconsistently, inside out, or are soups with duplicated faces and nested shells.
// repair_orientation() makes the orientation what the solid means, in four steps:
//
//  1. Cleaning. Faces with a repeated vertex index are removed. Exact duplicate faces (the same
//     three vertices) are grouped; within a group, a face and an opposite-orientation copy cancel
//     and both are removed, and of the copies that remain (all of one orientation) the first in
//     input order is kept. A cancelled pair is a zero-thickness sheet: the two faces bound no
//     volume and their winding numbers cancel everywhere, so removing them leaves the winding
//     number of every point off the surface unchanged (it is also how two solids that share a
//     wall, each with its own copy, become their union). Zero-area faces with three distinct
//     vertices are kept (they carry topology) and only counted.
//  2. Consistency. A component is a set of triangles connected through manifold edges (edges with
//     exactly two triangles); boundary and non-manifold edges separate components. A
//     breadth-first walk from the component's lowest triangle (smallest sorted vertex triple,
//     so that a permutation of the input walks the same way) gives each triangle a parity: a
//     neighbour that traverses the shared edge the same way as its parent gets the opposite
//     parity. The minority parity is flipped, so the larger part keeps its orientation (a tie
//     keeps the lowest triangle's). An edge that contradicts the walk makes the component
//     non-orientable (a Moebius band); such a component is left as the walk made it.
//  3. Outward. A closed component (orientable, and using each of its edges exactly twice, in
//     opposite directions, so shells that touch along a non-manifold edge stay closed) is
//     oriented so that its signed volume is positive, unless it is a cavity: a component inside
//     an odd number of other closed components is oriented inward. "Inside" is the winding
//     number of the other component, a solid-angle sum (Van Oosterom and Strackee, "The solid
//     angle of a plane triangle", IEEE Trans. Biomed. Eng. 1983) rounded to an integer, at the
//     centroid of the component's lowest triangle; two components that intersect each other
//     (step 4) are never nested. Bounding-box containment selects the candidates, and the
//     brute-force sums are bounded (kNestingBudget); past the bound every closed component is
//     oriented outward and nesting_checked is false. Open components keep step 2's
//     orientation: without an inside they have no outward.
//  4. Self-intersection (reported, nothing changed). Candidate pairs come from a uniform grid
//     over the triangles' bounding boxes; two triangles intersect when an edge of one properly
//     crosses the other, decided with orientation predicates in double (for non-coplanar
//     triangles an edge of one meets the other exactly when they intersect). Pairs that share
//     an edge are adjacent and skipped; pairs that share one vertex are tested (a crossing away
//     from the vertex is found). Touching contacts (an orientation exactly zero) and coplanar
//     overlaps are not counted. Beyond kSelfIntersectionMaxTriangles triangles, a grid that would
//     need more than about 32 entries a triangle or hand over more than
//     kSelfIntersectionCandidates pairs, or a non-finite coordinate, the test is not run. It runs before step 3, which
//     needs to know which components cross each other. The count is exact, not capped: the
//     budgets bound the work, and counting every pair found costs nothing more.
//
// The result depends only on the input: every step is serial or writes per-index outputs, the
// walks and tie-breaks use the vertex indices, and the surviving triangles keep their input
// order. Vertices that only removed faces used are removed too (bounds() stays the surface's);
// the others keep their order and values, and vertices no face used are left alone. A surface
// that needs nothing (closed, consistent, outward, no duplicates) comes back bit for bit
// unchanged.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "core/mesh/surface.h"

namespace mchex {

struct OrientationReport {
  // Step 1.
  std::size_t degenerate_faces_removed = 0;   // a repeated vertex index
  std::size_t duplicate_faces_removed = 0;    // includes both faces of each cancelled pair
  std::size_t cancelled_pairs = 0;            // opposite-orientation duplicate pairs (zero-thickness sheets)
  std::size_t zero_area_faces = 0;            // distinct vertices, zero area: kept
  std::size_t orphaned_vertices_removed = 0;  // used only by removed faces
  // Step 2, over the cleaned surface.
  std::size_t components = 0;  // connected through manifold edges
  std::size_t nonorientable_components = 0;
  std::size_t flipped_triangles = 0;  // the minority of each component's walk
  std::size_t boundary_edges = 0;     // one triangle (holes)
  std::size_t boundary_loops = 0;     // connected pieces of the boundary-edge graph
  std::size_t nonmanifold_edges = 0;  // three or more triangles
  // Step 3.
  std::size_t closed_components = 0;    // see step 3
  std::size_t cavities = 0;             // closed components oriented inward (odd nesting)
  std::size_t reversed_components = 0;  // closed components turned over to face the right way
  std::size_t reversed_triangles = 0;   // the triangles of those components
  bool nesting_checked = true;          // false: kNestingBudget exceeded, all oriented outward
  // Step 4.
  bool self_intersection_checked = false;   // false: past a bound (see step 4)
  std::size_t self_intersecting_pairs = 0;  // exact count of intersecting pairs when checked

  friend bool operator==(const OrientationReport&, const OrientationReport&) = default;
  bool changed() const {
    return degenerate_faces_removed + duplicate_faces_removed + flipped_triangles + reversed_triangles > 0;
  }
};

// Work bounds. Nesting: at most this many pairs of closed components whose boxes are compared,
// and as many winding-number terms summed. Self-intersection: the triangle count, and the
// candidate pairs its grid may hand to the exact test.
inline constexpr std::size_t kNestingBudget = 100'000'000;
inline constexpr std::size_t kSelfIntersectionMaxTriangles = std::size_t{1} << 22;
inline constexpr std::size_t kSelfIntersectionCandidates = 400'000'000;

// Repairs `surface` in place (steps 1 to 3 above) and reports what it found and did. Throws
// InputError for a vertex index out of range, ResourceError from 2^30 triangles.
OrientationReport repair_orientation(TriangleSurface& surface);

// The report in one line for a log: what was found, then only what was done, e.g.
// "2 components (2 closed, 1 cavity), no boundary, no non-manifold edge, self-intersections:
// none; flipped 12 triangles, reversed 1 component".
std::string describe(const OrientationReport& report);

}  // namespace mchex
