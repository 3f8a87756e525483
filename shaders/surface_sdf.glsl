// The body of shaders/surface_sdf.comp (subgroup walk) and shaders/surface_sdf_single*.comp and
// surface_sdf_texel_counted.comp (one walk per invocation): signed distance (f > 0 inside) to a
// triangle surface at a batch of points, a thin wrapper around the shared device logic of
// kernels/sdf.h (the same source as the OpenCL kernel) over the device scene of
// core/device_scene.h. The including shader has set #version and, for the subgroup walk,
// MCHEX_SDF_SUBGROUP and its extensions; MCHEX_TEXEL_SCENE reads the search arrays from texel
// buffers instead of storage buffers.
//
// Each invocation takes `per_item` points in turn, each search seeded by its previous answer (the
// result does not depend on the seed). With the subgroup walk the SUBGROUP is the packet of
// kernels/sdf.h, so at each turn a subgroup of S invocations takes S consecutive points (Morton
// neighbours, the points arrive in Morton order) and its invocations' next turn the next S: the
// group's points are [group * 64 * per_item, + 64 * per_item), invocation i of the group takes
// (i / S) * S * per_item + turn * S + i % S among them. That numbering covers every point once
// whichever invocations a driver puts in a subgroup; only speed depends on S matching.
#extension GL_GOOGLE_include_directive : require
#include "mchex_tables.glsl.h"
#include "kernels/dialect.h"
layout(local_size_x = 64) in;

#ifdef MCHEX_TEXEL_SCENE
// The search arrays as uniform texel buffers (host/backends/vulkan.cpp makes the views: RGBA32F,
// RGBA32UI for the links and for two doubles of the corners, R32UI).
layout(binding = 0) uniform samplerBuffer wide_boxes;
layout(binding = 1) uniform usamplerBuffer wide_links;
layout(binding = 2) uniform samplerBuffer leaf_bounds;
layout(binding = 3) uniform usamplerBuffer leaf_slot;
layout(binding = 4) uniform usamplerBuffer slot_triangle;
layout(binding = 5) uniform usamplerBuffer slot_corners;
layout(binding = 6) uniform usamplerBuffer slot_features;
#define WIDE_BOX(i) texelFetch(wide_boxes, int(i))
#define WIDE_LINKS4(i) texelFetch(wide_links, int(i))
#define LEAF_BOUND(i) texelFetch(leaf_bounds, int(i))
#define LEAF_SLOT(i) texelFetch(leaf_slot, int(i)).x
#define SLOT_TRIANGLE(i) texelFetch(slot_triangle, int(i)).x
#define SLOT_CORNER_PAIRS(k, lo, hi)                  \
  {                                                   \
    uvec4 pair_ = texelFetch(slot_corners, int(k));   \
    lo = packDouble2x32(pair_.xy);                    \
    hi = packDouble2x32(pair_.zw);                    \
  }
#define SLOT_FEATURE(i) texelFetch(slot_features, int(i)).x
#else
layout(std430, binding = 0) readonly buffer WideBoxes { vec4 wide_boxes[]; };
layout(std430, binding = 1) readonly buffer WideLinks { uint wide_links[]; };
layout(std430, binding = 2) readonly buffer LeafBounds { vec4 leaf_bounds[]; };
layout(std430, binding = 3) readonly buffer LeafSlot { uint leaf_slot[]; };
layout(std430, binding = 4) readonly buffer SlotTriangle { uint slot_triangle[]; };
layout(std430, binding = 5) readonly buffer SlotCorners { double slot_corners[]; };
layout(std430, binding = 6) readonly buffer SlotFeatures { uint slot_features[]; };
#endif
layout(std430, binding = 7) readonly buffer FaceNormals { double face_normals[]; };
layout(std430, binding = 8) readonly buffer EdgeNormals { double edge_normals[]; };
layout(std430, binding = 9) readonly buffer VertexNormals { double vertex_normals[]; };
layout(std430, binding = 10) readonly buffer Points { double points[]; };  // x, y, z per point
layout(std430, binding = 11) writeonly buffer Values { double values[]; };
// loop_budget: kernels/sdf.h's loop budget (0: none); a point whose search ran out of it gets NaN,
// which the host replaces with core's value.
layout(push_constant) uniform Push { uint n; uint per_item; uint loop_budget; uint pad; double scale; } pc;

#include "kernels/sdf.h"

void main() {
#ifdef MCHEX_SDF_SUBGROUP
  const uint span = min(gl_SubgroupSize, 64u);
#else
  const uint span = 1u;
#endif
  const uint local = gl_LocalInvocationIndex;
  const uint base = gl_WorkGroupID.x * 64u * pc.per_item + (local / span) * span * pc.per_item + local % span;
  SurfacePacket q;
  q.seed[0] = 0u;
  q.budget = pc.loop_budget;
  q.spent = 0u;
  // Every invocation runs every turn (a subgroup's walk needs all of its invocations), those past
  // the batch's end with no point.
  for (uint turn = 0u; turn < pc.per_item; ++turn) {
    const uint i = base + turn * span;
    q.lanes = i < pc.n ? 1 : 0;
    q.p[0] = i < pc.n ? dvec3(points[3u * i], points[3u * i + 1u], points[3u * i + 2u]) : dvec3(0.0);
    q = closest_on_surface(q, pc.scale);
    if (i < pc.n) {
      if (q.incomplete != 0) {
        values[i] = double(uintBitsToFloat(0x7FC00000u));  // NaN
      } else {
        values[i] = signed_value_of(q.p[0], q.hit[0]);
        q.seed[0] = q.hit[0].slot;
      }
    }
  }
}
