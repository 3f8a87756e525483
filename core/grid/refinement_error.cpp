#include "core/grid/refinement_error.h"

#include <cmath>
#include <limits>

namespace mchex {

double refinement_error(const std::array<double, kChildLatticePoints>& f, double size) {
  // Parent corner values f[x][y][z] at local coordinates x, y, z in {0, 1}.
  double c[2][2][2];
  for (int z = 0; z < 2; ++z)
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 2; ++x) c[x][y][z] = f[child_lattice_index(3 * x, 3 * y, 3 * z)];
  double worst = 0;
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 4; ++i) {
        const double u = i / 3.0, v = j / 3.0, w = k / 3.0;
        // Trilinear interpolant as nested lerps, and its partial derivatives (per unit of the
        // local coordinate; divided by size below to get physical units).
        const double c00 = c[0][0][0] + u * (c[1][0][0] - c[0][0][0]);
        const double c10 = c[0][1][0] + u * (c[1][1][0] - c[0][1][0]);
        const double c01 = c[0][0][1] + u * (c[1][0][1] - c[0][0][1]);
        const double c11 = c[0][1][1] + u * (c[1][1][1] - c[0][1][1]);
        const double c0 = c00 + v * (c10 - c00), c1 = c01 + v * (c11 - c01);
        const double parent = c0 + w * (c1 - c0);
        const double dx00 = c[1][0][0] - c[0][0][0], dx10 = c[1][1][0] - c[0][1][0];
        const double dx01 = c[1][0][1] - c[0][0][1], dx11 = c[1][1][1] - c[0][1][1];
        const double dx0 = dx00 + v * (dx10 - dx00), dx1 = dx01 + v * (dx11 - dx01);
        const double gx = dx0 + w * (dx1 - dx0);
        const double gy = (c10 - c00) + w * ((c11 - c01) - (c10 - c00));
        const double gz = c1 - c0;
        const double grad = std::sqrt(gx * gx + gy * gy + gz * gz) / size;
        const double change = std::fabs(f[child_lattice_index(i, j, k)] - parent);
        if (change == 0) continue;
        if (grad == 0) return std::numeric_limits<double>::infinity();
        const double e = change / grad;
        if (e > worst) worst = e;
      }
  return worst;
}

}  // namespace mchex
