// Built-in analytic solids with closed-form signed distance (f > 0 inside). They are the
// embedded default input and the exact references of the tests: their inside test (f > 0) is
// exact everywhere, and |f| is the exact Euclidean distance to the surface, except for the
// two-holed solid inside its tube junction, where |f| is a lower bound (see shapes.cpp).
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "core/sdf.h"

namespace mchex {

enum class ShapeKind { kSphere, kTorus, kRoundedBox, kTwoHoled };

struct ShapeInfo {
  ShapeKind kind;
  std::string_view name;
  int euler_characteristic;  // of the boundary surface: 2 - 2 * genus
};

const std::vector<ShapeInfo>& shape_catalog();
// Throws InputError listing the known names.
ShapeKind parse_shape(std::string_view name);
std::string_view shape_name(ShapeKind kind);
int shape_euler_characteristic(ShapeKind kind);

class ShapeSdf final : public SignedDistance {
 public:
  explicit ShapeSdf(ShapeKind kind) : kind_(kind) {}
  double operator()(Vec3 p) const;
  void evaluate(std::span<const Vec3> points, std::span<double> values) const override;
  Box bounds() const override;
  ShapeKind kind() const { return kind_; }

 private:
  ShapeKind kind_;
};

// Closed, consistently oriented triangulations of the sphere and the torus at a given
// resolution (segments around the main circle), for tests and benchmarks that need a real
// triangle model with a known answer. Vertices lie exactly on the analytic surface.
TriangleSurface tessellate(ShapeKind kind, int segments);

}  // namespace mchex
