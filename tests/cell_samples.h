// Corner values for the cutting tests (test_polyhedra, test_local_refinement): one sign pattern,
// magnitudes drawn so that crossings land anywhere, or near the ends and at the clamp itself.
#pragma once

#include <array>
#include <cstdint>
#include <random>

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

}  // namespace mchex::test
