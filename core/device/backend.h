// The narrow interface between the mesher and the compute devices (docs/backends.md): the
// data-parallel stages of the pipeline, each a batch in and a batch out. `cpu` is the reference
// (core/, double precision, Embree + TBB); `opencl` (kernels/) and `vulkan` (shaders/) must give
// the same answers: equal classifications, SDF values equal wherever they decide a sign or a
// case (the host re-decides guard-band values in double), coordinates that follow from them
// equal to 1e-9 of the box diagonal.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/base/geometry.h"
#include "core/cutting/mc33.h"
#include "core/grid/hex_complex.h"
#include "core/grid/refinement_error.h"
#include "core/mesh/surface.h"
#include "core/sdf/shapes.h"

namespace mchex {

// What the SDF is of: a triangle surface (closed or not, the sign rule of core/sdf/sdf.h) or a
// built-in analytic shape. Backends build their device-side structures once per source.
// A backend keeps the device structures of the last surface it saw (keyed by the surface's
// address and array addresses and sizes), so the same surface must not change between calls.
struct SdfSource {
  const TriangleSurface* surface = nullptr;  // set for a surface ...
  ShapeKind shape = ShapeKind::kSphere;      // ... otherwise this shape
  // Optional: the caller's own reference SDF of the same source (core/sdf/sdf.h SurfaceSdf or
  // ShapeSdf); the cpu backend evaluates it instead of building a second BVH.
  const SignedDistance* reference = nullptr;
};

// The per-cell result of MC classification, compact enough to come back from a device: the
// fields of core/cutting/mc33.h CellClass that are not derived from the values again on the host.
struct CellCode {
  Subcase subcase = Subcase::kEmpty;
  std::uint8_t sign_mask = 0;
  std::uint8_t face_joins = 0;
  std::int8_t tunnel = 0;
  std::uint8_t symmetry = 0;
  std::uint8_t inverted = 0;
  std::uint16_t cut_edges = 0;
  friend bool operator==(const CellCode&, const CellCode&) = default;
};
CellCode encode_cell(const CellClass& c);
// The two 32-bit words a kernel writes per cell (layout in core/device/device_scene.h) as a CellCode,
// and back.
CellCode decode_cell_words(std::uint32_t w0, std::uint32_t w1);
std::array<std::uint32_t, 2> encode_cell_words(const CellCode& c);

// What classify_cells writes: what the mesher needs (core/cutting/mchex_mesher.h DeviceClassification),
// one byte per cell and the offsets, and, only when asked for, the packed CellCode words (tests
// compare every field with core's; decode_cell_words reads them). Decoding every cell into a
// CellCode on the host is what made classification slow end to end (perf/GPU_RUNS.md).
struct CellClassification {
  std::span<std::uint8_t> subcases;     // cells entries: core/cutting/mc33.h Subcase
  std::span<std::uint64_t> offsets;     // cells + 1 entries; offsets.back() the total
  std::span<std::uint32_t> words = {};  // empty, or 2 * cells (core/device/device_scene.h layout)
  // Empty, or 12 * cells: the crossing parameter on each of the cell's Table-1 edges, as core's
  // classify() gives it (core/cutting/mc33.h CellClass::crossing: f_a / (f_a - f_b) from the edge's first
  // corner on a cut edge, after the zero rule; NaN on an uncut edge; not yet clamped).
  std::span<double> crossings = {};
};

struct ClassifyOptions {
  // > 0: the values are the raw SDF, and the mesher's zero rule (core/cutting/mchex_mesher.h
  // apply_zero_rule: |f| < t becomes -t) is applied to each corner value as it is read, so the
  // caller need not make a ruled copy. 0: the values are classified as given.
  double zero_tolerance = 0;
  // > 0: the complex is uniform_complex() of a grid with this many cells per axis (cells in grid
  // order, points in vertex_index order): a device computes each cell's corner ids instead of
  // reading complex.cells (whose 32 bytes per cell would otherwise cross to the device). The
  // backend checks the sizes; core/cutting/mchex_mesher.h cross-checks every subcase.
  std::uint32_t uniform_cells_per_axis = 0;
  // The caller's promise that `values` is the array this backend's last signed_distance call
  // wrote, unchanged since: a device that kept its output there (one chunk, no shared memory)
  // classifies from it instead of uploading the values again. The backend also checks that the
  // address and size match; without the promise it always uses the caller's values.
  bool values_from_last_sdf = false;
};

struct DeviceInfo {
  std::string backend;   // "cpu" | "opencl" | "vulkan"
  std::string platform;  // OpenCL platform / Vulkan driver name
  std::string name;
  std::string type;  // "cpu" | "gpu" | "other"
  bool fp64 = false;
  // How a backend computes on it: "fp64" (the kernels repeat core's double arithmetic), or "fp32"
  // (no fp64, or MCHEX_FORCE_FP32: single-precision kernels decide what they can prove, the host
  // computes every value in double; results are the same, bit for bit). In device lists: what the
  // backend would use there (the environment's MCHEX_FORCE_FP32 included).
  std::string precision;
  std::uint64_t max_buffer_bytes = 0;  // largest single allocation / storage buffer range
  std::uint64_t global_memory_bytes = 0;
  std::uint32_t compute_units = 0;  // 0: the API does not say (Vulkan has no such property)
  std::string version;              // API version and driver version, as the driver states them
  std::string note;                 // why the backend cannot use this device, if it cannot (e.g. no fp64)
  // How a backend made for this device runs its stages here (the shader or kernel variants it
  // chose), for reports and profiling; empty in device lists.
  std::string kernels;
};

class Backend {
 public:
  virtual ~Backend() = default;
  virtual const DeviceInfo& device() const = 0;

  // Signed distance (f > 0 inside) at every point; values.size() == points.size().
  virtual void signed_distance(const SdfSource& source, std::span<const Vec3> points, std::span<double> values) = 0;

  // The refinement error of core/grid/refinement_error.h for cells.size() cells: lattice[i] holds the
  // 64 child-lattice values of cell i, sizes[i] its edge length.
  virtual void refinement_error(std::span<const std::array<double, kChildLatticePoints>> lattice,
                                std::span<const double> sizes, std::span<double> errors) = 0;

  // MC33 classification of every cell of the complex from the values at its points, and the
  // exclusive prefix sum of the hexes the mesher makes from each cell (core/cutting/local_refinement.h
  // local_refinement_hexes(subcase): 8 + 2 * cut edges for a cell cut directly, the sum over its
  // leaves for one refined locally). See CellClassification and ClassifyOptions. Throws InputError
  // when a corner value is not finite (as core's classify()).
  virtual void classify_cells(const HexComplex& complex, std::span<const double> values, const CellClassification& out,
                              const ClassifyOptions& options = {}) = 0;
};

// backend.classify_cells with the words asked for and decoded: every field of every cell, for
// tests and diagnostics. Throws std::logic_error if a cell's subcase byte and its words disagree.
void classify_cells_codes(Backend& backend, const HexComplex& complex, std::span<const double> values,
                          std::span<CellCode> codes, std::span<std::uint64_t> offsets,
                          const ClassifyOptions& options = {});

// Checks a classify_cells call's sizes (std::invalid_argument) and, for uniform_cells_per_axis,
// that the complex has the uniform grid's numbers of cells and points.
void check_classify_sizes(const HexComplex& complex, std::span<const double> values, const CellClassification& out,
                          const ClassifyOptions& options);

}  // namespace mchex
