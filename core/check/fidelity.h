// How well the inside mesh fits the input solid (the paper's section 6 measures):
//  - IoU: volume of (mesh AND solid) over volume of (mesh OR solid), counted on a lattice of
//    cell-centred samples over the mesh box; a sample is in the mesh when it lies in some hex
//    (inverse trilinear map), in the solid when the reference SDF is positive there.
//  - two-sided Hausdorff distance between the mesh boundary (the quads of the inside mesh that
//    belong to one hex) and the input surface, both sampled at a spacing, divided by the input's
//    bounding-box diagonal (the paper's HR). Sampling makes it a lower bound of the true value,
//    tight to about the spacing.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "core/mesh/hex_mesh.h"
#include "core/sdf/sdf.h"

namespace mchex {

struct Fidelity {
  double iou = 0;
  double mesh_volume = 0, solid_volume = 0;  // lattice estimates
  double mesh_to_surface = 0;                // max over mesh-boundary samples
  double surface_to_mesh = 0;                // max over input-surface samples
  double hausdorff = 0;
  double hausdorff_ratio = 0;  // hausdorff / input bounding-box diagonal
  std::size_t lattice = 0;     // samples per axis
  std::size_t unresolved = 0;  // samples no hex contains where a hex's inverse map did not converge
  // With far_tolerance > 0: the samples of either side farther than it from the other side
  // (mesh-boundary samples first, then input-surface samples), where a finer grid is wanted.
  std::vector<Vec3> far_points;
  // With far_tolerance > 0: the IoU lattice samples where mesh and solid disagree.
  std::vector<Vec3> misclassified_points;
};

// Points on the reference surface at about the given spacing.
std::vector<Vec3> sample_surface(const TriangleSurface& surface, double spacing);
// The same from an SDF whose |f| is 1-Lipschitz (every SDF here: exact distances, or the
// two-holed solid's tube radius less a minimum of distances): the box's lattice points within a
// spacing of the surface, pulled onto it.
std::vector<Vec3> sample_surface(const SignedDistance& solid, const Box& box, double spacing);

// The unsigned distance to the input surface at each point (what |f| of the solid's SDF gives,
// without its sign: under the winding-number rule the sign is most of an evaluation's cost).
using SurfaceDistance = std::function<void(std::span<const Vec3> points, std::span<double> distances)>;

// The input's side of the measures, the same for every mesh measured against one solid on one
// lattice: the fitted grid's rounds measure several meshes of a run against it, so it is made once.
struct FidelityReference {
  std::vector<Vec3> surface_samples;  // on the input surface, about `spacing` apart
  Box lattice_box;
  std::size_t lattice = 0;  // samples per axis
  double spacing = 0;       // of the surface samples and the mesh-boundary samples
  // The solid's SDF at the lattice's cell-centred samples (x fastest), or at least its sign (the
  // IoU reads only the sign).
  std::vector<double> lattice_values;
};

// distance_bounds_sign: |f| is at most the distance to any point where f changes sign (a closed,
// consistently oriented surface, whose winding number changes only across it; an analytic
// shape), so the IoU lattice evaluates the SDF only in blocks near the surface; the signs are
// the same (an open surface's winding-number sign can change away from it: leave it false).
FidelityReference fidelity_reference(const SignedDistance& solid, std::vector<Vec3> surface_samples,
                                     const Box& lattice_box, std::size_t lattice, double spacing,
                                     bool distance_bounds_sign = false);

// The distance from each point to the boundary of `inside` (its quads that belong to one hex),
// each quad stood in for by four triangles through its bilinear centre: the Hausdorff distance's
// input side. Searched at most chunk_quads quads at a time (their search tree, not the whole
// boundary's, is what the measure holds); the answers are the same bit for bit at any chunk size.
constexpr std::size_t kBoundaryChunkQuads = std::size_t(1) << 15;
// The Hausdorff distance's mesh side measures its samples this many at a time (measure_fidelity).
constexpr std::size_t kMeshSampleBlock = std::size_t(1) << 16;
std::vector<double> distance_to_boundary(const HexMesh& inside, std::span<const Vec3> points,
                                         std::size_t chunk_quads = kBoundaryChunkQuads);
// `distance` (optional) measures the mesh side of the Hausdorff distance; |solid| when empty.
Fidelity measure_fidelity(const HexMesh& inside, const SignedDistance& solid, const FidelityReference& reference,
                          const SurfaceDistance& distance = {}, double far_tolerance = 0);
// The same with the reference made for this one measure.
Fidelity measure_fidelity(const HexMesh& inside, const SignedDistance& solid, std::span<const Vec3> surface_samples,
                          const Box& lattice_box, std::size_t lattice, double spacing,
                          const SurfaceDistance& distance = {}, bool distance_bounds_sign = false,
                          double far_tolerance = 0);

}  // namespace mchex
