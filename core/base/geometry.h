// Small double-precision vector and box types shared by every stage of the pipeline.
// Plain aggregates so that arrays of them are flat (structure-of-arrays friendly, memcpy-able).
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

namespace mchex {

struct Vec3 {
  double x = 0, y = 0, z = 0;

  constexpr double& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  constexpr double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  friend constexpr bool operator==(const Vec3&, const Vec3&) = default;
};

constexpr Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
constexpr Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
constexpr Vec3 operator-(Vec3 a) { return {-a.x, -a.y, -a.z}; }
constexpr Vec3 operator*(double s, Vec3 a) { return {s * a.x, s * a.y, s * a.z}; }
constexpr Vec3 operator*(Vec3 a, double s) { return s * a; }
constexpr Vec3 operator/(Vec3 a, double s) { return {a.x / s, a.y / s, a.z / s}; }
constexpr Vec3& operator+=(Vec3& a, Vec3 b) { return a = a + b; }
constexpr Vec3& operator-=(Vec3& a, Vec3 b) { return a = a - b; }
constexpr double dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
constexpr Vec3 cross(Vec3 a, Vec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
constexpr double squared_norm(Vec3 a) { return dot(a, a); }
inline double norm(Vec3 a) { return std::sqrt(dot(a, a)); }
inline Vec3 normalized(Vec3 a) {
  const double n = norm(a);
  return n > 0 ? a / n : Vec3{};
}
// Signed volume of the parallelepiped spanned by a, b, c (the paper's omega, Theorem 5.2).
constexpr double triple(Vec3 a, Vec3 b, Vec3 c) { return dot(a, cross(b, c)); }
inline bool is_finite(Vec3 a) { return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z); }
// The point of segment ab nearest to p (a when the segment has no length).
constexpr Vec3 closest_on_segment(Vec3 p, Vec3 a, Vec3 b) {
  const Vec3 d = b - a;
  const double l2 = dot(d, d);
  const double t = l2 > 0 ? std::clamp(dot(p - a, d) / l2, 0.0, 1.0) : 0.0;
  return a + t * d;
}

// a + s (b - a) for s in [0, 1], exact at both ends (s = 0 gives a, s = 1 gives b) and where
// a == b. The plain a + s (b - a) can miss b by an ulp at s = 1: a subdivision point on the face of
// a cell that lies in a face of the box would leave the box's plane when the cell's other corners
// are moved (repel), and the boundary would no longer close on the box.
constexpr double exact_lerp(double a, double b, double s) { return s < 0.5 ? a + s * (b - a) : b - (1 - s) * (b - a); }

// Two doubles in one SSE2 register (a GCC and Clang vector extension; elsewhere two scalars). Each
// operation is the IEEE operation on each lane, so a lane holds what the scalar code computes: for
// the few loops that run billions of times (certify) and that the compiler does not vectorize.
using Double2 = double __attribute__((vector_size(16)));

struct Box {
  Vec3 lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
          std::numeric_limits<double>::infinity()};
  Vec3 hi{-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
          -std::numeric_limits<double>::infinity()};

  void extend(Vec3 p) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  bool empty() const { return !(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z); }
  Vec3 size() const { return hi - lo; }
  Vec3 center() const { return 0.5 * (lo + hi); }
  double diagonal() const { return norm(hi - lo); }
  double volume() const {
    const Vec3 s = size();
    return s.x * s.y * s.z;
  }
  bool contains(Vec3 p) const {
    return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z;
  }
};

// The squared distance from p to the closed box b (0 inside it).
inline double squared_distance_to_box(Vec3 p, const Box& b) {
  double d = 0;
  for (int a = 0; a < 3; ++a) {
    const double e = std::max({b.lo[a] - p[a], 0.0, p[a] - b.hi[a]});
    d += e * e;
  }
  return d;
}

// x, then y, then z: an order to sort and search sets of points by, not a geometric one.
constexpr bool lexicographic_less(Vec3 a, Vec3 b) {
  return a.x != b.x ? a.x < b.x : a.y != b.y ? a.y < b.y : a.z < b.z;
}

}  // namespace mchex
