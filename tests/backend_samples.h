// Inputs shared by the backend tests (test_opencl, test_vulkan).
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/grid/grid.h"
#include "core/grid/hex_complex.h"
#include "core/cutting/mchex_mesher.h"
#include "core/cutting/mc33.h"
#include "core/sdf/shapes.h"
#include "core/device/backend.h"

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
  // The mesher's classification call on this grid: the zero rule and the uniform numbering on
  // the device.
  ClassifyOptions options() const {
    ClassifyOptions co;
    co.zero_tolerance = tiny;
    co.uniform_cells_per_axis = grid.cells_per_axis();
    return co;
  }
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

// Asks `b` for the crossing parameters of every cell of the complex and compares them with core's
// classify() of the cell's values after the zero rule of `options`: bit for bit on cut edges, NaN
// on the others; the subcases must be core's too. Returns how many cut edges were compared.
inline std::size_t expect_crossings_are_cores(Backend& b, const HexComplex& complex, const std::vector<double>& values,
                                              const ClassifyOptions& options = {}) {
  const std::size_t n = complex.cells.size();
  std::vector<std::uint8_t> subcases(n);
  std::vector<std::uint64_t> offsets(n + 1);
  std::vector<double> crossings(12 * n, 7.0);  // no entry may keep this
  b.classify_cells(complex, values, {subcases, offsets, {}, crossings}, options);
  std::size_t compared = 0, wrong = 0;
  for (std::size_t i = 0; i < n; ++i) {
    std::array<double, 8> f;
    for (int c = 0; c < 8; ++c) {
      const double v = values[complex.cells[i][c]];
      f[c] = std::abs(v) < options.zero_tolerance ? -options.zero_tolerance : v;
    }
    const CellClass want = classify(f);
    if (subcases[i] != static_cast<std::uint8_t>(want.subcase)) ++wrong;
    for (int e = 0; e < 12; ++e) {
      const double got = crossings[12 * i + std::size_t(e)];
      const bool cut = (want.cut_edges >> e & 1) != 0;
      const bool same = cut ? std::memcmp(&got, &want.crossing[std::size_t(e)], sizeof got) == 0 : std::isnan(got);
      if (!same && ++wrong <= 5)
        ADD_FAILURE() << "cell " << i << " edge " << e << ": got " << got << ", core " << want.crossing[std::size_t(e)];
      compared += cut ? 1 : 0;
    }
  }
  EXPECT_EQ(wrong, 0u);
  return compared;
}

}  // namespace mchex::test
