// The MCHex mesher on a uniform grid; see mchex_mesher.h for the keys that make it conform.
#include "core/mchex_mesher.h"

#include <cmath>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/mchex_cells.h"

namespace mchex {

double zero_tolerance(double cell_size) { return 1e-10 * cell_size; }

MeshPair mesh_mchex(const UniformGrid& grid, std::span<const double> values, double eps,
                    MchexStats* stats_out) {
  if (!(eps > 0 && eps < 0.5)) throw InputError("eps must be in (0, 0.5), got " + std::to_string(eps));
  if (values.size() != grid.vertex_count())
    throw InputError("mesh_mchex: " + std::to_string(values.size()) + " values for " +
                     std::to_string(grid.vertex_count()) + " grid vertices");
  MchexStats stats;

  // The zero rule (mchex_mesher.h), once per vertex.
  const double tiny = zero_tolerance(grid.cell_size());
  std::vector<double> f(values.begin(), values.end());
  for (double& v : f) {
    if (!std::isfinite(v)) throw InputError("mesh_mchex: a grid value is not finite");
    if (std::abs(v) < tiny) {
      v = -tiny;
      ++stats.perturbed_values;
    }
  }

  MchexCells cells = mchex_cut_cells(grid, f, eps, stats);
  if (stats_out) *stats_out = stats;
  // Both meshes from the one point array: interface points are bit-identical.
  return {compact_mesh(cells.points, cells.inside, kInside),
          compact_mesh(cells.points, cells.outside, kOutside)};
}

}  // namespace mchex
