#include "core/sdf/shapes.h"

#include <cmath>
#include <numbers>

#include "core/base/error.h"
#include "core/base/parallel.h"

namespace mchex {
namespace {

using namespace shape_dimensions;

// sqrt(a^2 + b^2) with exactly these roundings, not std::hypot: the OpenCL and Vulkan kernels
// (kernels/sdf.h) reproduce the shapes bit for bit, and hypot's last bit is libm's choice (C and
// OpenCL allow it several ulps), while *, + and sqrt are correctly rounded everywhere. Shape
// coordinates are O(1), so hypot's guard against overflow is not needed.
double planar_norm(double a, double b) { return std::sqrt(a * a + b * b); }

double circle_distance(Vec3 p, double cx, double radius) {
  const double r = planar_norm(p.x - cx, p.y) - radius;
  return planar_norm(r, p.z);
}

}  // namespace

const std::vector<ShapeInfo>& shape_catalog() {
  static const std::vector<ShapeInfo> catalog = {
      {ShapeKind::kSphere, "sphere", 2},
      {ShapeKind::kTorus, "torus", 0},
      {ShapeKind::kRoundedBox, "rounded-box", 2},
      {ShapeKind::kTwoHoled, "two-holed", -2},
  };
  return catalog;
}

ShapeKind parse_shape(std::string_view name) {
  std::string known;
  for (const auto& s : shape_catalog()) {
    if (s.name == name) return s.kind;
    known += (known.empty() ? "" : ", ") + std::string(s.name);
  }
  throw InputError("unknown shape '" + std::string(name) + "' (known: " + known + ")");
}

std::string_view shape_name(ShapeKind kind) {
  for (const auto& s : shape_catalog())
    if (s.kind == kind) return s.name;
  return "?";
}

int shape_euler_characteristic(ShapeKind kind) {
  for (const auto& s : shape_catalog())
    if (s.kind == kind) return s.euler_characteristic;
  return 0;
}

double ShapeSdf::operator()(Vec3 p) const {
  switch (kind_) {
    case ShapeKind::kSphere: return kSphereRadius - norm(p);
    case ShapeKind::kTorus: return kTorusMinor - planar_norm(planar_norm(p.x, p.y) - kTorusMajor, p.z);
    case ShapeKind::kRoundedBox: {
      // Distance to the inner box shrunk by the rounding radius, minus that radius: exact for a
      // box whose edges and corners are rounded with it.
      const Vec3 q{std::abs(p.x) - (kBoxHalf.x - kBoxRounding), std::abs(p.y) - (kBoxHalf.y - kBoxRounding),
                   std::abs(p.z) - (kBoxHalf.z - kBoxRounding)};
      const Vec3 out{std::max(q.x, 0.0), std::max(q.y, 0.0), std::max(q.z, 0.0)};
      const double inner = std::min(std::max({q.x, q.y, q.z}), 0.0);
      return -(norm(out) + inner - kBoxRounding);
    }
    case ShapeKind::kTwoHoled: {
      // Outside the tube, r - dist(p, curve) is exactly minus the distance to the tube surface.
      // Inside, it is exact wherever the nearest curve point is unique and non-junction; near the
      // junction at the origin it underestimates the depth (a lower bound), never the sign.
      const double d =
          std::min(circle_distance(p, -kEightRing, kEightRing), circle_distance(p, kEightRing, kEightRing));
      return kEightTube - d;
    }
  }
  return 0;
}

void ShapeSdf::evaluate(std::span<const Vec3> points, std::span<double> values) const {
  parallel_for(points.size(), [&](std::size_t i) { values[i] = (*this)(points[i]); });
}

Box ShapeSdf::bounds() const {
  switch (kind_) {
    case ShapeKind::kSphere:
      return {{-kSphereRadius, -kSphereRadius, -kSphereRadius}, {kSphereRadius, kSphereRadius, kSphereRadius}};
    case ShapeKind::kTorus: {
      const double r = kTorusMajor + kTorusMinor;
      return {{-r, -r, -kTorusMinor}, {r, r, kTorusMinor}};
    }
    case ShapeKind::kRoundedBox: return {-1.0 * kBoxHalf, kBoxHalf};
    case ShapeKind::kTwoHoled: {
      const double x = 2 * kEightRing + kEightTube, y = kEightRing + kEightTube;
      return {{-x, -y, -kEightTube}, {x, y, kEightTube}};
    }
  }
  return {};
}

TriangleSurface tessellate(ShapeKind kind, int segments) {
  if (kind != ShapeKind::kSphere && kind != ShapeKind::kTorus)
    throw InputError("tessellate: only sphere and torus have a parametric tessellation");
  if (segments < 3) throw InputError("tessellate: need at least 3 segments");
  TriangleSurface s;
  const double pi = std::numbers::pi;
  if (kind == ShapeKind::kTorus) {
    // u around the z axis, v around the tube; (u, v) grid closed in both directions.
    const int nu = segments, nv = std::max(3, int(std::lround(segments * kTorusMinor / kTorusMajor)));
    for (int i = 0; i < nu; ++i)
      for (int j = 0; j < nv; ++j) {
        const double u = 2 * pi * i / nu, v = 2 * pi * j / nv;
        const double r = kTorusMajor + kTorusMinor * std::cos(v);
        s.vertices.push_back({r * std::cos(u), r * std::sin(u), kTorusMinor * std::sin(v)});
      }
    auto id = [&](int i, int j) { return uint32_t((i % nu) * nv + (j % nv)); };
    for (int i = 0; i < nu; ++i)
      for (int j = 0; j < nv; ++j) {
        // Counter-clockwise seen from outside: outward normals, positive volume.
        s.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
        s.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
      }
    return s;
  }
  // Sphere: latitude rings between two poles.
  const int nu = segments, nv = std::max(2, segments / 2);
  s.vertices.push_back({0, 0, -kSphereRadius});
  for (int j = 1; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const double v = -pi / 2 + pi * j / nv, u = 2 * pi * i / nu;
      s.vertices.push_back({kSphereRadius * std::cos(v) * std::cos(u), kSphereRadius * std::cos(v) * std::sin(u),
                            kSphereRadius * std::sin(v)});
    }
  s.vertices.push_back({0, 0, kSphereRadius});
  const uint32_t south = 0, north = uint32_t(s.vertices.size() - 1);
  auto ring = [&](int j, int i) { return uint32_t(1 + (j - 1) * nu + (i % nu)); };
  for (int i = 0; i < nu; ++i) s.triangles.push_back({south, ring(1, i + 1), ring(1, i)});
  for (int j = 1; j + 1 < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      s.triangles.push_back({ring(j, i), ring(j, i + 1), ring(j + 1, i + 1)});
      s.triangles.push_back({ring(j, i), ring(j + 1, i + 1), ring(j + 1, i)});
    }
  for (int i = 0; i < nu; ++i) s.triangles.push_back({ring(nv - 1, i), ring(nv - 1, i + 1), north});
  return s;
}

}  // namespace mchex
