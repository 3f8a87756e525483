// Kernel throughput of every backend side by side (cpu reference, opencl, vulkan), as ratios to
// the cpu reference measured in the same run (the machine is shared and noisy: only ratios within
// one run compare), each result checked equal to the cpu's bit for bit. And where the time goes:
//   opencl  device time per kernel (OpenCL profiling events), host->device writes and
//           device->host reads, the rest being host-side work (argument checks, decoding,
//           chunking) and launch latency;
//   vulkan  host copies into mapped buffers, dispatches (submit to fence) and copies back out
//           (with decoding); its first call per kernel is timed apart ("cold": lavapipe
//           JIT-compiles a shader at its first dispatch).
//
//   bench_backends [--grid N] [--segments S] [--depth D] [--repeat R] [--platform NAME]
//                  [--vulkan-device NAME] [--backends cpu,opencl,vulkan] [--kernels K1,K2,...]
//   (backends also opencl-fp32, vulkan-fp32: the forced single-precision path; vulkan-subgroup:
//   the surface SDF's subgroup-shared walk instead of the default one walk per invocation)
//
// Workloads: surface SDF at the N^3 points of a grid over the tessellated torus (2 S x 0.4 S
// triangles; S = 256 gives 52,224), analytic-shape SDF (torus) on the same points, refinement
// error of 100,000 cells of the two-holed shape, and MC33 classification + hex prefix sum of the
// uniform depth-D complex of the two-holed shape (depth 4: 531,441 cells; 5: 14,348,907) in three
// forms: "classify+scan" the mesher's call (subcase bytes and offsets from the raw values, zero
// rule and corner ids on the device), "classify+scan codes" every field of every cell decoded from
// the words (the tests' call, corner list uploaded), and "sdf+classify" the shape's SDF at the
// complex's points followed by classification from the values the SDF left on the device.
// --kernels picks some of these by name. Prints a table and one JSON line.
#include <algorithm>
#include <bit>
#include <cstdio>
#include <cstring>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/cutting/mchex_mesher.h"
#include "core/device/backend.h"
#include "core/grid/grid.h"
#include "core/grid/hex_complex.h"
#include "core/grid/refinement_error.h"
#include "core/sdf/shapes.h"
#include "host/backends/cpu.h"
#if MCHEX_WITH_OPENCL
#include "host/backends/opencl.h"
#endif
#if MCHEX_WITH_VULKAN
#include "host/backends/vulkan.h"
#endif
#include "core/base/parallel.h"
#include "perf/bench_common.h"

using namespace mchex;
using bench::seconds_of;

namespace {

struct Workloads {
  TriangleSurface surface;
  std::vector<Vec3> points;
  std::vector<std::array<double, kChildLatticePoints>> lattice;
  std::vector<double> sizes;
  HexComplex complex;
  std::vector<double> values;
};

// What one backend's run of one kernel gave.
struct Measured {
  double cold = 0;  // first call
  double best = 0;  // best of the repeats (the least disturbed by other users of the machine)
  bool equal = true;
  std::map<std::string, double> profile;  // part -> seconds of the best run
};

// The outputs of one kernel run, to compare with the cpu's.
struct Outputs {
  std::vector<double> doubles;
  std::vector<CellCode> codes;
  std::vector<std::uint8_t> subcases;
  std::vector<std::uint64_t> offsets;
  bool operator==(const Outputs& o) const {
    if (doubles.size() != o.doubles.size()) return false;
    for (std::size_t i = 0; i < doubles.size(); ++i)
      if (std::bit_cast<std::uint64_t>(doubles[i]) != std::bit_cast<std::uint64_t>(o.doubles[i])) return false;
    return codes == o.codes && subcases == o.subcases && offsets == o.offsets;
  }
};

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string part; std::getline(in, part, ',');) out.push_back(part);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  int grid = 82, segments = 256, depth = 4, repeat = 3;
  std::string platform, vulkan_device, wanted = "cpu,opencl,vulkan", only;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--grid") grid = std::atoi(argv[i + 1]);
    else if (a == "--segments") segments = std::atoi(argv[i + 1]);
    else if (a == "--depth") depth = std::atoi(argv[i + 1]);
    else if (a == "--repeat") repeat = std::atoi(argv[i + 1]);
    else if (a == "--platform") platform = argv[i + 1];
    else if (a == "--vulkan-device") vulkan_device = argv[i + 1];
    else if (a == "--backends") wanted = argv[i + 1];
    else if (a == "--kernels") only = argv[i + 1];
    else {
      std::fprintf(stderr, "bench_backends: unknown option %s\n", argv[i]);
      return 1;
    }
  }

  Workloads w;
  w.surface = tessellate(ShapeKind::kTorus, segments);
  {
    const Box cube = padded_cube(w.surface.bounds(), 0.1);
    const Vec3 s = cube.size();
    for (int k = 0; k < grid; ++k)
      for (int j = 0; j < grid; ++j)
        for (int i = 0; i < grid; ++i)
          w.points.push_back(cube.lo + Vec3{s.x * i / (grid - 1), s.y * j / (grid - 1), s.z * k / (grid - 1)});
  }
  const ShapeSdf two_holed(ShapeKind::kTwoHoled);
  {
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> pos(-1.4, 1.1);
    for (int c = 0; c < 100000; ++c) {
      const Vec3 lo{pos(rng), pos(rng) * 0.7, pos(rng) * 0.3};
      const double h = 0.02 + 0.1 * (rng() % 100) / 100.0;
      std::array<double, kChildLatticePoints> f;
      for (int z = 0; z < 4; ++z)
        for (int y = 0; y < 4; ++y)
          for (int x = 0; x < 4; ++x)
            f[child_lattice_index(x, y, z)] = two_holed(lo + Vec3{x * h / 3, y * h / 3, z * h / 3});
      w.lattice.push_back(f);
      w.sizes.push_back(h);
    }
  }
  const UniformGrid ugrid(padded_cube(two_holed.bounds(), 0.1), depth);
  const std::uint32_t uniform_n = ugrid.cells_per_axis();
  w.complex = uniform_complex(ugrid);
  w.values.resize(w.complex.points.size());
  two_holed.evaluate(w.complex.points, w.values);

  struct Named {
    std::string name;
    std::unique_ptr<Backend> backend;
  };
  std::vector<Named> backends;
#if MCHEX_WITH_OPENCL
  std::map<std::string, OpenclBackend*> ocls;
#endif
#if MCHEX_WITH_VULKAN
  std::map<std::string, VulkanBackend*> vks;
#endif
  nlohmann::json unavailable = nlohmann::json::object();
  for (const std::string& name : split(wanted)) {
    try {
      if (name == "cpu") {
        backends.push_back({name, make_cpu_backend()});
      } else if (name == "opencl" || name == "opencl-fp32") {
#if !MCHEX_WITH_OPENCL
        throw std::runtime_error("not built into this binary (-DMCHEX_WITH_OPENCL=OFF)");
#else
        // opencl-fp32: the single-precision path (kernels/sdf_fp32.h) forced on the same device.
        OpenclOptions o;
        o.platform = platform;
        o.force_fp32 = name == "opencl-fp32";
        auto b = std::make_unique<OpenclBackend>(o);
        ocls[name] = b.get();
        backends.push_back({name, std::move(b)});
#endif
      } else if (name == "vulkan" || name == "vulkan-subgroup" || name == "vulkan-fp32") {
#if !MCHEX_WITH_VULKAN
        throw std::runtime_error("not built into this binary (-DMCHEX_WITH_VULKAN=OFF)");
#else
        // vulkan-subgroup: the surface SDF's subgroup-shared walk forced (kernels/sdf.h), to
        // compare with the one walk per invocation that every device takes by default.
        VulkanOptions o;
        o.device = vulkan_device;
        if (name == "vulkan-subgroup") o.sdf_walk = VulkanOptions::SdfWalk::kSubgroup;
        o.force_fp32 = name == "vulkan-fp32";  // host/backends/fp32_path.h, as opencl-fp32
        auto b = std::make_unique<VulkanBackend>(o);
        vks[name] = b.get();
        backends.push_back({name, std::move(b)});
#endif
      } else {
        std::fprintf(stderr, "bench_backends: unknown backend %s\n", name.c_str());
        return 1;
      }
    } catch (const std::exception& e) {
      // A backend with no device here is reported, not fatal: the others still compare.
      std::printf("%s: not measured (%s)\n", name.c_str(), e.what());
      unavailable[name] = e.what();
    }
  }
  if (backends.empty() || backends.front().name != "cpu") {
    std::fprintf(stderr, "bench_backends: the cpu reference must come first (ratios are to it)\n");
    return 1;
  }

  const std::size_t n_points = w.points.size(), n_cells = w.complex.cells.size();
  std::vector<std::string> kernels = {"sdf_surface",   "sdf_shape",           "refinement_error",
                                      "classify+scan", "classify+scan codes", "sdf+classify"};
  if (!only.empty()) kernels = split(only);
  auto wanted_kernel = [&](const std::string& k) {
    return std::find(kernels.begin(), kernels.end(), k) != kernels.end();
  };
  const std::map<std::string, std::size_t> items = {
      {"sdf_surface", n_points},  {"sdf_shape", n_points},          {"refinement_error", w.lattice.size()},
      {"classify+scan", n_cells}, {"classify+scan codes", n_cells}, {"sdf+classify", n_cells}};
  std::map<std::string, std::map<std::string, Measured>> results;  // kernel -> backend -> measured
  std::map<std::string, Outputs> reference;                        // kernel -> cpu outputs
  for (auto& entry : backends) {
    // Named references, not a structured binding: clang 14 cannot capture one in a lambda.
    const std::string& name = entry.name;
    std::unique_ptr<Backend>& b = entry.backend;
    SdfSource surface;
    surface.surface = &w.surface;
    SdfSource shape;
    shape.shape = ShapeKind::kTorus;
    if (wanted_kernel("sdf_surface")) {
      // The device scene (BVH, pseudonormals) is built once per surface: not part of the rate.
      std::vector<double> out(16);
      b->signed_distance(surface, std::span(w.points).first(16), out);
    }
    // run(out) fills out, sizing its arrays with resize(): the cold run allocates them (fresh
    // pages, first touched by the kernel), the timed runs write into the same arrays, as a caller
    // that keeps its buffers would (allocating 130 MB of outputs for 14 M cells cost as much as
    // half the OpenCL classification). Both the cold run's output and the last run's must equal
    // the cpu reference's.
    auto measure = [&](const std::string& kernel, auto&& run) {
      Measured m;
      Outputs out;
      m.cold = seconds_of([&] { run(out); });
      const bool cold_equal = name == "cpu" || out == reference[kernel];
      m.best = 1e300;
      for (int r = 0; r < repeat; ++r) {
#if MCHEX_WITH_OPENCL
        OpenclBackend* ocl = ocls.count(name) ? ocls[name] : nullptr;
        if (ocl) ocl->reset_profile();
#endif
#if MCHEX_WITH_VULKAN
        VulkanBackend* vk = vks.count(name) ? vks[name] : nullptr;
        const VulkanBackend::Profile before = vk ? vk->profile() : VulkanBackend::Profile{};
        const Fp32Stats fp32_before = vk ? vk->fp32_stats() : Fp32Stats{};
#endif
        const double s = seconds_of([&] { run(out); });
        if (s >= m.best) continue;
        m.best = s;
        m.profile.clear();
#if MCHEX_WITH_OPENCL
        if (ocl) {
          for (const auto& [k, e] : ocl->profile().kernels) m.profile[k] = e.seconds;
          const Fp32Stats& st = ocl->fp32_stats();
          if (st.points) {
            m.profile["fp32: points the host evaluated whole (count)"] = double(st.host_points);
            m.profile["fp32: candidates per point (mean)"] = double(st.candidates) / double(st.points - st.host_points);
          }
        }
#endif
#if MCHEX_WITH_VULKAN
        if (vk) {
          const VulkanBackend::Profile after = vk->profile();
          m.profile["upload"] = after.upload - before.upload;
          m.profile["device"] = after.device - before.device;
          m.profile["download"] = after.download - before.download;
          if (after.host_points != before.host_points)
            m.profile["points past the loop budget, on the host (count)"] =
                double(after.host_points - before.host_points);
          const Fp32Stats st = vk->fp32_stats();
          if (const std::uint64_t points = st.points - fp32_before.points) {
            const std::uint64_t host = st.host_points - fp32_before.host_points;
            m.profile["fp32: points the host evaluated whole (count)"] = double(host);
            m.profile["fp32: of them past the loop budget (count)"] =
                double(st.budget_points - fp32_before.budget_points);
            m.profile["fp32: candidates per point (mean)"] =
                double(st.candidates - fp32_before.candidates) / double(points - host);
          }
        }
#endif
      }
      if (name == "cpu") reference[kernel] = out;
      else m.equal = cold_equal && out == reference[kernel];
      results[kernel][name] = m;
    };
    if (wanted_kernel("sdf_surface"))
      measure("sdf_surface", [&](Outputs& o) {
        o.doubles.resize(n_points);
        b->signed_distance(surface, w.points, o.doubles);
      });
    if (wanted_kernel("sdf_shape"))
      measure("sdf_shape", [&](Outputs& o) {
        o.doubles.resize(n_points);
        b->signed_distance(shape, w.points, o.doubles);
      });
    if (wanted_kernel("refinement_error"))
      measure("refinement_error", [&](Outputs& o) {
        o.doubles.resize(w.lattice.size());
        b->refinement_error(w.lattice, w.sizes, o.doubles);
      });
    // What the mesher needs (a subcase byte per cell and the offsets), from the raw SDF values with
    // the zero rule and the uniform grid's corner ids on the device: host/cli/main.cpp's call.
    ClassifyOptions co;
    co.zero_tolerance = zero_tolerance_of(w.complex);
    co.uniform_cells_per_axis = uniform_n;
    if (wanted_kernel("classify+scan"))
      measure("classify+scan", [&](Outputs& o) {
        o.subcases.resize(n_cells);
        o.offsets.resize(n_cells + 1);
        b->classify_cells(w.complex, w.values, {o.subcases, o.offsets}, co);
      });
    // Every field of every cell (the words, decoded), from the corner list: what the tests compare.
    if (wanted_kernel("classify+scan codes"))
      measure("classify+scan codes", [&](Outputs& o) {
        o.codes.resize(n_cells);
        o.offsets.resize(n_cells + 1);
        classify_cells_codes(*b, w.complex, w.values, o.codes, o.offsets, {co.zero_tolerance, 0, false});
      });
    // The SDF of the analytic shape at the complex's points, then classification from the values
    // the SDF left on the device (ClassifyOptions::values_from_last_sdf): the whole device part of
    // `mesh --shape two-holed --method mchex`.
    if (wanted_kernel("sdf+classify"))
      measure("sdf+classify", [&](Outputs& o) {
        std::vector<double> v(w.complex.points.size());
        SdfSource two;
        two.shape = ShapeKind::kTwoHoled;
        b->signed_distance(two, w.complex.points, v);
        ClassifyOptions resident = co;
        resident.values_from_last_sdf = true;
        o.subcases.resize(n_cells);
        o.offsets.resize(n_cells + 1);
        b->classify_cells(w.complex, v, {o.subcases, o.offsets}, resident);
      });
  }

  std::printf("bench_backends: %zu surface triangles, %zu points, %zu refinement cells, %zu MC cells, %d CPU threads\n",
              w.surface.triangles.size(), n_points, w.lattice.size(), n_cells, hardware_threads());
  nlohmann::json j = {
      {"bench", "backends"},       {"triangles", w.surface.triangles.size()}, {"points", n_points},
      {"mc_cells", n_cells},       {"refinement_cells", w.lattice.size()},    {"threads", hardware_threads()},
      {"unavailable", unavailable}};
  for (auto& [name, b] : backends) {
    std::printf("%-7s %s / %s\n", name.c_str(), b->device().platform.c_str(), b->device().name.c_str());
    j["devices"][name] = b->device().platform + " / " + b->device().name;
  }
#if MCHEX_WITH_VULKAN
  for (const auto& [name, vk] : vks) j[name + "_pipeline_seconds"] = vk->pipeline_seconds();
#endif

  // Rates in M items/s; "x cpu" is the backend's time over the cpu's (the targets: SDF
  // within 2x on PoCL, 4x on lavapipe).
  std::printf("\n%-17s %9s %9s", "kernel", "items", "cpu M/s");
  for (std::size_t k = 1; k < backends.size(); ++k)
    std::printf(" | %7s M/s %7s %8s", backends[k].name.c_str(), "x cpu", "cold s");
  std::printf("\n");
  bool all_equal = true;
  for (const std::string& kernel : kernels) {
    auto& r = results[kernel];
    const double cpu = r["cpu"].best;
    std::printf("%-17s %9zu %9.3f", kernel.c_str(), items.at(kernel), items.at(kernel) / cpu / 1e6);
    j["items"][kernel] = items.at(kernel);
    for (auto& [name, b] : backends) {
      const Measured& m = r[name];
      j["seconds"][kernel][name] = m.best;
      j["cold_seconds"][kernel][name] = m.cold;
      j["rate_per_s"][kernel][name] = items.at(kernel) / m.best;
      if (name == "cpu") continue;
      j["time_ratio_to_cpu"][kernel][name] = m.best / cpu;
      j["equal_to_cpu"][kernel][name] = m.equal;
      all_equal = all_equal && m.equal;
      std::printf(" | %11.3f %7.2f %8.3f%s", items.at(kernel) / m.best / 1e6, m.best / cpu, m.cold,
                  m.equal ? "" : " DIFFERS");
      // Points a device handed back to the host (loop budget, fp32 overflow) make its time partly
      // the cpu's: say so where they are more than 1 % of the items.
      for (const auto& [part, v] : m.profile)
        if (part.find("on the host (count)") != std::string::npos ||
            part.find("evaluated whole (count)") != std::string::npos)
          if (v > 0.01 * double(items.at(kernel)))
            std::printf(" (%.0f %% on the host)", 100 * v / double(items.at(kernel)));
    }
    std::printf("\n");
  }

  for (auto& [name, b] : backends) {
    if (name == "cpu") continue;
    std::printf("\n%s: where the time goes (seconds of the best run)\n", name.c_str());
    for (const std::string& kernel : kernels) {
      const Measured& m = results[kernel][name];
      std::printf("  %-17s wall %.4f:", kernel.c_str(), m.best);
      double accounted = 0;
      for (const auto& [part, s] : m.profile) {
        std::printf(" %s %.4f", part.c_str(), s);
        const bool count = part.find("(count)") != std::string::npos || part.find("(mean)") != std::string::npos;
        if (!count) accounted += s;
      }
      std::printf("  | host-side and launch %.4f\n", m.best - accounted);
      j["profile_s"][name][kernel] = m.profile;
      j["profile_s"][name][kernel]["wall"] = m.best;
    }
  }
  j["equal"] = all_equal;
  std::printf("\nresults equal to the cpu reference bit for bit: %s\n%s\n", all_equal ? "yes" : "NO", j.dump().c_str());
  return all_equal ? 0 : 1;
}
