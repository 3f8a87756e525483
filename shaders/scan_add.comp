#version 450
// Exclusive prefix sum, pass 3 of 3: every offset gets its block's offset.
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
layout(local_size_x = 256) in;

layout(std430, binding = 0) buffer Offsets { uint64_t offsets[]; };
layout(std430, binding = 1) readonly buffer Totals { uint64_t totals[]; };
layout(push_constant) uniform Push { uint n; } pc;

void main() {
  const uint i = gl_GlobalInvocationID.x;
  if (i < pc.n) offsets[i] += totals[i / 1024u];
}
