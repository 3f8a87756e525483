#include "host/backends/fp32_path.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <string>

#include "core/base/parallel.h"
#include "host/backends/device_front.h"

namespace mchex {

bool fp32_forced_by_environment() {
  const char* force = std::getenv("MCHEX_FORCE_FP32");
  return force && *force && std::string(force) != "0";
}

namespace {

// kernels/sdf_fp32.h's candidates -> core's value: SurfaceSdf's rule (least squared distance by
// core/sdf/sdf.h closest_point_on_triangle, the lowest triangle id among equal ones, the sign of the
// closest feature's pseudonormal) over the candidate triangles, which hold its answer.
double value_from_candidates(const TriangleSurface& s, const Pseudonormals& normals,
                             std::span<const std::uint32_t> slot_triangle, Vec3 p, const std::uint32_t* slots,
                             std::uint32_t count) {
  ClosestPoint best{p, std::numeric_limits<double>::infinity(), -1};
  std::uint32_t best_t = 0;
  for (std::uint32_t k = 0; k < count; ++k) {
    const std::uint32_t t = slot_triangle[slots[k]];
    const auto& tri = s.triangles[t];
    const ClosestPoint cp = closest_point_on_triangle(p, s.vertices[tri[0]], s.vertices[tri[1]], s.vertices[tri[2]]);
    if (cp.squared_distance < best.squared_distance || (cp.squared_distance == best.squared_distance && t < best_t)) {
      best = cp;
      best_t = t;
    }
  }
  return pseudonormal_signed_value(p, best.point, best.squared_distance, normals.of(best_t, best.region, s));
}

}  // namespace

Fp32Surface::Fp32Surface(const TriangleSurface& s)
    : surface_(&s),
      vertices_(s.vertices.data()),
      triangles_(s.triangles.data()),
      num_vertices_(s.vertices.size()),
      num_triangles_(s.triangles.size()),
      normals_(s) {
  DeviceScene d = DeviceScene::build(s, DeviceScene::Search::kFp32);
  DeviceScene32 d32 = DeviceScene32::build(d);
  arrays_.node_slack = std::move(d32.node_slack);
  arrays_.slot_corners = std::move(d32.slot_corners);
  arrays_.slot_slack = std::move(d32.slot_slack);
  arrays_.nodes = std::move(d.nodes);
  // Rounded up, so that the kernel's W bounds every coordinate magnitude.
  arrays_.scale = std::nextafter(float(d.scale), INFINITY);
  slot_triangle_ = std::move(d.slot_triangle);
}

bool Fp32Surface::is_of(const TriangleSurface& s) const {
  return surface_ == &s && vertices_ == s.vertices.data() && triangles_ == s.triangles.data() &&
         num_vertices_ == s.vertices.size() && num_triangles_ == s.triangles.size();
}

Fp32DeviceArrays Fp32Surface::take_device_arrays() {
  Fp32DeviceArrays out = std::move(arrays_);
  arrays_ = Fp32DeviceArrays{};
  arrays_.scale = out.scale;
  return out;
}

void Fp32Surface::values_from_records(std::span<const Vec3> points, std::span<const std::uint32_t> order,
                                      std::size_t first, std::span<const std::uint32_t> records,
                                      std::span<double> values, Fp32Stats& stats) {
  const std::size_t count = records.size() / kFp32RecordWords;
  auto index = [&](std::size_t i) { return order.empty() ? first + i : std::size_t(order[first + i]); };
  std::vector<std::size_t> whole;  // points the host evaluates with SurfaceSdf
  for (std::size_t i = 0; i < count; ++i) {
    const std::uint32_t c = records[kFp32RecordWords * i];
    if (c > kFp32Candidates) {
      whole.push_back(index(i));
      stats.budget_points += c == kFp32OutOfBudget;
    } else {
      stats.candidates += c;
    }
  }
  parallel_for(count, [&](std::size_t i) {
    const std::uint32_t c = records[kFp32RecordWords * i];
    if (c > kFp32Candidates) return;
    const std::size_t j = index(i);
    values[j] =
        value_from_candidates(*surface_, normals_, slot_triangle_, points[j], &records[kFp32RecordWords * i + 1], c);
  });
  stats.points += count;
  stats.host_points += whole.size();
  host_values_at(whole_, *surface_, points, whole, values);
}

}  // namespace mchex
