// The body of shaders/classify.comp and classify_crossings.comp.
// MC33 classification, one cell per invocation: a thin wrapper around the shared device logic of
// kernels/classify.h (the same source as the OpenCL kernel; in GLSL its face test takes the exact
// no-fma path, Dekker products and an expansion sum, since Vulkan does not promise a fused fma).
// Writes each cell's Subcase byte (all the mesher needs; four to a word, OR-ed atomically into a
// word the host zeroed, since core Vulkan has no byte stores), the CellCode words (core/device/device_scene.h
// layout) when asked for, the crossing parameters in classify_crossings.comp (MCHEX_CLASSIFY_CROSSINGS:
// a shader of its own, since llvmpipe would run a flagged branch under a mask in every cell), and
// the cell's hex count for the prefix sum (shaders/scan_*.comp).
// Tables come from the generated mchex_tables.glsl.h; the (sign pattern, face outcomes) lookup is
// core's own, uploaded as `configs` (core/device/device_scene.h packed_mc33_configs()).
#extension GL_GOOGLE_include_directive : require
#include "mchex_tables.glsl.h"
#include "kernels/dialect.h"
layout(local_size_x = 64) in;

// flags bit 0 (gathered): values[] holds the 8 corner values of every cell of the chunk (the host
// gathers them when the point values exceed one storage buffer); otherwise values[] holds f at
// every grid point, and the corner ids come from cell_points[] (8 per cell of the chunk) or, when
// uniform_n > 0, from the uniform grid's numbering (kernels/classify.h uniform_cell_base).
// flags bit 1: write the CellCode words. zero_tolerance > 0: the mesher's zero rule on each value.
layout(std430, binding = 0) readonly buffer Values { double values[]; };
layout(std430, binding = 1) readonly buffer Cells { uint cell_points[]; };
layout(std430, binding = 2) readonly buffer Configs { uint configs[]; };
layout(std430, binding = 3) writeonly buffer Codes { uint codes[]; };
layout(std430, binding = 4) writeonly buffer Counts { uint counts[]; };
layout(std430, binding = 5) buffer Subcases { uint subcases[]; };  // 4 bytes per word, zeroed by the host
layout(std430, binding = 6) buffer Bad { uint bad[]; };
#ifdef MCHEX_CLASSIFY_CROSSINGS
layout(std430, binding = 7) writeonly buffer Crossings { double crossings[]; };  // 12 per cell
#endif
layout(push_constant) uniform Push { uint cells; uint first; uint uniform_n; uint flags; double zero_tolerance; } pc;

#include "kernels/classify.h"

void main() {
  const uint cell = gl_GlobalInvocationID.x;
  if (cell < pc.cells) {
    CellValues v;
    int mask = 0;
    bool finite = true;
    const uint base = pc.uniform_n > 0u ? uniform_cell_base(pc.first + cell, pc.uniform_n) : 0u;
    for (uint c = 0u; c < 8u; ++c) {
      double f;
      if ((pc.flags & 1u) != 0u) f = values[8u * cell + c];
      else if (pc.uniform_n > 0u) f = values[base + uniform_corner_offset(pc.uniform_n, int(c))];
      else f = values[cell_points[8u * cell + c]];
      finite = finite && !(isinf(f) || isnan(f));
      f = abs(f) < pc.zero_tolerance ? -pc.zero_tolerance : f;
      v.f[c] = f;
      if (f > 0.0) mask |= 1 << c;
    }
    if (!finite) bad[0] = 1u;
    const CellWords w = classify_pattern(v, mask);
    atomicOr(subcases[cell / 4u], (w.w0 & 255u) << (8u * (cell % 4u)));
    if ((pc.flags & 2u) != 0u) {
      codes[2u * cell] = w.w0;
      codes[2u * cell + 1u] = w.w1;
    }
#ifdef MCHEX_CLASSIFY_CROSSINGS
    for (int e = 0; e < 12; ++e) crossings[12u * cell + uint(e)] = edge_crossing(v, mask, e);
#endif
    counts[cell] = cell_hexes(w);
  }
}
