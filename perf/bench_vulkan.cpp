// The vulkan backend's kernels against the cpu reference (core/, TBB threads) in one run:
// refinement error per cell, MC33 classification + prefix sum per cell, and the SDF of an
// analytic shape and of a triangle model at the points of a grid. Timings are ratios within the
// run (the machine is shared); the first vulkan call of each kernel is timed apart ("cold":
// lavapipe JIT-compiles a shader at its first dispatch). Also says where the vulkan time goes
// (host copies in, dispatches, copies out). Prints a table and one JSON line.
//   bench_vulkan [--cells N] [--grid N] [--segments S] [--device NAME]
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include <tbb/info.h>

#include "core/grid.h"
#include "core/hex_complex.h"
#include "core/mc33.h"
#include "core/parallel.h"
#include "core/refinement_error.h"
#include "core/sdf.h"
#include "core/shapes.h"
#include "host/backend_vulkan.h"
#include "perf/bench_common.h"

using namespace mchex;
using bench::seconds_of;

namespace {

struct Row {
  std::string kernel;
  std::size_t items = 0;
  double cpu = 0, vulkan_cold = 0, vulkan = 0;
  VulkanBackend::Profile profile;
};

VulkanBackend::Profile minus(VulkanBackend::Profile a, VulkanBackend::Profile b) {
  return {a.upload - b.upload, a.device - b.device, a.download - b.download};
}

// Best of a few runs (the machine is shared: the minimum is the least disturbed).
template <class F>
double best_of(int runs, F&& f) {
  double best = 1e300;
  for (int i = 0; i < runs; ++i) best = std::min(best, seconds_of(f));
  return best;
}

}  // namespace

int main(int argc, char** argv) {
  std::size_t cells = 2'000'000;
  int grid = 60, segments = 256;
  VulkanOptions options;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--cells")) cells = std::stoul(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--grid")) grid = std::stoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--segments")) segments = std::stoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--device")) options.device = argv[i + 1];
  }
  VulkanBackend vk(options);
  std::vector<Row> rows;
  bool equal = true;

  // Refinement error: smooth fields in random cells (a sphere's distance).
  {
    const std::size_t n = cells / 8;
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> u(-1, 1);
    std::vector<std::array<double, kChildLatticePoints>> lattice(n);
    std::vector<double> sizes(n), ref(n), dev(n);
    for (std::size_t i = 0; i < n; ++i) {
      const double h = 0.05, cx = u(rng), cy = u(rng), cz = u(rng);
      for (int c = 0; c < 4; ++c)
        for (int b = 0; b < 4; ++b)
          for (int a = 0; a < 4; ++a) {
            const double x = cx + h * a / 3, y = cy + h * b / 3, z = cz + h * c / 3;
            lattice[i][child_lattice_index(a, b, c)] = 0.8 - std::sqrt(x * x + y * y + z * z);
          }
      sizes[i] = h;
    }
    Row r;
    r.kernel = "refinement_error";
    r.items = n;
    r.cpu = best_of(3, [&] { parallel_for(n, [&](std::size_t i) { ref[i] = refinement_error(lattice[i], sizes[i]); }); });
    r.vulkan_cold = seconds_of([&] { vk.refinement_error(lattice, sizes, dev); });
    const auto p0 = vk.profile();
    r.vulkan = best_of(3, [&] { vk.refinement_error(lattice, sizes, dev); });
    r.profile = minus(vk.profile(), p0);
    for (std::size_t i = 0; i < n; ++i) equal = equal && std::bit_cast<std::uint64_t>(ref[i]) == std::bit_cast<std::uint64_t>(dev[i]);
    rows.push_back(r);
  }

  // MC33 classification + prefix sum on a uniform grid's cells with a noisy sphere field.
  {
    int depth = 1;
    while (std::size_t(std::pow(3, depth + 1)) * std::size_t(std::pow(3, depth + 1)) * std::size_t(std::pow(3, depth + 1)) <= cells) ++depth;
    const UniformGrid g(Box{{-1, -1, -1}, {1, 1, 1}}, depth);
    const HexComplex complex = uniform_complex(g);
    std::mt19937_64 rng(2);
    std::uniform_real_distribution<double> u(-0.3, 0.3);
    std::vector<double> values(complex.points.size());
    for (std::size_t i = 0; i < values.size(); ++i) {
      const Vec3 p = complex.points[i];
      values[i] = 0.7 - std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z) + u(rng);
    }
    const std::size_t n = complex.cells.size();
    std::vector<CellCode> ref(n), dev(n);
    std::vector<std::uint64_t> ref_off(n + 1), dev_off(n + 1);
    std::vector<std::uint32_t> counts(n);
    Row r;
    r.kernel = "classify+scan";
    r.items = n;
    r.cpu = best_of(3, [&] {
      parallel_for(n, [&](std::size_t i) {
        std::array<double, 8> f;
        for (int c = 0; c < 8; ++c) f[c] = values[complex.cells[i][c]];
        const CellClass k = classify(f);
        ref[i] = CellCode{k.subcase, k.sign_mask, k.face_joins, k.tunnel, k.symmetry, std::uint8_t(k.inverted), k.cut_edges};
        counts[i] = 8 + 2 * std::popcount(k.cut_edges);
      });
      ref_off[0] = 0;
      for (std::size_t i = 0; i < n; ++i) ref_off[i + 1] = ref_off[i] + counts[i];
    });
    r.vulkan_cold = seconds_of([&] { vk.classify_cells(complex, values, dev, dev_off); });
    const auto p0 = vk.profile();
    r.vulkan = best_of(3, [&] { vk.classify_cells(complex, values, dev, dev_off); });
    r.profile = minus(vk.profile(), p0);
    equal = equal && ref == dev && ref_off == dev_off;
    rows.push_back(r);
  }

  // SDF at the points of a grid: an analytic shape, then a tessellated torus.
  auto sdf_row = [&](const std::string& name, const SdfSource& source, const SignedDistance& reference) {
    const Box cube = padded_cube(reference.bounds(), 0.1);
    std::vector<Vec3> pts;
    for (int k = 0; k < grid; ++k)
      for (int j = 0; j < grid; ++j)
        for (int i = 0; i < grid; ++i)
          pts.push_back(cube.lo + Vec3{cube.size().x * i / (grid - 1), cube.size().y * j / (grid - 1),
                                       cube.size().z * k / (grid - 1)});
    std::vector<double> ref(pts.size()), dev(pts.size());
    Row r;
    r.kernel = name;
    r.items = pts.size();
    r.cpu = best_of(3, [&] { reference.evaluate(pts, ref); });
    r.vulkan_cold = seconds_of([&] { vk.signed_distance(source, pts, dev); });
    const auto p0 = vk.profile();
    r.vulkan = best_of(3, [&] { vk.signed_distance(source, pts, dev); });
    r.profile = minus(vk.profile(), p0);
    for (std::size_t i = 0; i < pts.size(); ++i)
      equal = equal && std::bit_cast<std::uint64_t>(ref[i]) == std::bit_cast<std::uint64_t>(dev[i]);
    rows.push_back(r);
  };
  {
    const ShapeSdf shape(ShapeKind::kTorus);
    SdfSource source;
    source.shape = ShapeKind::kTorus;
    sdf_row("sdf torus (analytic)", source, shape);
  }
  {
    const TriangleSurface surface = tessellate(ShapeKind::kTorus, segments);
    const SurfaceSdf reference(surface);
    SdfSource source;
    source.surface = &surface;
    sdf_row("sdf torus (" + std::to_string(surface.triangles.size()) + " triangles)", source, reference);
  }

  std::printf("vulkan device: %s (%s); cpu reference on %d threads\n", vk.device().name.c_str(),
              vk.device().platform.c_str(), tbb::info::default_concurrency());
  std::printf("%-34s %10s %10s %10s %10s %8s | %8s %8s %8s\n", "kernel", "items", "cpu s", "vk cold s",
              "vk s", "vk/cpu", "upload", "device", "download");
  std::string json = "{\"bench\":\"vulkan\",\"device\":\"" + vk.device().name + "\",\"equal\":" +
                     (equal ? "true" : "false") + ",\"pipeline_seconds\":" + std::to_string(vk.pipeline_seconds()) +
                     ",\"kernels\":[";
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const Row& r = rows[i];
    const double runs = 3;  // the profile covers the 3 timed runs
    std::printf("%-34s %10zu %10.4f %10.4f %10.4f %8.2f | %8.4f %8.4f %8.4f\n", r.kernel.c_str(), r.items,
                r.cpu, r.vulkan_cold, r.vulkan, r.vulkan / r.cpu, r.profile.upload / runs,
                r.profile.device / runs, r.profile.download / runs);
    json += (i ? "," : "") + std::string("{\"kernel\":\"") + r.kernel + "\",\"items\":" + std::to_string(r.items) +
            ",\"cpu_s\":" + std::to_string(r.cpu) + ",\"vulkan_cold_s\":" + std::to_string(r.vulkan_cold) +
            ",\"vulkan_s\":" + std::to_string(r.vulkan) + ",\"ratio_vulkan_over_cpu\":" +
            std::to_string(r.vulkan / r.cpu) + ",\"upload_s\":" + std::to_string(r.profile.upload / runs) +
            ",\"device_s\":" + std::to_string(r.profile.device / runs) +
            ",\"download_s\":" + std::to_string(r.profile.download / runs) + "}";
  }
  json += "]}";
  std::printf("results equal to the cpu reference bit for bit: %s\n%s\n", equal ? "yes" : "NO", json.c_str());
  return equal ? 0 : 1;
}
