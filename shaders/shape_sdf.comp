#version 450
// Signed distance (f > 0 inside) of a built-in analytic shape (core/sdf/shapes.h ShapeKind) at a batch
// of points: a thin wrapper around kernels/sdf.h shape_sdf (dimensions from the generated tables).
#extension GL_GOOGLE_include_directive : require
#include "mchex_tables.glsl.h"
#include "kernels/dialect.h"
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Points { double points[]; };  // x, y, z per point
layout(std430, binding = 1) writeonly buffer Values { double values[]; };
layout(push_constant) uniform Push { uint n; int kind; } pc;
#define MCHEX_SHAPES_ONLY  // kernels/sdf.h without the surface SDF (and its buffers)
#include "kernels/sdf.h"

void main() {
  const uint i = gl_GlobalInvocationID.x;
  if (i >= pc.n) return;
  values[i] = shape_sdf(pc.kind, dvec3(points[3u * i], points[3u * i + 1u], points[3u * i + 2u]));
}
