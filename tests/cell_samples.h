// Corner values for the cutting tests (test_polyhedra, test_local_refinement): one sign pattern,
// magnitudes drawn so that crossings land anywhere, or near the ends and at the clamp itself.
#pragma once

#include <array>
#include <cstdint>
#include <random>

#include "core/mesh/quality.h"

namespace mchex::test {

using CellValues = std::array<double, 8>;

// kind 0: magnitudes uniform in [0.05, 1]; kind 1 / 2: each magnitude 1 or a tiny one (1e-3 /
// 1e-6 scale), so that crossings sit near 0 and 1 and at the clamp eps itself.
inline CellValues draw_cell(std::uint8_t positive_mask, int kind, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.05, 1.0);
  std::bernoulli_distribution coin(0.5);
  CellValues f;
  for (int c = 0; c < 8; ++c) {
    double m = u(rng);
    if (kind == 1) m = coin(rng) ? 1.0 : 1e-3 * u(rng);
    if (kind == 2) m = coin(rng) ? 1.0 : 1e-6 * u(rng);
    f[c] = (positive_mask >> c & 1) ? m : -m;
  }
  return f;
}

// A random right-handed affine image of the unit cube: a linear part near the identity with
// determinant above 0.3 (far from degenerate) and a translation. Theorem 5.2 of the paper: the
// certificate is invariant under such maps, so cells like these must certify like the cube.
inline HexCorners random_affine_cube(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-0.4, 0.4);
  for (;;) {
    double a[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) a[i][j] = (i == j ? 1.0 : 0.0) + u(rng);
    const double det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
                       a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                       a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
    if (det <= 0.3) continue;
    const Vec3 t{10 * u(rng), -7 * u(rng), 3 * u(rng)};
    HexCorners c;
    for (int i = 0; i < 8; ++i) {
      const Vec3 p = kUnitCubeCorners[i];
      c[i] = Vec3{a[0][0] * p.x + a[0][1] * p.y + a[0][2] * p.z, a[1][0] * p.x + a[1][1] * p.y + a[1][2] * p.z,
                  a[2][0] * p.x + a[2][1] * p.y + a[2][2] * p.z} +
             t;
    }
    return c;
  }
}

}  // namespace mchex::test
