// The sharp features of a triangle surface: the curves along which the surface folds, the corners
// where they end or meet, and the nearest point on them. The mesh optimiser (core/optimize/
// optimize.h) keeps the boundary vertices that represent a feature on its curve, and fixes only
// those at a corner; everywhere else a boundary vertex slides freely on the surface.
//
// Why from the input: the boundary quads of a coarse hex mesh fold wherever a thin part (an ear,
// a fin) is a cell or two thick, on a model that has no sharp edge; only the input's own
// dihedral angles say where a fold belongs to the shape (docs/optimize.md, "Features").
//
// An edge is sharp when the normals of its two triangles differ by more than `angle` degrees
// (the pair oriented alike: one that runs the edge the same way has one normal turned round), or
// when it does not have exactly two triangles (the rim of a hole, a non-manifold edge). A
// triangle with a repeated vertex index or zero area has no normal, and an edge it shares is
// not sharp. A curve is a maximal chain of sharp edges through vertices with exactly two sharp
// edges. A vertex with three or more (where curves meet) is a corner; one with a single sharp edge
// (a crease that fades out) only ends its curve: a point sliding along the curve stops there
// anyway, whereas a corner must keep a mesh vertex on it. A closed loop is one curve.
// Everything depends only on the surface: edges, curves and search answers are the same on any
// number of threads.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/base/geometry.h"
#include "core/mesh/surface.h"

namespace mchex {

class FeatureCurves {
 public:
  // Curves are numbered 0 .. curves() - 1 and corners after them, curves() .. curves() +
  // corners() - 1: a corner is a curve of one point. In nearest(), kAnyCurve asks for the nearest
  // point on any curve (not a corner), kCorner for the nearest corner.
  static constexpr uint32_t kAnyCurve = std::numeric_limits<uint32_t>::max();
  static constexpr uint32_t kCorner = kAnyCurve - 1;

  FeatureCurves() = default;
  FeatureCurves(const TriangleSurface& surface, double angle_degrees);

  bool empty() const { return segments_.empty(); }
  std::size_t sharp_edges() const { return segments_.size() - corners_; }
  std::size_t corners() const { return corners_; }
  std::size_t curves() const { return curves_; }
  bool is_corner(uint32_t curve) const { return curve >= curves_ && curve < curves_ + corners_; }

  struct Nearest {
    Vec3 point;
    double squared_distance = std::numeric_limits<double>::infinity();
    uint32_t curve = kAnyCurve;  // the curve or corner it is on; kAnyCurve: nothing found
    Vec3 tangent;                // unit direction of the sharp edge the point is on (0 at a corner)
  };
  // The nearest point to p on `curve` (a curve's or a corner's number, or kAnyCurve, kCorner)
  // within `radius`; ties go to the lower edge, so the answer is deterministic.
  Nearest nearest(Vec3 p, uint32_t curve = kAnyCurve, double radius = std::numeric_limits<double>::infinity()) const;

 private:
  // Sharp edges, then the corners as segments of length zero; curve_[i] is the number of each.
  std::vector<std::array<Vec3, 2>> segments_;
  std::vector<uint32_t> curve_;
  std::size_t corners_ = 0, curves_ = 0;
  // A bounding volume hierarchy over the segments: node n covers segments order_[first, first +
  // count) when it is a leaf (count > 0), else its children are n + 1 and `second`.
  struct Node {
    Box box;
    uint32_t first = 0, count = 0, second = 0;
  };
  std::vector<Node> nodes_;
  std::vector<uint32_t> order_;
  uint32_t build(uint32_t first, uint32_t count);
};

}  // namespace mchex
