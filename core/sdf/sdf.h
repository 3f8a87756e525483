// Signed distance fields: the mesher's only view of the geometry. Convention: f > 0 inside.
//
// SurfaceSdf is the CPU reference for triangle surfaces: the closest point comes from a
// nearest-first search of a BVH that Embree builds (core/sdf/bvh.h), O(log T) per point against the
// paper's brute-force loop over all triangles, with every candidate measured in double (points
// are searched in Morton order, 32 neighbours sharing one walk of the tree);
// the sign by one of two rules (SignRule):
// - kPseudonormal (SurfaceSdf's default; the pipeline's is kWindingNumber): the angle-weighted pseudonormal of the
// closest feature
//   (Baerentzen & Aanaes 2005). Exact for closed, consistently oriented 2-manifold surfaces. On
//   open surfaces, non-manifold edges, soups or folded spikes it never fails but is only locally
//   meaningful: each point takes the side of the nearest triangle's feature, so the "inside"
//   leaks out through holes and flips where orientations disagree.
// - kWindingNumber: inside where the generalized winding number exceeds 1/2 (Jacobson et al.
//   2013; core/sdf/winding_number.h), decided exactly however it is approximated. The same as
//   the pseudonormal on clean closed surfaces, and robust on the others.
// - kWindingParity: inside where the nearest integer to the winding number is odd. For several
//   closed shells at once (the regions of core/pipeline/regions.h) this is the symmetric
//   difference of their solids, whose boundary is every shell: |f| is the distance to the nearest
//   shell and f changes sign across each of them, whichever way each faces.
// Either way |f| is the exact closest-point distance and a point on the surface gets 0.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "core/base/geometry.h"
#include "core/mesh/surface.h"

namespace mchex {

enum class SignRule { kPseudonormal, kWindingNumber, kWindingParity };
// The rule's name in the command line's --sign and the report: pseudonormal, winding, parity.
constexpr const char* sign_rule_name(SignRule r) {
  return r == SignRule::kPseudonormal ? "pseudonormal" : r == SignRule::kWindingNumber ? "winding" : "parity";
}

class WindingNumber;

class SignedDistance {
 public:
  virtual ~SignedDistance() = default;
  // Batch evaluation: values[i] = f(points[i]); threaded; deterministic. Neighbouring points in
  // the batch evaluate fastest (grid order), but any order is correct.
  virtual void evaluate(std::span<const Vec3> points, std::span<double> values) const = 0;
  // A box that holds the solid (f <= 0 outside it).
  virtual Box bounds() const = 0;
};

// What a SurfaceSdf's search tree is made for (core/sdf/search_tree.h): kRepeated, a surface
// evaluated many times (boxes fitted to the triangles: the fewest nodes opened per search);
// kOneBatchInFours, a surface searched by one batch and dropped whose triangles come in fours that
// belong together (each of the fidelity's boundary quads, split around its centre): one leaf
// each, Embree's Morton builder and axis-aligned boxes (core/sdf/bvh.h BvhBuilder::kMortonFours:
// hierarchy and tree made in a fraction of the time on a 254k-triangle mesh boundary, searched as
// fast). The values are the same either way: the search is exact whatever the tree.
enum class SearchUse { kRepeated, kOneBatchInFours };

class SurfaceSdf final : public SignedDistance {
 public:
  // The surface is kept (a caller done with its own can move it in).
  explicit SurfaceSdf(TriangleSurface surface, SignRule sign = SignRule::kPseudonormal,
                      SearchUse use = SearchUse::kRepeated);
  ~SurfaceSdf() override;
  SurfaceSdf(const SurfaceSdf&) = delete;
  SurfaceSdf& operator=(const SurfaceSdf&) = delete;

  void evaluate(std::span<const Vec3> points, std::span<double> values) const override;
  Box bounds() const override;
  SignRule sign_rule() const;
  // The winding number that decides the sign under kWindingNumber or kWindingParity (sharing
  // this SDF's BVH), else null.
  const WindingNumber* winding() const;
  // The signed distance by the pseudonormal rule whatever this SDF's own rule: exact for a closed,
  // consistently oriented surface and cheaper than the winding number near it (core/pipeline/
  // regions.h labels with it).
  void evaluate_pseudonormal(std::span<const Vec3> points, std::span<double> values) const;
  // Unsigned distance to the triangles (used for Hausdorff distances and by evaluate()).
  void distance(std::span<const Vec3> points, std::span<double> values) const;
  // closest[i] = the point of the triangles nearest to points[i] (the same search as distance();
  // ties go to the lower triangle index, so the answer is deterministic). Threaded. For the mesh
  // optimiser (core/optimize/optimize.h), which keeps boundary vertices on the input surface.
  void closest_points(std::span<const Vec3> points, std::span<Vec3> closest) const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

// The permutation that orders points along a Morton (Z-order) curve over their bounding box
// (21 bits per axis; non-finite coordinates sort anywhere). Nearest-triangle searches run in this
// order, here and on the devices: consecutive points are then neighbours in all three directions,
// so one packet's answers seed the next and successive searches find the tree's nodes in cache.
std::vector<uint32_t> morton_order(std::span<const Vec3> points);

// Reference for the benchmarks and tests: the paper's method, every point against every
// triangle, with the same sign rule. O(points x triangles).
void brute_force_sdf(const TriangleSurface& surface, std::span<const Vec3> points, std::span<double> values);

// Closest point on triangle (a, b, c) to p, and which feature it lies on, so that the caller can
// pick the feature's pseudonormal. Region: 0..2 vertex a/b/c, 3 edge ab, 4 edge bc, 5 edge ca,
// 6 interior.
struct ClosestPoint {
  Vec3 point;
  double squared_distance;
  int region;
};
ClosestPoint closest_point_on_triangle(Vec3 p, Vec3 a, Vec3 b, Vec3 c);

}  // namespace mchex
