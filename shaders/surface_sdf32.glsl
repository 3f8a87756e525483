// The body of shaders/surface_sdf32.comp and surface_sdf32_counted.comp: the fp32 path's surface
// SDF (kernels/sdf_fp32.h, the same source as kernels/mchex.cl's sdf_surface32) for devices
// without shaderFloat64 or shaderInt64, or forced (MCHEX_FORCE_FP32). No double and no 64-bit
// integer anywhere: per point it writes a candidate record (host/backends/fp32_path.h: the count, then
// MCHEX_FP32_CANDIDATES slots; count MCHEX_FP32_CANDIDATES + 1 too many candidates, + 2 out of
// the loop budget) and the host computes the value from it in double.
//
// Vulkan's float precision is looser than IEEE for two operations the bounds use (Vulkan spec,
// "Precision and Operation of SPIR-V Instructions": x / y within 2.5 ULP, sqrt inherited from
// 1 / inversesqrt, about 4.5 ULP; +, -, * correctly rounded). kernels/sdf_fp32.h's margins absorb
// that: D's relative error grows to at most 6 2^-23 (its dot product 1.5, sqrt 4.5), within the
// 2^-20 factor of U; |n| may exceed 1 by 2^-23 before it is scaled, under 4 2^-23 M on L, within
// the 34 2^-23 M left of its 2^-17 M term. Fused multiply-adds round less, never more.
//
// Each invocation takes `per_item` consecutive points (Morton order: the host sorts them), each
// search seeded with the previous one's nearest slot (the result does not depend on the seed).
#extension GL_GOOGLE_include_directive : require
#define MCHEX_FP32
#include "mchex_tables.glsl.h"
#include "kernels/dialect.h"
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Nodes { BvhNode nodes[]; };
layout(std430, binding = 1) readonly buffer NodeSlack { float node_slack[]; };
layout(std430, binding = 2) readonly buffer SlotCorners32 { float slot_corners32[]; };
layout(std430, binding = 3) readonly buffer SlotSlack { float slot_slack[]; };
layout(std430, binding = 4) readonly buffer Points { float points[]; };  // x, y, z per point, rounded to float
layout(std430, binding = 5) writeonly buffer Records { uint records[]; };
// loop_budget: kernels/sdf_fp32.h's (0: none).
layout(push_constant) uniform Push { uint n; uint per_item; uint loop_budget; float scale; } pc;

#include "kernels/sdf_fp32.h"

void main() {
  const uint first = gl_GlobalInvocationID.x * pc.per_item;
  uint seed = 0u;
  uint spent = 0u;
  for (uint turn = 0u; turn < pc.per_item; ++turn) {
    const uint i = first + turn;
    if (i >= pc.n) break;
    const vec3 p = vec3(points[3u * i], points[3u * i + 1u], points[3u * i + 2u]);
    const Candidates32 s = surface_candidates32_within(p, seed, pc.scale, pc.loop_budget, spent);
    const uint out_at = uint(MCHEX_FP32_CANDIDATES + 1) * i;
    records[out_at] = s.overflow == 2 ? uint(MCHEX_FP32_CANDIDATES + 2)
                    : s.overflow != 0 ? uint(MCHEX_FP32_CANDIDATES + 1) : uint(s.count);
    for (int k = 0; k < MCHEX_FP32_CANDIDATES; ++k) records[out_at + 1u + uint(k)] = k < s.count ? s.slot[k] : 0u;
    seed = s.nearest;
    spent = s.spent;
  }
}
