// Validator for the mesher's output: one hex mesh, or an inside/outside pair that must tile a
// box (docs/pipeline.md: two conforming meshes sharing one quad surface, positive Jacobian).
//
// What is checked, and what counts as an error (MeshCheck::ok is false when any is found):
//  - each mesh alone: finite points; every hex has 8 distinct in-range indices; no inverted or
//    degenerate hex (det J <= 0 at a corner); one region label per hex; every quad face is in
//    one or two hexes, a face in two hexes has opposite orientations there (outward normals by
//    VTK face order) and the same cyclic vertex order (else the two quads differ).
//  - the pair: vertices of the two meshes are matched by exact coordinates; in the union no
//    face is in more than two hexes (overlap); every face in one hex of the union lies on one
//    side plane of the box (else a gap), which makes the inside boundary off the box equal to
//    the outside boundary face for face; interface faces are oppositely oriented; the two
//    volumes add up to the box volume.
// What is only reported: quality (scaled Jacobian, Bernstein certificate and bound, edge ratio,
// dihedral angles, inverse condition number; docs/quality.md), for the mesh and per region
// label, with histograms of the scaled Jacobian and the Bernstein bound; and the shape of each
// mesh's boundary surface (closed 2-manifold? Euler characteristic,
// components). Meshes from the RO method, for instance, may touch themselves along an edge.
//
// Faces are matched by sorting, not hashing: face references are bucketed by their smallest
// vertex id (a counting sort, 4 bytes per face) and each small bucket is sorted by the other
// three ids, in parallel with TBB. Memory is O(faces + vertices); results are deterministic.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>
#include <nlohmann/json.hpp>

#include "core/base/geometry.h"
#include "core/mesh/hex_mesh.h"

namespace mchex {

struct CheckOptions {
  std::size_t max_messages = 20;   // error messages kept, the first in element/face order
  double volume_tolerance = 1e-9;  // |V_inside + V_outside - V_box| <= this * V_box
  // The mesh writers always give one label per hex; a mesh read from a format without labels
  // has none, which callers accept by setting this to false (a wrong non-zero size stays an
  // error either way).
  bool require_regions = true;
  // Keep each hex's scaled Jacobian (MeshStats::scaled_jacobians): the .vtu writer's cell field,
  // which it would otherwise compute again (8 bytes per hex while the meshes are written).
  bool keep_scaled_jacobians = false;
};

// Counts of one per-hex measure in fixed bins, the same for every mesh so that histograms of
// two meshes or two runs compare bin for bin. Bin i holds kEdges[i] <= v < kEdges[i + 1], the
// last bin [0.9, 1] closed; `below` counts v < -1 (and NaN), `above` v > 1. The scaled
// Jacobian lies in [-1, 1]; the Bernstein bound min beta / h^3 can lie outside.
struct Histogram {
  static constexpr int kBins = 11;
  static constexpr std::array<double, kBins + 1> kEdges = {-1, 0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1};
  std::array<std::size_t, kBins> counts{};
  std::size_t below = 0;
  std::size_t above = 0;
  void add(double v);
  void join(const Histogram& other);
  std::size_t total() const;
};

// Quality over a set of hexes (HexQuality per hex, core/mesh/quality.h); min and max over the
// hexes of each per-hex value, the angles in degrees.
struct QualityStats {
  std::size_t count = 0;  // hexes measured: those with valid indices and finite corners
  double min_scaled_jacobian = std::numeric_limits<double>::infinity();
  double max_scaled_jacobian = -std::numeric_limits<double>::infinity();
  double mean_scaled_jacobian = 0;
  std::size_t certified = 0;                                              // all 27 Bernstein coefficients of det J > 0
  double min_bernstein_scaled = std::numeric_limits<double>::infinity();  // min beta / h^3
  double min_edge_ratio = std::numeric_limits<double>::infinity();
  double max_edge_ratio = 0;
  double min_dihedral_angle = std::numeric_limits<double>::infinity();
  double max_dihedral_angle = -std::numeric_limits<double>::infinity();
  double min_inverse_condition = std::numeric_limits<double>::infinity();
  double max_inverse_condition = -std::numeric_limits<double>::infinity();
  double volume = 0;                     // sum of exact trilinear volumes
  Histogram scaled_jacobian_histogram;   // of each hex's min over the 9 points
  Histogram bernstein_scaled_histogram;  // of each hex's min beta / h^3
};

// The quality of the hexes with one region label.
struct RegionQuality {
  int32_t region = 0;
  QualityStats quality;
};

// The boundary surface of one mesh: the faces that are in exactly one of its hexes.
struct BoundaryStats {
  std::size_t quads = 0;
  std::size_t edges = 0;
  std::size_t vertices = 0;
  std::size_t bad_edges = 0;              // edges not in exactly two boundary quads
  std::size_t misoriented_edges = 0;      // edges in two quads that run it the same way
  std::size_t bad_vertices = 0;           // vertices whose quad fan is not a single cycle
  std::int64_t euler_characteristic = 0;  // V - E + F
  std::size_t components = 0;             // connected through shared vertices
  bool closed_manifold() const { return bad_edges == 0 && bad_vertices == 0; }
};

struct MeshStats {
  std::size_t points = 0;
  std::size_t hexes = 0;
  // Errors.
  std::size_t nonfinite_points = 0;
  std::size_t bad_index_hexes = 0;        // an index >= points.size()
  std::size_t repeated_vertex_hexes = 0;  // the same index twice in one hex
  std::size_t inverted_hexes = 0;         // det J <= 0 at some corner
  bool region_size_ok = true;
  std::size_t nonmanifold_faces = 0;   // faces in more than two hexes
  std::size_t orientation_errors = 0;  // faces in two hexes with the same orientation
  std::size_t cyclic_mismatches = 0;   // same 4 vertices, different cyclic order
  // Counts.
  std::size_t faces = 0;  // distinct vertex sets of quad faces
  std::size_t interior_faces = 0;
  std::size_t boundary_faces = 0;
  QualityStats quality;
  // Per region label, ascending; empty when the mesh has no labels (or not one per hex), and when
  // it has more than kMaxRegions distinct labels (then too_many_regions).
  static constexpr std::size_t kMaxRegions = 256;
  std::vector<RegionQuality> regions;
  bool too_many_regions = false;
  BoundaryStats boundary;
  // With CheckOptions::keep_scaled_jacobians: per hex, its scaled Jacobian (HexQuality::
  // scaled_jacobian, the min over the 9 points), NaN for a hex with bad indices or corners.
  std::vector<double> scaled_jacobians;
};

// Checks on the inside/outside pair together.
struct UnionStats {
  Box box;
  bool box_given = false;           // else the bounding box of the hexes' corners
  std::size_t matched_points = 0;   // outside points at the coordinates of an inside point
  std::size_t interface_faces = 0;  // faces in one inside and one outside hex
  // Errors.
  std::size_t overlap_faces = 0;     // faces in more than two hexes, both meshes among them
  std::size_t gap_faces = 0;         // faces in one hex of the union, not on a side of the box
  std::size_t interface_errors = 0;  // interface faces with equal orientation or cyclic order
  double volume = 0;
  double box_volume = 0;
  double volume_relative_error = 0;
  bool volume_ok = true;
};

struct MeshCheck {
  bool ok = true;  // no error of any kind above
  std::size_t error_count = 0;
  MeshStats inside;
  std::optional<MeshStats> outside;
  std::optional<UnionStats> combined;  // present with an outside mesh
  std::vector<std::string> errors;     // the first CheckOptions::max_messages
};

// `outside` may be null (one mesh alone). `box` is the domain the pair must tile; when null,
// the bounding box of the hexes' corners. Without an outside mesh the box is not used.
// Never throws for bad mesh content; throws ResourceError when a mesh has more than
// 2^32 / 6 hexes (face references are 32-bit).
MeshCheck check_mesh(const HexMesh& inside, const HexMesh* outside, const Box* box, const CheckOptions& options = {});

// The quads that belong to exactly one hex, each as its hex lists it (outward), sorted. The
// mesh's indices must be in range (as check_mesh or the mesh reader ensure).
std::vector<std::array<uint32_t, 4>> boundary_quads(const HexMesh& mesh);

nlohmann::json to_json(const Histogram& h);
nlohmann::json to_json(const QualityStats& q);
nlohmann::json to_json(const BoundaryStats& b);
nlohmann::json to_json(const MeshStats& m);
nlohmann::json to_json(const UnionStats& u);
nlohmann::json to_json(const MeshCheck& c);

}  // namespace mchex
