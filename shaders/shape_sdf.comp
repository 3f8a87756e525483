#version 450
// Signed distance (f > 0 inside) of a built-in analytic shape (core/shapes.h ShapeKind) at a batch
// of points: a thin wrapper around kernels/sdf.h shape_sdf (dimensions from the generated tables).
#extension GL_GOOGLE_include_directive : require
#include "mchex_tables.glsl.h"
#include "kernels/dialect.h"
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Points { double points[]; };  // x, y, z per point
layout(std430, binding = 1) writeonly buffer Values { double values[]; };
layout(push_constant) uniform Push { uint n; int kind; } pc;
// kernels/sdf.h also holds the surface SDF, whose functions name the scene buffers; they are
// declared here so it compiles, and never used (nor bound) by this shader.
layout(std430, binding = 2) readonly buffer Nodes { BvhNode nodes[]; };
layout(std430, binding = 3) readonly buffer SlotTriangle { uint slot_triangle[]; };
layout(std430, binding = 4) readonly buffer SlotCorners { double slot_corners[]; };
layout(std430, binding = 5) readonly buffer SlotFeatures { uint slot_features[]; };
layout(std430, binding = 6) readonly buffer FaceNormals { double face_normals[]; };
layout(std430, binding = 7) readonly buffer EdgeNormals { double edge_normals[]; };
layout(std430, binding = 8) readonly buffer VertexNormals { double vertex_normals[]; };

#include "kernels/sdf.h"

void main() {
  const uint i = gl_GlobalInvocationID.x;
  if (i >= pc.n) return;
  values[i] = shape_sdf(pc.kind, dvec3(points[3u * i], points[3u * i + 1u], points[3u * i + 2u]));
}
