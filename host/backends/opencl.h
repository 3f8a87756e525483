// The opencl backend: kernels/*.cl (OpenCL C 1.2) on any OpenCL device (PoCL on this machine's
// CPUs): in double precision where the device has cl_khr_fp64, else (or forced) the fp32 path of
// kernels/sdf_fp32.h with the values computed on the host in double. The program is built from source once per device,
// driver and source text, and its binary kept on disk (see OpenclOptions::cache_dir), so a second
// run does not recompile. Large batches go in chunks within the device's largest allocation.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/device/backend.h"
#include "host/backends/device_front.h"
#include "host/backends/fp32_path.h"  // Fp32Stats

namespace mchex {

struct OpenclOptions {
  // The platform whose name contains this text (case-sensitive), or any platform when empty.
  std::string platform;
  // Prefer a GPU device; otherwise the first device with fp64 in platform order.
  bool prefer_gpu = true;
  // Extra OpenCL C build options (tests build the no-fma face test with -DMCHEX_NO_FMA).
  std::string build_options;
  // Program binary cache folder; empty: $XDG_CACHE_HOME/mchex-gpu, else $HOME/.cache/mchex-gpu.
  // Caching is skipped when no such folder can be made.
  std::string cache_dir;
  // Largest number of points / cells per dispatch (0: as many as the device's allocation limit
  // allows). Tests make it small to cross chunk boundaries.
  std::size_t max_chunk = 0;
  // Use the caller's arrays in place (CL_MEM_USE_HOST_PTR) when the device shares the host's
  // memory (CL_DEVICE_HOST_UNIFIED_MEMORY, e.g. PoCL). false: device buffers and copies, as on a
  // discrete GPU (tests run that path on PoCL with it).
  bool zero_copy = true;
  // Run the single-precision kernels even on a device with fp64 (tests: the fp32 path on PoCL).
  // The environment variable MCHEX_FORCE_FP32=1 does the same. A device without fp64 always
  // runs them.
  bool force_fp32 = false;
};

// Device time per kernel (from OpenCL profiling events) and host<->device transfer time.
struct OpenclProfile {
  struct Entry {
    std::uint64_t calls = 0;
    double seconds = 0;
  };
  std::map<std::string, Entry> kernels;  // by kernel name, plus "write" and "read"
};

class OpenclBackend : public DeviceBackend {
 public:
  // Throws InputError when no platform/device matches or none has fp64.
  explicit OpenclBackend(const OpenclOptions& options = {});
  ~OpenclBackend() override;
  OpenclBackend(const OpenclBackend&) = delete;
  OpenclBackend& operator=(const OpenclBackend&) = delete;

  const DeviceInfo& device() const override;

  // Whether the program came from the binary cache, and the cache file ("" when not caching).
  bool program_from_cache() const;
  const std::string& cache_file() const;
  const OpenclProfile& profile() const;
  void reset_profile();
  const Fp32Stats& fp32_stats() const;

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

// Every OpenCL platform and device (DeviceInfo::note says why one is unusable). Empty when no
// OpenCL platform is installed.
std::vector<DeviceInfo> list_opencl_devices();

}  // namespace mchex
