#version 450
// Signed distance (f > 0 inside) of the built-in analytic shapes of core/shapes.cpp, one point per
// invocation, rounding as the reference does (shaders/sdf_geometry.glsl). The shape's dimensions
// come from core through the push constants (ShapeKind and its parameters), not from this file.
#extension GL_GOOGLE_include_directive : require
#include "shaders/sdf_geometry.glsl"
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Points { double points[]; };  // x, y, z per point
layout(std430, binding = 1) writeonly buffer Values { double values[]; };
// kind: 0 sphere, 1 torus, 2 rounded box, 3 two-holed (core/shapes.h ShapeKind order)
// a, b, c, d: the kind's parameters in the order host/backend_vulkan.cpp documents.
layout(push_constant) uniform Push { uint n; uint kind; double a, b, c, d; } pc;

double max_like_std(double x, double y) { return x < y ? y : x; }
double min_like_std(double x, double y) { return y < x ? y : x; }

double circle_distance(dvec3 p, double cx, double radius) {
  precise const double px = p.x - cx;
  precise const double r = hypot_like_glibc(px, p.y) - radius;
  return hypot_like_glibc(r, p.z);
}

void main() {
  const uint i = gl_GlobalInvocationID.x;
  if (i >= pc.n) return;
  const dvec3 p = dvec3(points[3u * i], points[3u * i + 1u], points[3u * i + 2u]);
  precise double f = 0.0;
  if (pc.kind == 0u) {  // sphere: a = radius
    f = pc.a - sqrt(dot3(p, p));
  } else if (pc.kind == 1u) {  // torus: a = major radius, b = minor radius
    precise const double ring = hypot_like_glibc(p.x, p.y) - pc.a;
    f = pc.b - hypot_like_glibc(ring, p.z);
  } else if (pc.kind == 2u) {  // rounded box: (a, b, c) = half extents, d = rounding radius
    precise const dvec3 q = dvec3(abs(p.x) - (pc.a - pc.d), abs(p.y) - (pc.b - pc.d),
                                  abs(p.z) - (pc.c - pc.d));
    const dvec3 outside = dvec3(max_like_std(q.x, 0.0), max_like_std(q.y, 0.0), max_like_std(q.z, 0.0));
    // std::max({x, y, z}) keeps the first of equal largest values.
    const double largest = max_like_std(max_like_std(q.x, q.y), q.z);
    const double inner = min_like_std(largest, 0.0);
    f = -(sqrt(dot3(outside, outside)) + inner - pc.d);
  } else {  // two-holed: a = ring radius, b = tube radius
    const double d = min_like_std(circle_distance(p, -pc.a, pc.a), circle_distance(p, pc.a, pc.a));
    f = pc.b - d;
  }
  values[i] = f;
}
