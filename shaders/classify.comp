#version 450
// MC33 classification, one cell per invocation: a thin wrapper around the shared device logic of
// kernels/classify.h (the same source as the OpenCL kernel; in GLSL its face test takes the exact
// no-fma path, Dekker products and an expansion sum, since Vulkan does not promise a fused fma).
// Writes the CellCode words (core/device_scene.h layout) and the cell's hex count for the prefix
// sum (shaders/scan_*.comp). Tables come from the generated mchex_tables.glsl.h; the (sign
// pattern, face outcomes) lookup is core's own, uploaded as `configs`
// (core/device_scene.h packed_mc33_configs()).
#extension GL_GOOGLE_include_directive : require
#include "mchex_tables.glsl.h"
#include "kernels/dialect.h"
layout(local_size_x = 64) in;

// gathered == 0: values[] holds f at every grid point and cell_points[] 8 point ids per cell;
// gathered == 1: values[] holds the 8 corner values of every cell of the chunk (the host
// gathers them when the point values exceed one storage buffer).
layout(std430, binding = 0) readonly buffer Values { double values[]; };
layout(std430, binding = 1) readonly buffer Cells { uint cell_points[]; };
layout(std430, binding = 2) readonly buffer Configs { uint configs[]; };
layout(std430, binding = 3) writeonly buffer Codes { uint codes[]; };
layout(std430, binding = 4) writeonly buffer Counts { uint counts[]; };
layout(push_constant) uniform Push { uint cells; uint gathered; } pc;

#include "kernels/classify.h"

void main() {
  const uint cell = gl_GlobalInvocationID.x;
  if (cell >= pc.cells) return;
  CellValues v;
  for (uint c = 0u; c < 8u; ++c)
    v.f[c] = pc.gathered != 0u ? values[8u * cell + c] : values[cell_points[8u * cell + c]];
  const CellWords w = classify_cell(v);
  codes[2u * cell] = w.w0;
  codes[2u * cell + 1u] = w.w1;
  counts[cell] = cell_hexes(w);
}
