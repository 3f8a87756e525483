// The host half of the fp32 path (issue 7: "use fp64 where the device has it; where single
// precision could flip a sign or a case, the host re-decides those values in double"), shared by
// the opencl and vulkan backends. A device without fp64 (or any device, forced) runs
// kernels/sdf_fp32.h: single precision decides WHICH triangles can hold core's answer and returns
// them as a candidate record per point; this file turns the records into core/sdf/sdf.h SurfaceSdf's
// values in double, bit for bit, and evaluates the points the device gave up on with SurfaceSdf
// itself. The backends' other stages (analytic shapes, refinement error, classification) run on
// the host in double on this path: every operation of theirs decides its result.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "core/base/geometry.h"
#include "core/device/device_scene.h"
#include "core/mesh/surface.h"
#include "core/sdf/bvh.h"
#include "core/sdf/sdf.h"

namespace mchex {

// Whether MCHEX_FORCE_FP32 asks for the fp32 path (set, non-empty and not "0").
bool fp32_forced_by_environment();

// The fp32 path's division of work: points whose value the host computed from the device's
// candidate triangles, and points the host evaluated whole with core's SurfaceSdf: more than
// MCHEX_FP32_CANDIDATES candidates, or (budget_points, a subset) a search that ran out of its
// loop budget (kernels/sdf_fp32.h; only under llvmpipe's loop limit). Analytic shapes, refinement
// errors and classification run on the host in double on this path and are not counted here.
struct Fp32Stats {
  std::uint64_t points = 0, candidates = 0, host_points = 0, budget_points = 0;
};

// A point's record from kernels/sdf_fp32.h: kFp32RecordWords words, the count first, then the
// slots. A count of kFp32Candidates + 1 means too many candidates, kFp32Candidates + 2 that the
// search ran out of its loop budget.
inline constexpr std::size_t kFp32RecordWords = kFp32Candidates + 1;
inline constexpr std::uint32_t kFp32Overflow = kFp32Candidates + 1, kFp32OutOfBudget = kFp32Candidates + 2;

// What a device needs for kernels/sdf_fp32.h (buffer names of its header comment).
struct Fp32DeviceArrays {
  std::vector<BvhNode> nodes;
  std::vector<float> node_slack, slot_corners, slot_slack;
  float scale = 0;  // the surface's largest coordinate magnitude, rounded up to float
};

// One surface on the fp32 path: the arrays to upload (taken once), and what turns records into
// core's values. Keyed like the backends' scenes (core/device/backend.h SdfSource: the surface must not
// change while a backend holds it).
class Fp32Surface {
 public:
  explicit Fp32Surface(const TriangleSurface& surface);
  bool is_of(const TriangleSurface& surface) const;

  // The device arrays, moved out (empty afterwards): uploaded once, not kept twice.
  Fp32DeviceArrays take_device_arrays();

  // Values for a batch: record i (records[kFp32RecordWords * i ...]) belongs to the point
  // points[order[first + i]] (order empty: points[first + i]) and its value goes to the same
  // index of values. Counts into stats.
  void values_from_records(std::span<const Vec3> points, std::span<const std::uint32_t> order, std::size_t first,
                           std::span<const std::uint32_t> records, std::span<double> values, Fp32Stats& stats);

 private:
  const TriangleSurface* surface_;
  const void* vertices_;
  const void* triangles_;
  std::size_t num_vertices_, num_triangles_;
  Fp32DeviceArrays arrays_;
  std::vector<std::uint32_t> slot_triangle_;
  Pseudonormals normals_;
  std::unique_ptr<SurfaceSdf> whole_;  // core's SDF for the points the device gave up on, made when first needed
};

}  // namespace mchex
