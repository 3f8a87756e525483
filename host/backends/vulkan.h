// The `vulkan` backend (core/device/backend.h): the data-parallel stages as GLSL compute shaders
// (shaders/*.comp), compiled to SPIR-V at build time and run through Vulkan 1.2 (Mesa lavapipe on
// this machine): in double precision on a device with shaderFloat64 and shaderInt64, else (or
// forced) the fp32 path of kernels/sdf_fp32.h, whose values the host computes in double
// (host/backends/fp32_path.h). Results equal the cpu reference bit for bit: SDF values, refinement errors,
// CellCodes and hex offsets (test_vulkan checks each, on both paths).
//
// Large batches are cut into chunks that fit the device's limits: every binding within
// maxStorageBufferRange (128 MiB on lavapipe) and every dispatch within
// maxComputeWorkGroupCount[0]. Compiled pipelines are kept in a VkPipelineCache saved under
// $XDG_CACHE_HOME/mchex-gpu (else ~/.cache/mchex-gpu), one file per device UUID and driver
// version, so a second run does not recompile.
#pragma once

#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "core/device/backend.h"
#include "host/backends/device_front.h"
#include "host/backends/fp32_path.h"

namespace mchex {

struct VulkanOptions {
  // Which device: empty takes the first GPU, else the first device; otherwise the first device
  // whose name or driver name contains this text (e.g. "llvmpipe"). The environment variable
  // MCHEX_VULKAN_DEVICE, when set, is used where this is empty.
  std::string device;
  // Where the pipeline cache file lives; empty: no cache on disk.
  std::filesystem::path cache_dir = default_pipeline_cache_dir();
  // Largest number of elements (points, cells) per dispatch; 0: only the device's limits.
  // Tests force small chunks with it to exercise the chunking.
  std::size_t max_chunk = 0;
  // How the surface SDF walks the tree (kernels/sdf.h): kSubgroup, a subgroup's invocations
  // share one walk (needs subgroup arithmetic in compute shaders, else InputError); kSingle, one
  // walk per invocation; kAuto, the subgroup walk on GPUs with subgroup arithmetic (faster on an
  // H200) and one walk per invocation elsewhere (faster on lavapipe). Tests run both. (The fp32
  // path has one walk per invocation only: kernels/sdf_fp32.h.)
  enum class SdfWalk { kAuto, kSubgroup, kSingle };
  SdfWalk sdf_walk = SdfWalk::kAuto;
  // Run the fp32 path even on a device with fp64 (tests: the fp32 path on lavapipe). The
  // environment variable MCHEX_FORCE_FP32=1 does the same. A device without shaderFloat64 or
  // shaderInt64 always runs it: the surface SDF's candidate search on the device
  // (shaders/surface_sdf32*.comp), the values, analytic shapes, refinement errors and
  // classification on the host in double.
  bool force_fp32 = false;
  // Where the surface SDF's one-walk-per-invocation shader reads the search tree and triangles
  // from texel buffers by default (llvmpipe, whose storage-buffer reads are slow), read storage
  // buffers instead, as on every other device (tests run both).
  bool sdf_storage_reads = false;

  static std::filesystem::path default_pipeline_cache_dir();
};

class VulkanBackend : public DeviceBackend {
 public:
  // Throws InputError (exit 1, one line) when Vulkan has no usable device here (below Vulkan 1.2,
  // or no compute queue).
  explicit VulkanBackend(const VulkanOptions& options = {});
  ~VulkanBackend() override;

  const DeviceInfo& device() const override;

  // The pipeline cache: its file, how many bytes of it were loaded at creation, and the seconds
  // spent creating the pipelines (compilation, or a cache hit).
  std::filesystem::path pipeline_cache_file() const;
  std::size_t pipeline_cache_bytes_loaded() const;
  double pipeline_seconds() const;
  // The chosen device's pipelineCacheUUID: a cache file's header must carry it (Vulkan spec,
  // VkPipelineCacheHeaderVersionOne) for the driver to use the file.
  std::array<std::uint8_t, 16> pipeline_cache_uuid() const;
  // Dispatches issued so far (each within the device's limits): tests check the chunking.
  std::size_t dispatches() const;
  // Whether the surface SDF runs the subgroup walk (VulkanOptions::sdf_walk).
  bool sdf_subgroup_walk() const;
  // Whether the surface SDF reads the search arrays from texel buffers (scenes within
  // maxTexelBufferElements; else storage buffers).
  bool sdf_texel_reads() const;
  // Where the time went since creation (seconds): host copies into mapped buffers (and gathers),
  // dispatches (submit to fence: the device's work, JIT compilation on first use included), and
  // copies back out (and decoding).
  struct Profile {
    double upload = 0, device = 0, download = 0;
    // Surface SDF points whose device search ran out of its loop budget (kernels/sdf.h: lavapipe
    // cuts a shader's loops after 65,535 iterations), evaluated on the host by core instead.
    std::size_t host_points = 0;
  };
  // The loop budget the surface SDF runs under (kernels/sdf.h, or kernels/sdf_fp32.h on the fp32
  // path; 0: none).
  std::uint32_t sdf_loop_budget() const;
  Profile profile() const;
  // The fp32 path's division of work since creation (all zero on the fp64 path).
  Fp32Stats fp32_stats() const;

  struct Impl;

 protected:
  // host/backends/device_front.h
  bool fp32_path() const override;
  void forget_resident_values() override;
  void device_surface_sdf(const TriangleSurface& surface, const MortonBatch& points, std::span<double> values) override;
  void device_shape_sdf(ShapeKind shape, std::span<const Vec3> points, std::span<double> values) override;
  void device_surface_sdf32(const TriangleSurface& surface, std::span<const Vec3> points,
                            std::span<double> values) override;
  void device_refinement_error(std::span<const std::array<double, kChildLatticePoints>> lattice,
                               std::span<const double> sizes, std::span<double> errors) override;
  void device_classify_cells(const HexComplex& complex, std::span<const double> values, const CellClassification& out,
                             const ClassifyOptions& options) override;

 private:
  std::unique_ptr<Impl> impl_;
};

// Every Vulkan physical device (for `mchex-gpu devices`); empty when there is no Vulkan loader
// or driver (never throws for that).
std::vector<DeviceInfo> list_vulkan_devices();
// The same devices with what a GPU user wants to see: driver, API version, fp64/int64, storage
// buffer range, workgroup limits, memory heaps; one line each.
std::vector<std::string> describe_vulkan_devices();

}  // namespace mchex
