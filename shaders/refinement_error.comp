#version 450
// The refinement error of core/grid/refinement_error.h, one cell per invocation: a thin wrapper around
// the shared device logic of kernels/refine.h (the same source as the OpenCL kernel), bit for bit
// equal to the reference.
#extension GL_GOOGLE_include_directive : require
#include "mchex_tables.glsl.h"
#include "kernels/dialect.h"
#include "kernels/refine.h"
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Lattice { double lattice[]; };  // 64 per cell
layout(std430, binding = 1) readonly buffer Sizes { double sizes[]; };
layout(std430, binding = 2) writeonly buffer Errors { double errors[]; };
layout(push_constant) uniform Push { uint cells; } pc;

void main() {
  const uint cell = gl_GlobalInvocationID.x;
  if (cell >= pc.cells) return;
  ChildLattice L;
  for (uint k = 0u; k < uint(MCHEX_CHILD_LATTICE_POINTS); ++k) L.f[k] = lattice[cell * uint(MCHEX_CHILD_LATTICE_POINTS) + k];
  errors[cell] = refinement_error_of(L, sizes[cell]);
}
