// The front half of every device backend (opencl, vulkan), written once: what each batch
// operation of core/device/backend.h does before a device sees it. The batch-size checks; the
// answers that need no device (an empty batch; an empty surface, outside everywhere as in
// core/sdf/sdf.cpp); the fp32 path's host stages (analytic shapes, refinement error and MC33
// classification run on the host in double there, because every operation of theirs decides its
// result: nothing a float kernel could prove and leave out, host/backends/fp32_path.h); and the
// Morton order in which surface points go to a device, as core searches them (core/sdf/sdf.h:
// each invocation's run of points, and each group's, is a compact cluster whose searches seed
// one another and share the tree's nodes in cache), with the scatter of the values back.
//
// A device backend derives from DeviceBackend and implements the device_* hooks, each called
// only with a non-empty batch of the right sizes. The results do not depend on this split: the
// hooks see the same inputs as the backends' own front halves did (meshes byte-identical).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "core/device/backend.h"
#include "core/sdf/sdf.h"

namespace mchex {

// Surface points in the order a device searches them (core/sdf/sdf.h morton_order).
class MortonBatch {
 public:
  explicit MortonBatch(std::span<const Vec3> points);
  std::size_t size() const { return points_.size(); }
  std::span<const Vec3> points() const { return points_; }
  // order()[i]: the index in points() of the i-th point searched.
  std::span<const std::uint32_t> order() const { return order_; }
  // The searched points [first, first + count) as 3 coordinates each (double, or float for the
  // fp32 path's kernels) into dst.
  void gather(std::size_t first, std::size_t count, double* dst) const;
  void gather(std::size_t first, std::size_t count, float* dst) const;
  // The values of the searched points [first, first + src.size()) to their own indices.
  void scatter(std::size_t first, std::span<const double> src, std::span<double> values) const;

 private:
  std::span<const Vec3> points_;
  std::vector<std::uint32_t> order_;
};

// Items per dispatch when each needs `bytes_per_item` bytes of its largest buffer: within the
// device's `limit_bytes` (largest allocation or buffer range), at most `item_cap` (the API's
// index or workgroup-count limit) and, when non-zero, the caller's `max_chunk` (tests cross
// chunk boundaries with it); at least 1.
std::size_t items_per_chunk(std::uint64_t limit_bytes, std::size_t bytes_per_item, std::size_t item_cap,
                            std::size_t max_chunk);

// core's SurfaceSdf values at points[which[k]], into values[which[k]]: the points a device gave
// up on (a loop budget ran out, too many fp32 candidates). `sdf` is made on first use and kept.
void host_values_at(std::unique_ptr<SurfaceSdf>& sdf, const TriangleSurface& surface, std::span<const Vec3> points,
                    std::span<const std::size_t> which, std::span<double> values);

class DeviceBackend : public Backend {
 public:
  void signed_distance(const SdfSource& source, std::span<const Vec3> points, std::span<double> values) final;
  void refinement_error(std::span<const std::array<double, kChildLatticePoints>> lattice, std::span<const double> sizes,
                        std::span<double> errors) final;
  void classify_cells(const HexComplex& complex, std::span<const double> values, const CellClassification& out,
                      const ClassifyOptions& options = {}) final;

 protected:
  // Whether the backend runs the fp32 path (fixed when it is made).
  virtual bool fp32_path() const = 0;
  // Every signed_distance call first drops what the last one left on the device for
  // ClassifyOptions::values_from_last_sdf: the caller's array may change from here on.
  virtual void forget_resident_values() = 0;
  // The fp64 path's surface SDF (a surface with triangles) with the points in search order, and
  // the analytic shapes.
  virtual void device_surface_sdf(const TriangleSurface& surface, const MortonBatch& points,
                                  std::span<double> values) = 0;
  virtual void device_shape_sdf(ShapeKind shape, std::span<const Vec3> points, std::span<double> values) = 0;
  // The fp32 path's surface SDF (host/backends/fp32_path.h).
  virtual void device_surface_sdf32(const TriangleSurface& surface, std::span<const Vec3> points,
                                    std::span<double> values) = 0;
  virtual void device_refinement_error(std::span<const std::array<double, kChildLatticePoints>> lattice,
                                       std::span<const double> sizes, std::span<double> errors) = 0;
  // Sizes checked, offsets[0] already 0, at least one cell.
  virtual void device_classify_cells(const HexComplex& complex, std::span<const double> values,
                                     const CellClassification& out, const ClassifyOptions& options) = 0;
};

}  // namespace mchex
