// The refinement error of one octree cell on a device, in the common dialect of kernels/dialect.h:
// core/grid/refinement_error.cpp (paper Section 3) operation for operation, so that every value equals
// the CPU's bit for bit.
#ifndef MCHEX_REFINE_H
#define MCHEX_REFINE_H
#ifndef MCHEX_FP32  // double precision throughout (kernels/dialect.h)

#ifdef __OPENCL_C_VERSION__
#define MCHEX_DOUBLE_INFINITY CAST(double, INFINITY)
#else
#define MCHEX_DOUBLE_INFINITY double(uintBitsToFloat(0x7F800000u))
#endif

STRUCT(ChildLattice) {
  double f[64];  // core/grid/refinement_error.h: point (a, b, c) at a + 4 b + 16 c
};

INLINE double refinement_error_of(ChildLattice L, double size) {
  double c[8];  // parent corner (x, y, z) in {0,1}^3 at x + 2 y + 4 z
  for (int z = 0; z < 2; ++z)
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 2; ++x) c[x + 2 * y + 4 * z] = L.f[3 * x + 12 * y + 48 * z];
  EXACT double worst = 0.0;
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 4; ++i) {
        EXACT double u = CAST(double, i) / 3.0;
        EXACT double v = CAST(double, j) / 3.0;
        EXACT double w = CAST(double, k) / 3.0;
        EXACT double c00 = c[0] + u * (c[1] - c[0]);
        EXACT double c10 = c[2] + u * (c[3] - c[2]);
        EXACT double c01 = c[4] + u * (c[5] - c[4]);
        EXACT double c11 = c[6] + u * (c[7] - c[6]);
        EXACT double c0 = c00 + v * (c10 - c00);
        EXACT double c1 = c01 + v * (c11 - c01);
        EXACT double parent = c0 + w * (c1 - c0);
        EXACT double dx00 = c[1] - c[0];
        EXACT double dx10 = c[3] - c[2];
        EXACT double dx01 = c[5] - c[4];
        EXACT double dx11 = c[7] - c[6];
        EXACT double dx0 = dx00 + v * (dx10 - dx00);
        EXACT double dx1 = dx01 + v * (dx11 - dx01);
        EXACT double gx = dx0 + w * (dx1 - dx0);
        EXACT double gy = (c10 - c00) + w * ((c11 - c01) - (c10 - c00));
        EXACT double gz = c1 - c0;
        EXACT double grad = sqrt(gx * gx + gy * gy + gz * gz) / size;
        EXACT double change = FABS(L.f[i + 4 * j + 16 * k] - parent);
        if (change == 0.0) continue;
        if (grad == 0.0) return MCHEX_DOUBLE_INFINITY;
        EXACT double e = change / grad;
        if (e > worst) worst = e;
      }
  return worst;
}

#endif  // MCHEX_FP32
#endif
