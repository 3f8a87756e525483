#version 450
// Exclusive prefix sum, pass 2 of 3: one workgroup turns the block totals into each block's
// offset, starting from `carry` (the total of the chunks before this one), 256 blocks per round.
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
layout(local_size_x = 256) in;

layout(std430, binding = 0) buffer Totals { uint64_t totals[]; };
layout(push_constant) uniform Push { uint blocks; uint pad; uint64_t carry; } pc;

shared uint64_t sums[256];

void main() {
  const uint t = gl_LocalInvocationID.x;
  uint64_t carry = pc.carry;
  for (uint base = 0u; base < pc.blocks; base += 256u) {
    const uint64_t mine = base + t < pc.blocks ? totals[base + t] : uint64_t(0);
    sums[t] = mine;
    barrier();
    for (uint step = 1u; step < 256u; step <<= 1) {
      const uint64_t add = t >= step ? sums[t - step] : uint64_t(0);
      barrier();
      sums[t] += add;
      barrier();
    }
    if (base + t < pc.blocks) totals[base + t] = carry + sums[t] - mine;
    carry += sums[255];
    barrier();
  }
}
