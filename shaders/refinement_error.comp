#version 450
// The refinement error of core/refinement_error.h, one cell per invocation, bit for bit: the same
// operations in the same order, all `precise` (SPIR-V NoContraction) so that no multiply-add is
// fused (the reference is compiled without FMA contraction), in fp64.
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Lattice { double lattice[]; };  // 64 per cell
layout(std430, binding = 1) readonly buffer Sizes { double sizes[]; };
layout(std430, binding = 2) writeonly buffer Errors { double errors[]; };
layout(push_constant) uniform Push { uint cells; } pc;

double f_at(uint base, int a, int b, int c) { return lattice[base + uint(a + 4 * b + 16 * c)]; }

void main() {
  const uint cell = gl_GlobalInvocationID.x;
  if (cell >= pc.cells) return;
  const uint base = cell * 64u;
  const double size = sizes[cell];
  double c[8];  // parent corner x + 2y + 4z
  for (int z = 0; z < 2; ++z)
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 2; ++x) c[x + 2 * y + 4 * z] = f_at(base, 3 * x, 3 * y, 3 * z);
  precise double worst = 0.0;
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 4; ++i) {
        precise const double u = double(i) / 3.0, v = double(j) / 3.0, w = double(k) / 3.0;
        precise const double c00 = c[0] + u * (c[1] - c[0]);
        precise const double c10 = c[2] + u * (c[3] - c[2]);
        precise const double c01 = c[4] + u * (c[5] - c[4]);
        precise const double c11 = c[6] + u * (c[7] - c[6]);
        precise const double c0 = c00 + v * (c10 - c00), c1 = c01 + v * (c11 - c01);
        precise const double parent = c0 + w * (c1 - c0);
        precise const double dx00 = c[1] - c[0], dx10 = c[3] - c[2];
        precise const double dx01 = c[5] - c[4], dx11 = c[7] - c[6];
        precise const double dx0 = dx00 + v * (dx10 - dx00), dx1 = dx01 + v * (dx11 - dx01);
        precise const double gx = dx0 + w * (dx1 - dx0);
        precise const double gy = (c10 - c00) + w * ((c11 - c01) - (c10 - c00));
        precise const double gz = c1 - c0;
        precise const double grad = sqrt(gx * gx + gy * gy + gz * gz) / size;
        precise const double change = abs(f_at(base, i, j, k) - parent);
        if (change == 0.0) continue;
        if (grad == 0.0) {
          worst = packDouble2x32(uvec2(0u, 0x7ff00000u));  // +infinity: the cell must refine
          i = 4; j = 4; k = 4;  // leave all three loops
          break;
        }
        precise const double e = change / grad;
        if (e > worst) worst = e;
      }
  errors[cell] = worst;
}
