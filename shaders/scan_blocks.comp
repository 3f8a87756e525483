#version 450
// Exclusive prefix sum, pass 1 of 3 (shaders/scan_totals.comp, shaders/scan_add.comp): each
// workgroup scans one block of 1024 counts (4 per invocation) in shared memory (Hillis-Steele
// over the 256 invocation sums), writes block-local offsets and the block's total.
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
layout(local_size_x = 256) in;

layout(std430, binding = 0) readonly buffer Counts { uint counts[]; };
layout(std430, binding = 1) writeonly buffer Offsets { uint64_t offsets[]; };
layout(std430, binding = 2) writeonly buffer Totals { uint64_t totals[]; };
layout(push_constant) uniform Push { uint n; } pc;

shared uint sums[256];

void main() {
  const uint t = gl_LocalInvocationID.x;
  const uint first = gl_WorkGroupID.x * 1024u + 4u * t;
  uint local[4];
  uint sum = 0u;
  for (uint k = 0u; k < 4u; ++k) {
    local[k] = sum;
    sum += first + k < pc.n ? counts[first + k] : 0u;
  }
  sums[t] = sum;
  barrier();
  for (uint step = 1u; step < 256u; step <<= 1) {
    const uint add = t >= step ? sums[t - step] : 0u;
    barrier();
    sums[t] += add;
    barrier();
  }
  const uint before = sums[t] - sum;  // exclusive: the sums of the invocations before t
  for (uint k = 0u; k < 4u; ++k)
    if (first + k < pc.n) offsets[first + k] = uint64_t(before + local[k]);
  if (t == 255u) totals[gl_WorkGroupID.x] = uint64_t(sums[255]);
}
