// Inputs shared by the backend tests (test_opencl, test_vulkan).
#pragma once

#include <cmath>
#include <cstddef>
#include <vector>

#include "core/grid.h"
#include "core/hex_complex.h"
#include "core/mchex_mesher.h"
#include "core/shapes.h"

namespace mchex::test {

// The two-holed solid on the uniform depth-3 grid, with values near the surface replaced by ones
// the zero rule moves (0, -0, +-tiny/2) and ones it keeps (+-tiny exactly), next to cut cells;
// `ruled` is apply_zero_rule's result, what every backend's classification must reproduce.
struct ZeroRuleGrid {
  UniformGrid grid;
  HexComplex complex;
  std::vector<double> values, ruled;
  double tiny = 0;
  std::size_t moved = 0;
};

inline ZeroRuleGrid zero_rule_grid() {
  const ShapeSdf shape(ShapeKind::kTwoHoled);
  ZeroRuleGrid z{UniformGrid(padded_cube(shape.bounds(), 0.1), 3), {}, {}, {}, 0, 0};
  z.complex = uniform_complex(z.grid);
  z.values.resize(z.complex.points.size());
  shape.evaluate(z.complex.points, z.values);
  z.tiny = zero_tolerance_of(z.complex);
  const double specials[] = {0.0, -0.0, 0.5 * z.tiny, -0.5 * z.tiny, z.tiny, -z.tiny};
  for (std::size_t p = 0; p < z.values.size(); ++p)
    if (std::abs(z.values[p]) < 2 * z.grid.cell_size() && p % 7 == 0) z.values[p] = specials[(p / 7) % 6];
  z.ruled = apply_zero_rule(z.complex, z.values, &z.moved);
  return z;
}

}  // namespace mchex::test
