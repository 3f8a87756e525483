// Several solids in one conforming, region-labelled hex mesh (the multi-region meshing of Awad et
// al. 2016, reached through MCHex's own cutting): a reduction to one binary MCHex run.
//
// The reduction. Take every region's closed shell together as one surface and sign its distance
// field by the parity of the winding number (core/sdf/sdf.h SignRule::kWindingParity). Crossing any one shell changes
// the winding number by one, whichever way the shell faces, so the parity field changes sign across every shell and
// nowhere else: its zero set is the union of the shells, and each cell of their arrangement (a region, an overlap, the
// box outside) lies wholly on one side. MCHex cuts the grid by that field exactly as it cuts one solid, so the two
// meshes it makes, the odd and the even cells of the arrangement, conform face for face along every shell
// (core/cutting/mchex_mesher.h); with one region the parity field is the solid's own field and nothing changes.
// Touching regions are the exception: a face two shells share is crossed twice, the parity does not change across it,
// so the combined surface drops both copies (the union's boundary stays) and the labels alone tell the two regions
// apart there: they meet along grid faces, which are the shared face only where it lies on a grid plane
// (docs/regions.md).
//
// The labels. Every hex then takes the arrangement cell its polyhedron's grid corner (or, when
// that corner is a crossing, its centroid) lies in: the sign of each
// region's own field there (its winding number under the default sign rule), one bit per region.
// Where that point lies between the mesh's piecewise-trilinear interface and the true shell, its
// bits disagree with the side MCHex put it on (an odd count on the even side or the
// reverse); the bit of the shell nearest to the point is then flipped, since that is the shell
// the interface approximates there. The region is the first one in priority order whose bit is
// set (0: none, the box outside). So a region's hexes meet another's only across the interface
// (face for face), except within a cell of a junction curve where two shells cross and four
// cells of the arrangement meet: there the parity field has a saddle, lifted by JunctionLift
// (below) so that Marching Cubes opens it a cell wide, and the labels follow the grid corners.
// Cutting junction cells by the facets, which keeps such curves sharp, is the job of Awad's own
// method (not part of this reduction).
//
// Priority (what an overlap belongs to): by default the region of smaller enclosed volume first,
// so a nested solid keeps its own label and its container becomes the shell around it, and an
// inclusion that overlaps its matrix keeps the overlap; `order` (the command line's
// --region-order) lists the regions' 1-based input positions, highest priority first, instead.
// Labels are input positions: hexes of the i-th input carry region i, the box outside k + 1 (so
// one region keeps the single-solid labels 1 and 2).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/base/stage_clock.h"
#include "core/mesh/hex_mesh.h"
#include "core/mesh/surface.h"
#include "core/pipeline/solid.h"

namespace mchex {

using Segment = std::array<Vec3, 2>;

class RegionSet {
 public:
  // Loads every source as its own Solid (read, repair, BVH; options as for one solid), checks
  // `order` (a permutation of 1..k, or empty), and builds the combined surface. InputError for
  // fewer than two sources, a shape among them, a bad order or a region with no volume.
  RegionSet(std::span<const SolidSource> sources, StageClock& clock, bool quiet, const SolidOptions& options,
            std::span<const int> order);
  RegionSet(const RegionSet&) = delete;
  RegionSet& operator=(const RegionSet&) = delete;

  std::size_t size() const { return solids_.size(); }
  const Solid& region(std::size_t i) const { return *solids_[i]; }  // input order
  // Input positions (0-based), highest priority first.
  const std::vector<int>& priority() const { return priority_; }
  // Every shell, vertices welded across shells, the faces two regions share dropped (both copies).
  const TriangleSurface& combined() const { return combined_; }
  std::size_t shared_faces() const { return shared_faces_; }
  // "a.stl + b.stl + ..."
  std::string name() const;
  // The volume each region's shell encloses (its solid alone, before priority), input order.
  const std::vector<double>& enclosed_volumes() const { return enclosed_; }
  // The junction curves: where two shells cross, as the segments along which their triangles
  // cross (shells that only touch, sharing faces or edges in one plane, have none there).
  const std::vector<Segment>& junctions() const { return junctions_; }

 private:
  std::vector<std::unique_ptr<Solid>> solids_;
  std::vector<int> priority_;
  std::vector<double> enclosed_;
  TriangleSurface combined_;
  std::size_t shared_faces_ = 0;
  std::vector<Segment> junctions_;
};

// The segments where two triangle surfaces cross: every pair of triangles, one of each, whose
// corners lie strictly on both sides of the other's plane gives the segment they share (pairs that
// only touch, or lie in one plane, give none). Deterministic (a's triangle order, then b's).
std::vector<Segment> crossing_segments(const TriangleSurface& a, const TriangleSurface& b);

// The lift around the junction curves that MCHex's junction cells need (docs/regions.md,
// "Junction curves"). Where two shells cross, four cells of their arrangement meet along the curve
// in alternating parity: the parity field has a saddle there, Marching Cubes joins two opposite
// cells through a neck as thin as the grid values happen to make it, and that neck's polyhedra
// are the mesh's worst hexes (min scaled Jacobian 0.0009-0.004 on two overlapping spheres at
// depths 2-4 with --repel, where every hex away from the curve is above 0.18). Adding
// radius - d to the field within the radius of the curve (d the distance to it: a cone one radius
// high) moves the saddle's zero off the curve: the field is the radius on it, the two odd cells
// join across it through a neck about a radius wide, and the two even cells end short of it, their
// tips cut at about 45 degrees to the shells. Taking max(field, radius - d) instead, a round tube
// on the odd side, cuts the tips square and was measured worse (docs/regions.md). The labels give
// the neck's hexes to the region of the nearer shell (label_regions' flip), so each region's
// boundary moves by less than the radius, and only within it of the curve.
// The lift's radius in cells of the grid (an adaptive grid's cell where the curve lies): measured
// best among 0.5-3 cells on two overlapping spheres at depths 3 and 4 (docs/regions.md).
inline constexpr double kJunctionLiftRadius = 1.0;
// The fitted grid's rounds leave alone the samples within this many lift radii of a junction
// curve, where the lifted mesh lies off the shells by design.
inline constexpr double kJunctionFitMargin = 1.5;

class JunctionLift {
 public:
  // radii: one per segment (the grid's cell size where it lies), each positive.
  JunctionLift(std::span<const Segment> curves, std::vector<double> radii);
  // values[i] += the largest radius(s) - d(points[i], s) over the segments s nearer to the point
  // than their radius; returns how many values changed. `values` must be the parity field at
  // `points` (its size bounds the search). Threaded, deterministic.
  std::size_t lift(std::span<const Vec3> points, std::span<double> values) const;
  // Whether each point lies nearer than `factor` times a segment's radius to it: where the lifted
  // field's zero set leaves the shells (at most a radius from the curve), with a margin.
  std::vector<std::uint8_t> near(std::span<const Vec3> points, double factor) const;
  double min_radius() const { return min_radius_; }
  double max_radius() const { return max_radius_; }

 private:
  std::span<const Segment> curves_;
  std::vector<double> radii_;
  double min_radius_ = 0, max_radius_ = 0;
  double cell_ = 0;                                                      // the grid's cell edge
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> cells_;  // cell -> segments in it
  // f(segment, squared distance to p) for every segment in the cells that the box of half-edge
  // `reach` around p covers (those within `reach` among them; others may come too).
  template <class F>
  void for_segments_within(Vec3 p, double reach, F&& f) const;
};

// What labelling found, for the report (core/pipeline/report.h).
struct RegionStats {
  struct Region {
    std::string name;
    std::size_t hexes = 0;
    double volume = 0;           // of its hexes (exact trilinear volumes)
    double enclosed_volume = 0;  // of its shell alone
  };
  std::vector<Region> regions;  // input order
  std::vector<int> priority;    // 1-based input positions, highest first
  std::size_t outside_hexes = 0;
  std::size_t shared_faces = 0;
  std::size_t junction_segments = 0;  // RegionSet::junctions
  double lift_min_radius = 0;         // JunctionLift's radii (0: no lift)
  double lift_max_radius = 0;
  std::size_t flipped = 0;  // hexes whose centroid's bits disagreed with their side (one bit flipped)
};

// The region-labelled meshes from MCHex's (or RO's) two meshes of the parity field: inside holds
// every hex of a region (labels 1..k), outside the box's (label k + 1); points shared by the two
// parity meshes (bit-identical, being the same named points) are merged. Deterministic.
// grid_points: the points of the grid the two meshes were cut from (their grid points are these,
// bit for bit).
MeshPair label_regions(const MeshPair& parity, std::span<const Vec3> grid_points, const RegionSet& regions,
                       RegionStats* stats);

// One surface's shells as surfaces of their own, for one file that holds several regions (mesh
// --shells-as-regions): the components of triangles connected through manifold edges (edges of
// exactly two triangles), in the order of their first triangle in the file, each with only its
// own vertices. Shells that touch along an edge or at a vertex stay apart; shells that share a
// face do not split this way (the face's edges are in four triangles, which cuts it off both
// shells and leaves them open): such regions are given as files of their own.
std::vector<TriangleSurface> split_shells(const TriangleSurface& surface);

}  // namespace mchex
