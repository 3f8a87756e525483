#include "host/backends/device_front.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/base/parallel.h"
#include "core/grid/refinement_error.h"
#include "core/sdf/shapes.h"
#include "host/backends/cpu.h"

namespace mchex {

MortonBatch::MortonBatch(std::span<const Vec3> points) : points_(points), order_(morton_order(points)) {}

void MortonBatch::gather(std::size_t first, std::size_t count, double* dst) const {
  parallel_for(count, [&](std::size_t i) {
    const Vec3& p = points_[order_[first + i]];
    dst[3 * i] = p.x, dst[3 * i + 1] = p.y, dst[3 * i + 2] = p.z;
  });
}

void MortonBatch::gather(std::size_t first, std::size_t count, float* dst) const {
  parallel_for(count, [&](std::size_t i) {
    const Vec3& p = points_[order_[first + i]];
    dst[3 * i] = float(p.x), dst[3 * i + 1] = float(p.y), dst[3 * i + 2] = float(p.z);
  });
}

void MortonBatch::scatter(std::size_t first, std::span<const double> src, std::span<double> values) const {
  parallel_for(src.size(), [&](std::size_t i) { values[order_[first + i]] = src[i]; });
}

std::size_t items_per_chunk(std::uint64_t limit_bytes, std::size_t bytes_per_item, std::size_t item_cap,
                            std::size_t max_chunk) {
  std::size_t n = std::size_t(std::min<std::uint64_t>(limit_bytes / bytes_per_item, item_cap));
  if (max_chunk) n = std::min(n, max_chunk);
  return std::max<std::size_t>(n, 1);
}

void host_values_at(std::unique_ptr<SurfaceSdf>& sdf, const TriangleSurface& surface, std::span<const Vec3> points,
                    std::span<const std::size_t> which, std::span<double> values) {
  if (which.empty()) return;
  if (!sdf) sdf = std::make_unique<SurfaceSdf>(surface);
  std::vector<Vec3> p(which.size());
  std::vector<double> v(which.size());
  for (std::size_t k = 0; k < which.size(); ++k) p[k] = points[which[k]];
  sdf->evaluate(p, v);
  for (std::size_t k = 0; k < which.size(); ++k) values[which[k]] = v[k];
}

void DeviceBackend::signed_distance(const SdfSource& source, std::span<const Vec3> points, std::span<double> values) {
  if (points.size() != values.size()) throw std::invalid_argument("signed_distance: batch size mismatch");
  forget_resident_values();
  if (points.empty()) return;
  if (source.surface && source.surface->triangles.empty()) {
    // As core/sdf/sdf.cpp: no triangle, nothing is inside.
    std::fill(values.begin(), values.end(), -INFINITY);
    return;
  }
  if (fp32_path()) {
    if (source.surface) device_surface_sdf32(*source.surface, points, values);
    else ShapeSdf(source.shape).evaluate(points, values);
    return;
  }
  if (source.surface) device_surface_sdf(*source.surface, MortonBatch(points), values);
  else device_shape_sdf(source.shape, points, values);
}

void DeviceBackend::refinement_error(std::span<const std::array<double, kChildLatticePoints>> lattice,
                                     std::span<const double> sizes, std::span<double> errors) {
  if (lattice.size() != sizes.size() || lattice.size() != errors.size())
    throw std::invalid_argument("refinement_error: batch size mismatch");
  if (lattice.empty()) return;
  if (fp32_path()) {
    parallel_for(lattice.size(), [&](std::size_t i) { errors[i] = mchex::refinement_error(lattice[i], sizes[i]); });
    return;
  }
  device_refinement_error(lattice, sizes, errors);
}

void DeviceBackend::classify_cells(const HexComplex& complex, std::span<const double> values,
                                   const CellClassification& out, const ClassifyOptions& options) {
  check_classify_sizes(complex, values, out, options);
  out.offsets[0] = 0;
  if (complex.cells.empty()) return;
  if (fp32_path()) {
    // A float classification with a double filter is not built: core's, on the host.
    make_cpu_backend()->classify_cells(complex, values, out, options);
    return;
  }
  device_classify_cells(complex, values, out, options);
}

}  // namespace mchex
