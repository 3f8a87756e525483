// The certified mesh optimiser: moves the vertices of an inside/outside hex mesh pair to raise
// the minimum and mean scaled Jacobian (and keep the edge ratio down) without ever losing the
// Bernstein certificate of a hex (docs/optimize.md).
//
// Method. The two meshes are optimised as one: their interface points (shared by exact
// coordinates) become single vertices, so a move of an interface vertex is judged by the inside
// and the outside hexes it touches at once and written to both meshes. The vertices are coloured
// so that no two of a colour share a hex (greedy, in vertex order); a sweep visits the colours
// in turn and, within a colour, moves every vertex whose incident hexes include one below
// OptimizeOptions::active_below, all in parallel: a vertex's incident hexes hold no other vertex
// of its colour, so the moves are independent and the result does not depend on the threads.
// A vertex tries a few candidate positions (the mean of the "ideal corner" of each incident hex,
// where the corner would be if that hex were a parallelepiped of its other corners; the mean of
// its edge neighbours; the gradient of the worst scaled Jacobian among its hexes), each at full,
// half, quarter and eighth step, and takes the one that raises the minimum scaled Jacobian of
// its incident hexes most (or, at an equal minimum, their mean), among those that keep every
// incident hex Bernstein-certified (all 27 coefficients of det J positive) and keep the edge
// ratio of each under OptimizeOptions::max_edge_ratio (or no worse than it was). Once these plain
// sweeps stall, a second phase adds, where a vertex's hexes stay below 0.3, a compass search from
// the chosen point (14 directions, halving steps; not for surface vertices on the surface) and 8
// more tangent directions for a surface vertex on the surface, projected; it visits a vertex away
// from the surface only when one of its hexes is below OptimizeOptions::search_active_below, and
// stops after three stalled sweeps in a row (fewer hexes below 0.3 is progress there). The result
// is never below the plain sweeps' own. A third phase then lowers the edge ratios above
// OptimizeOptions::max_edge_ratio: vertices of such hexes move to lower the hexes' summed excess
// over it (steps that lengthen a shortest or shorten a longest edge, the candidates above, and
// for free vertices the compass search), no hex's ratio rising past max(cap, its own), the
// vertex's hexes kept at least at min(their minimum, max(the pair's minimum, 0.3)).
//
// Constraints. Vertices on the inside mesh's boundary (the interface) stay on the input surface:
// each candidate is moved in the tangent plane and projected onto the surface (the exact closest
// point for a triangle surface, Newton steps on the field for an analytic shape); without a
// surface they are fixed. One the mesher put off the surface (its points are only near it) and
// no projected candidate suits may search within the ball around its closest point through where
// it is: it never gets farther from the surface, and a projected candidate taken later puts it on
// the surface. Features come from the input's own geometry (core/mesh/
// feature_curves.h: triangle pairs folded by more than OptimizeOptions::feature_angle, chained
// into curves that meet at corners), not from the mesh: a boundary vertex whose quads fold by
// that angle represents a feature only where an input sharp edge lies within its size (then the
// nearest corner within it, else that curve, is its target). Such a vertex moves on the surface,
// never away from its target, and first tries to reach it; once on it, it slides along the
// curve (projected onto its polyline) or, at a corner, stays. Where the quads fold but the input
// is smooth (a thin part a cell or two thick, on a model without sharp edges), the vertex is a
// plain surface vertex. Vertices on a face of the outer box move in its plane, on an edge of the
// box along it; box corners are fixed.
//
// Guarantees. No hex that was certified loses its certificate; the minimum scaled Jacobian of the
// pair never falls (each accepted move raises or keeps the minimum of the hexes it changes, or in
// the third phase keeps them at least at the pair's minimum); the
// result is the same on any number of threads; the interface stays shared (same coordinates in
// both meshes); each sweep costs time linear in the hexes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <span>
#include <vector>

#include "core/base/geometry.h"
#include "core/mesh/hex_mesh.h"
#include "core/mesh/surface.h"
#include "core/sdf/sdf.h"

namespace mchex {

// The crossing clamp (MeshOptions::eps) that `mesh --optimize` uses unless --eps is given. The
// mesher's default, 1e-3, leaves polyhedra of 1e-3 of a cell around a grid point the surface
// nearly touches; their hexes can only be fixed by moving that whole cluster at once, which
// single-vertex moves cannot (docs/optimize.md, "Measured"). At 0.02 the clusters are 20 times
// larger and the optimiser brings them to the targets, while projecting the boundary onto the
// surface recovers the fidelity the wider clamp costs.
inline constexpr double kOptimizeEps = 0.02;

struct OptimizeOptions {
  int max_sweeps = 60;
  // The second phase (the search and the tangent candidates) once the plain sweeps stall; false
  // stops there, with the optimiser as it was before the search (30 sweeps at most then).
  bool search = true;
  // A vertex is moved in a sweep when one of its hexes has a scaled Jacobian below this (hexes
  // above it are left as they are: most of a grid's hexes are cubes).
  double active_below = 0.8;
  // In the second phase, a vertex that shares no hex with a surface vertex is visited only when
  // one of its hexes is below this (the others still below active_below: the fidelity is theirs).
  double search_active_below = 0.5;
  // Degrees between the normals of two input triangles that make their edge sharp, and between
  // two boundary quads that make their vertex a fold.
  double feature_angle = 40;
  double max_edge_ratio = 20;  // a move may not raise a hex's edge ratio past this (or past its own)
  // After the search, at most this many sweeps that lower the edge ratios above max_edge_ratio
  // (the third phase; not run without `search`).
  int ratio_sweeps = 20;
  // Stop when a sweep raises the minimum scaled Jacobian by less than this and the mean by less
  // than ten times it.
  double tolerance = 1e-4;
};

// The worst hex after optimisation and what holds it.
struct WorstHex {
  std::size_t hex = 0;  // index in its mesh
  int region = 0;       // kInside or kOutside
  Vec3 centre;
  double scaled_jacobian = 0;
  double edge_ratio = 0;
  int fixed_corners = 0;    // box corners, surface vertices without a surface, high valence
  int surface_corners = 0;  // on the input surface (movable along it)
  int box_corners = 0;      // on a face or edge of the box (movable along it)
};

struct OptimizeStats {
  int sweeps = 0;
  std::size_t hexes = 0, vertices = 0;  // of the pair, interface vertices counted once
  std::size_t free_vertices = 0, surface_vertices = 0, box_vertices = 0, fixed_vertices = 0;
  // Surface vertices that represent the input's sharp features (core/mesh/feature_curves.h):
  // those of a curve and those of a corner; and of them, those that lie on it after the sweeps.
  std::size_t curve_vertices = 0, corner_vertices = 0;
  std::size_t feature_vertices = 0;  // the two together
  std::size_t snapped_vertices = 0;
  std::size_t feature_curves = 0, feature_edges = 0;  // of the input (angle OptimizeOptions::feature_angle)
  int colours = 0;
  double min_sj_before = 0, min_sj_after = 0, mean_sj_before = 0, mean_sj_after = 0;
  double max_edge_ratio_before = 0, max_edge_ratio_after = 0;
  std::size_t certified_before = 0, certified_after = 0;
  std::size_t below_0_3_before = 0, below_0_3_after = 0;  // hexes with scaled Jacobian < 0.3
  std::size_t below_0_3_touching_fixed = 0;               // of those after: with a fixed corner
  // Hexes whose edge ratio is above max_edge_ratio by more than rounding (1e-9 relative).
  std::size_t above_edge_ratio_cap_before = 0, above_edge_ratio_cap_after = 0;
  std::size_t moves_accepted = 0, moves_rejected = 0;  // vertex visits with / without a move
  std::vector<double> min_per_sweep;                   // min scaled Jacobian after each sweep
  double seconds = 0;                                  // everything: setup, sweeps, statistics
  double sweep_seconds = 0;                            // the sweeps alone, wall
  double sweep_cpu_seconds = 0;                        // the same in CPU seconds of all threads (a loaded machine
                                                       // distorts this far less than the wall time)
  // The first phase (the plain sweeps) and the third (edge ratios): their sweeps and wall
  // seconds; the rest of `sweeps` and `sweep_seconds` is the second phase's.
  int plain_sweeps = 0, ratio_sweeps = 0;
  double plain_sweep_seconds = 0, ratio_sweep_seconds = 0;
  WorstHex worst;
  // Hexes of the pair processed per second per sweep.
  double hexes_per_second() const { return sweep_seconds > 0 ? double(hexes) * sweeps / sweep_seconds : 0; }
  double hexes_per_cpu_second() const { return sweep_cpu_seconds > 0 ? double(hexes) * sweeps / sweep_cpu_seconds : 0; }
  // The same per phase (wall).
  double plain_hexes_per_second() const {
    return plain_sweep_seconds > 0 ? double(hexes) * plain_sweeps / plain_sweep_seconds : 0;
  }
  int search_sweeps() const { return sweeps - plain_sweeps - ratio_sweeps; }
  double search_sweep_seconds() const { return sweep_seconds - plain_sweep_seconds - ratio_sweep_seconds; }
  double search_hexes_per_second() const {
    const double t = search_sweep_seconds();
    return search_sweeps() > 0 && t > 0 ? double(hexes) * search_sweeps() / t : 0;
  }
  double ratio_hexes_per_second() const {
    return ratio_sweeps > 0 && ratio_sweep_seconds > 0 ? double(hexes) * ratio_sweeps / ratio_sweep_seconds : 0;
  }
};

// Optimises the pair in place. `surface` is the solid's field (its zero set is the input
// surface): a SurfaceSdf gives exact closest points, any other field Newton projection; null
// fixes the boundary. `triangles`, the surface the SurfaceSdf was built from, gives the
// features; without it (an analytic shape, whose built-in kinds are smooth) there are none.
// `meshes.outside` may be empty: then the inside mesh alone is optimised and its boundary kept
// on the surface.
OptimizeStats optimize(MeshPair& meshes, const SignedDistance* surface, const OptimizeOptions& options = {},
                       const TriangleSurface* triangles = nullptr);

// The boundary snapped onto the surface, certified (`mesh` does it after each cut unless
// --no-snap; docs/pipeline.md, "The boundary snapped"). Every vertex of the inside mesh's
// boundary (the interface, shared with the outside mesh) goes to its projection on the zero set
// of `surface` (project_to_surface), or half or a quarter of the way, the first of the three at
// which every hex it is a corner of, in either mesh, is Bernstein-certified, has a scaled
// Jacobian at least min(the one it had, limits.floor) and an edge ratio at most max(the one it
// had, limits.max_edge_ratio); else it stays. Vertices are taken in colours
// (no two of a colour share a hex), a colour's in parallel: the same result on any number of
// threads. Vertices on a face of the outside mesh's box stay. Moves only points: hexes, their
// corners and the certificates (never lost) are as they were.
inline constexpr double kSnapFloor = 0.2;
struct SnapLimits {
  double floor = kSnapFloor;  // a hex's scaled Jacobian may fall to min(its own, floor)
  // A hex's edge ratio may grow up to max(its own, this); infinity: no limit.
  double max_edge_ratio = std::numeric_limits<double>::infinity();
};
// No hex's scaled Jacobian falls and no edge ratio grows (mesh --repel: quality asked for).
inline constexpr SnapLimits kSnapKeepingQuality{1, 0};
struct SnapStats {
  std::size_t vertices = 0;  // on the boundary
  std::size_t moved = 0;     // to the surface
  std::size_t partly = 0;    // half or a quarter of the way
  std::size_t stayed = 0;    // refused (or already on the surface: no move)
  double seconds = 0;
};
// `held`, where given, marks the boundary points that stay where they are (several regions: those
// near a junction curve, where the cut leaves the shells by design and a projection could land on
// the other shell).
using SnapHeld = std::function<std::vector<uint8_t>(std::span<const Vec3> points)>;
SnapStats snap_boundary(MeshPair& meshes, const SignedDistance& surface, const SnapLimits& limits = {},
                        const SnapHeld& held = {});

// Projects points onto the zero set of `surface` (what optimize uses; public for the tests).
void project_to_surface(const SignedDistance& surface, std::span<Vec3> points);

}  // namespace mchex
