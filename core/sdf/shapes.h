// Built-in analytic solids with closed-form signed distance (f > 0 inside). They are the
// embedded default input and the exact references of the tests: their inside test (f > 0) is
// exact everywhere, and |f| is the exact Euclidean distance to the surface, except for the
// two-holed solid inside its tube junction, where |f| is a lower bound (see shapes.cpp).
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "core/sdf/sdf.h"

namespace mchex {

// Dimensions, chosen so that every shape fits in [-1.5, 1.5]^3 and its thinnest part spans a
// few cells of a depth-3 grid over its padded box. Public so that the device kernels' generated
// tables (host/backends/gen_device_tables.cpp) take them from here.
namespace shape_dimensions {
inline constexpr double kSphereRadius = 1.0;
inline constexpr double kTorusMajor = 1.0, kTorusMinor = 0.4;
inline constexpr Vec3 kBoxHalf{1.0, 0.75, 0.5};
inline constexpr double kBoxRounding = 0.2;
// Two-holed solid: a tube of radius kEightTube around a figure eight made of two circles of
// radius kEightRing in the plane z = 0, touching at the origin. Its core curve is a wedge of two
// circles (first Betti number 2), so its boundary has genus 2.
inline constexpr double kEightRing = 0.6, kEightTube = 0.25;
}  // namespace shape_dimensions

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
