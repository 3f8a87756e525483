#version 450
// Signed distance (f > 0 inside) to a triangle surface at a batch of points: a thin wrapper around
// the shared device logic of kernels/sdf.h (the same source as the OpenCL kernel), over the
// device scene of core/device_scene.h. `per_item` consecutive points per invocation, each search
// seeded by the previous point's answer (the result does not depend on the seed).
#extension GL_GOOGLE_include_directive : require
#include "mchex_tables.glsl.h"
#include "kernels/dialect.h"
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Nodes { BvhNode nodes[]; };
layout(std430, binding = 1) readonly buffer SlotTriangle { uint slot_triangle[]; };
layout(std430, binding = 2) readonly buffer SlotCorners { double slot_corners[]; };
layout(std430, binding = 3) readonly buffer SlotFeatures { uint slot_features[]; };
layout(std430, binding = 4) readonly buffer FaceNormals { double face_normals[]; };
layout(std430, binding = 5) readonly buffer EdgeNormals { double edge_normals[]; };
layout(std430, binding = 6) readonly buffer VertexNormals { double vertex_normals[]; };
layout(std430, binding = 7) readonly buffer Points { double points[]; };  // x, y, z per point
layout(std430, binding = 8) writeonly buffer Values { double values[]; };
layout(push_constant) uniform Push { uint n; uint per_item; double scale; } pc;

#include "kernels/sdf.h"

void main() {
  const uint first = gl_GlobalInvocationID.x * pc.per_item;
  if (first >= pc.n) return;
  const uint last = min(pc.n, first + pc.per_item);
  uint seed = 0u;
  for (uint i = first; i < last; ++i) {
    const dvec3 p = dvec3(points[3u * i], points[3u * i + 1u], points[3u * i + 2u]);
    const SurfaceHit hit = closest_on_surface(p, seed, pc.scale);
    values[i] = signed_value_of(p, hit);
    seed = hit.slot;
  }
}
