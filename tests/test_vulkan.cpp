// The vulkan backend against the cpu reference, really run on Mesa lavapipe (selected
// explicitly: its ICD is the only one the loader sees in this process, and the device is picked
// by name). No lavapipe means these tests FAIL; they never skip.
//
// Every comparison is exact: SDF values and refinement errors bit for bit, CellCodes field for
// field, offsets equal. Inputs are random and adversarial (every sign pattern with random, tied
// and guard-band magnitudes; points on triangles, edges and vertices and far away), and the
// chunked paths are forced with a small chunk size.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <glob.h>
#include <limits>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/grid/grid.h"
#include "core/grid/hex_complex.h"
#include "core/cutting/local_refinement.h"
#include "core/cutting/mc33.h"
#include "core/cutting/mchex_mesher.h"
#include "core/grid/refinement_error.h"
#include "core/sdf/sdf.h"
#include "core/sdf/shapes.h"
#include "core/mesh/surface.h"
#include "tests/backend_samples.h"
#include "host/backends/cpu.h"
#include "host/backends/vulkan.h"
#include "host/backends/vk_context.h"
#include "host/backends/vk_spirv.h"

namespace fs = std::filesystem;
using namespace mchex;

namespace {

// The scratch folder of this test process: the pipeline cache and Mesa's shader cache live here,
// so runs never depend on (or fill) the user's caches.
fs::path scratch() {
  static const fs::path dir = [] {
    fs::path d = fs::temp_directory_path() / ("mchex-test-vulkan-" + std::to_string(::getpid()));
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
  }();
  return dir;
}

// Before any Vulkan call: only lavapipe's ICD, Mesa's caches in the scratch folder.
class LavapipeEnvironment : public ::testing::Environment {
 public:
  void SetUp() override {
    glob_t g{};
    std::string icd;
    if (::glob("/usr/share/vulkan/icd.d/lvp_icd.*.json", 0, nullptr, &g) == 0 && g.gl_pathc > 0)
      icd = g.gl_pathv[0];
    globfree(&g);
    // An empty VK_DRIVER_FILES would let the loader take every ICD; the device-name check in
    // lavapipe() still fails the tests then.
    ::setenv("VK_DRIVER_FILES", icd.c_str(), 1);
    ::setenv("VK_ICD_FILENAMES", icd.c_str(), 1);  // loaders before 1.3.207 read this name
    ::setenv("MESA_SHADER_CACHE_DIR", (scratch() / "mesa").c_str(), 1);
    ::unsetenv("MCHEX_VULKAN_DEVICE");
    ::unsetenv("MCHEX_FORCE_FP32");  // the fp64 tests run fp64; the fp32 ones ask for it
  }
  void TearDown() override { fs::remove_all(scratch()); }
};
const auto* const kEnvironment = ::testing::AddGlobalTestEnvironment(new LavapipeEnvironment);

VulkanOptions lavapipe_options(std::size_t max_chunk = 0, fs::path cache = scratch() / "pipelines") {
  VulkanOptions o;
  o.device = "llvmpipe";
  o.cache_dir = std::move(cache);
  o.max_chunk = max_chunk;
  return o;
}

VulkanBackend& lavapipe() {
  static VulkanBackend backend(lavapipe_options());
  return backend;
}

// The surface SDF's shaders on lavapipe: the subgroup walk (kernels/sdf.h), one walk per
// invocation reading texel buffers (lavapipe's default) and the same reading storage buffers (the
// fallback for devices without subgroup arithmetic, scenes over maxTexelBufferElements, and GPUs).
struct SdfVariant {
  const char* name;
  VulkanBackend& backend;
};
std::vector<SdfVariant> sdf_variants() {
  auto make = [](VulkanOptions::SdfWalk walk, bool storage) {
    VulkanOptions o = lavapipe_options();
    o.sdf_walk = walk;
    o.sdf_storage_reads = storage;
    return o;
  };
  static VulkanBackend subgroup(make(VulkanOptions::SdfWalk::kSubgroup, false));
  static VulkanBackend single(make(VulkanOptions::SdfWalk::kSingle, false));
  static VulkanBackend storage(make(VulkanOptions::SdfWalk::kSingle, true));
  return {{"subgroup walk", subgroup}, {"single walk, texel reads", single}, {"single walk, storage reads", storage}};
}

std::uint64_t bits(double x) { return std::bit_cast<std::uint64_t>(x); }

// A complex whose cells own their 8 points, so each cell's values are set independently.
HexComplex separate_cells(std::size_t cells) {
  HexComplex c;
  c.points.resize(8 * cells);
  c.cells.resize(cells);
  for (std::size_t i = 0; i < cells; ++i)
    for (int k = 0; k < 8; ++k) c.cells[i][k] = static_cast<std::uint32_t>(8 * i + k);
  return c;
}

void expect_same_as_reference(const HexComplex& complex, const std::vector<double>& values,
                              const std::vector<CellCode>& codes,
                              const std::vector<std::uint64_t>& offsets) {
  ASSERT_EQ(codes.size(), complex.cells.size());
  ASSERT_EQ(offsets.size(), complex.cells.size() + 1);
  std::uint64_t total = 0;
  int wrong = 0;
  for (std::size_t i = 0; i < complex.cells.size() && wrong < 5; ++i) {
    std::array<double, 8> f;
    for (int c = 0; c < 8; ++c) f[c] = values[complex.cells[i][c]];
    const CellClass r = classify(f);
    const CellCode& g = codes[i];
    const bool same = g.subcase == r.subcase && g.sign_mask == r.sign_mask &&
                      g.face_joins == r.face_joins && g.tunnel == r.tunnel &&
                      g.symmetry == r.symmetry && (g.inverted != 0) == r.inverted &&
                      g.cut_edges == r.cut_edges && offsets[i] == total;
    if (!same) {
      ++wrong;
      ADD_FAILURE() << "cell " << i << ": device subcase " << int(g.subcase) << " mask " << int(g.sign_mask)
                    << " faces " << int(g.face_joins) << " tunnel " << int(g.tunnel) << " symmetry "
                    << int(g.symmetry) << " inverted " << int(g.inverted) << " cut " << g.cut_edges
                    << " offset " << offsets[i] << "; reference " << int(r.subcase) << " "
                    << int(r.sign_mask) << " " << int(r.face_joins) << " " << int(r.tunnel) << " "
                    << int(r.symmetry) << " " << r.inverted << " " << r.cut_edges << " " << total;
    }
    total += static_cast<std::uint64_t>(local_refinement_hexes(r.subcase));  // the mesher's count
  }
  if (wrong == 0) {
    EXPECT_EQ(offsets.back(), total);
  }
}

struct Classified {
  std::vector<CellCode> codes;
  std::vector<std::uint64_t> offsets;
};

Classified run_classify(Backend& b, const HexComplex& complex, const std::vector<double>& values) {
  Classified out{std::vector<CellCode>(complex.cells.size()),
                 std::vector<std::uint64_t>(complex.cells.size() + 1)};
  classify_cells_codes(b, complex, values, out.codes, out.offsets);
  return out;
}

// Every sign pattern, each with several magnitude rules: random, all equal (every face test a
// tie), powers of two (exact products: ties and near-ties of the asymptotic decider), values at
// the zero tolerance of the mesher's zero rule (1e-10 of the cell size) mixed with O(1) ones, and
// magnitudes spread over many decades.
std::vector<double> adversarial_values(std::size_t& cells, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(1e-3, 1.0);
  std::uniform_int_distribution<int> pow2(-3, 3), decade(-12, 2), coin(0, 1);
  std::vector<double> v;
  for (int mask = 0; mask < 256; ++mask)
    for (int rule = 0; rule < 5; ++rule)
      for (int rep = 0; rep < (rule == 1 ? 1 : 24); ++rep)
        for (int c = 0; c < 8; ++c) {
          double m = 1;
          switch (rule) {
            case 0: m = unit(rng); break;
            case 1: m = 1; break;
            case 2: m = std::ldexp(1.0, pow2(rng)); break;
            case 3: m = coin(rng) ? 1e-10 : unit(rng); break;
            case 4: m = std::pow(10.0, decade(rng)) * unit(rng); break;
          }
          v.push_back((mask >> c & 1) ? m : -m);
        }
  cells = v.size() / 8;
  return v;
}

}  // namespace

TEST(vulkan, LavapipeIsListedWithItsLimits) {
  const std::vector<DeviceInfo> devices = list_vulkan_devices();
  auto it = std::find_if(devices.begin(), devices.end(),
                         [](const DeviceInfo& d) { return d.name.find("llvmpipe") != std::string::npos; });
  ASSERT_NE(it, devices.end()) << "lavapipe (llvmpipe) not found: setup.sh installs mesa-vulkan-drivers";
  EXPECT_EQ(it->backend, "vulkan");
  EXPECT_EQ(it->type, "cpu");
  EXPECT_TRUE(it->fp64);
  EXPECT_GE(it->max_buffer_bytes, 1u << 20);
  const std::vector<std::string> lines = describe_vulkan_devices();
  ASSERT_FALSE(lines.empty());
  EXPECT_NE(lines[0].find("maxStorageBufferRange"), std::string::npos) << lines[0];
  EXPECT_NE(lines[0].find("shaderFloat64 yes"), std::string::npos) << lines[0];
  EXPECT_EQ(lavapipe().device().name, it->name);
}

TEST(vulkan, AbsentDeviceIsOneClearInputError) {
  VulkanOptions o = lavapipe_options();
  o.device = "no-such-device";
  try {
    VulkanBackend b(o);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no-such-device"), std::string::npos) << e.what();
  }
}

TEST(vulkan, RefinementErrorIsBitIdenticalToTheReference) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<std::array<double, kChildLatticePoints>> lattice;
  std::vector<double> sizes;
  auto add = [&](auto&& value, double size) {
    std::array<double, kChildLatticePoints> f;
    for (int c = 0; c < 4; ++c)
      for (int b = 0; b < 4; ++b)
        for (int a = 0; a < 4; ++a) f[child_lattice_index(a, b, c)] = value(a / 3.0, b / 3.0, c / 3.0);
    lattice.push_back(f);
    sizes.push_back(size);
  };
  for (int i = 0; i < 3000; ++i) {
    // A sphere's distance in a random cell (smooth), a random field (rough), a trilinear field
    // (error 0 up to rounding), a constant (0), and flat parents with a bump (infinite error).
    const double size = std::ldexp(1.0, -(i % 7)) * (0.5 + 0.5 * std::abs(u(rng)));
    const double cx = u(rng), cy = u(rng), cz = u(rng);
    add([&](double x, double y, double z) {
      return 0.7 - std::sqrt((cx + size * x) * (cx + size * x) + (cy + size * y) * (cy + size * y) +
                             (cz + size * z) * (cz + size * z));
    }, size);
    add([&](double, double, double) { return u(rng); }, size);
    const double a = u(rng), b = u(rng), c = u(rng), d = u(rng);
    add([&](double x, double y, double z) { return a + b * x + c * y * z + d * x * y * z; }, size);
    add([&](double, double, double) { return cx; }, size);
    add([&](double x, double y, double z) { return (x > 0 && x < 1 && y > 0 && y < 1 && z > 0 && z < 1) ? cy : cx; },
        size);
  }
  std::vector<double> device(lattice.size());
  lavapipe().refinement_error(lattice, sizes, device);
  int infinite = 0;
  for (std::size_t i = 0; i < lattice.size(); ++i) {
    const double ref = refinement_error(lattice[i], sizes[i]);
    ASSERT_EQ(bits(device[i]), bits(ref)) << "cell " << i << ": " << device[i] << " vs " << ref;
    infinite += std::isinf(ref);
  }
  EXPECT_GT(infinite, 0);  // the zero-gradient rule was exercised

  // Chunked: 97 cells per dispatch gives the same bits.
  VulkanBackend small(lavapipe_options(97));
  std::vector<double> chunked(lattice.size());
  const std::size_t before = small.dispatches();
  small.refinement_error(lattice, sizes, chunked);
  EXPECT_EQ(small.dispatches() - before, (lattice.size() + 96) / 97);
  for (std::size_t i = 0; i < lattice.size(); ++i) ASSERT_EQ(bits(chunked[i]), bits(device[i])) << i;
}

TEST(vulkan, ClassifyEverySignPatternWithRandomTiedAndGuardBandMagnitudes) {
  std::mt19937_64 rng(11);
  std::size_t cells = 0;
  const std::vector<double> values = adversarial_values(cells, rng);
  const HexComplex complex = separate_cells(cells);
  const Classified got = run_classify(lavapipe(), complex, values);
  expect_same_as_reference(complex, values, got.codes, got.offsets);
  std::set<int> masks;
  for (const CellCode& c : got.codes) masks.insert(c.sign_mask);
  EXPECT_EQ(masks.size(), 256u);
}

// The crossing parameters (ClassifyOptions' `crossings`): core's f_a / (f_a - f_b) bit for bit on
// every cut edge of the adversarial sign patterns, and on the uniform grid with the zero rule
// applied on the device, whole and in chunks.
TEST(vulkan, ClassifyCrossingParametersAreCoresBitForBit) {
  std::mt19937_64 rng(12);
  std::size_t cells = 0;
  const std::vector<double> values = adversarial_values(cells, rng);
  EXPECT_GT(test::expect_crossings_are_cores(lavapipe(), separate_cells(cells), values), 20000u);
  const test::ZeroRuleGrid z = test::zero_rule_grid();
  const ClassifyOptions co = z.options();
  EXPECT_GT(test::expect_crossings_are_cores(lavapipe(), z.complex, z.values, co), 1000u);
  VulkanBackend chunked(lavapipe_options(1000));
  EXPECT_GT(test::expect_crossings_are_cores(chunked, z.complex, z.values, co), 1000u);
}

TEST(vulkan, ClassifyRandomFieldsReachEverySubcaseIncludingTunnels) {
  // Random corner values hit all 32 subcase slots (the tunnel subcases are rare: many cells).
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  const std::size_t cells = 400000;
  HexComplex complex = separate_cells(cells);
  std::vector<double> values(8 * cells);
  for (double& v : values) v = u(rng);
  const Classified got = run_classify(lavapipe(), complex, values);
  expect_same_as_reference(complex, values, got.codes, got.offsets);
  std::set<int> subcases;
  for (const CellCode& c : got.codes) subcases.insert(static_cast<int>(c.subcase));
  EXPECT_EQ(subcases.size(), std::size_t(kNumSubcases));
}

TEST(vulkan, ClassifyOnASharedGridChunkedAndGatheredEqualsWhole) {
  // A uniform grid (shared points) with a smooth field plus noise; then the same with 1000 cells
  // per chunk, which also takes the gathered-values path and carries the prefix sum across
  // chunks.
  const UniformGrid grid(Box{{-1, -1, -1}, {1, 1, 1}}, 3);
  const HexComplex complex = uniform_complex(grid);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-0.05, 0.05);
  std::vector<double> values(complex.points.size());
  for (std::size_t i = 0; i < values.size(); ++i) {
    const Vec3 p = complex.points[i];
    values[i] = 0.8 - std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z) + u(rng);
  }
  const Classified whole = run_classify(lavapipe(), complex, values);
  expect_same_as_reference(complex, values, whole.codes, whole.offsets);
  VulkanBackend small(lavapipe_options(1000));
  const Classified chunked = run_classify(small, complex, values);
  EXPECT_TRUE(chunked.codes == whole.codes);
  EXPECT_TRUE(chunked.offsets == whole.offsets);
  EXPECT_GE(small.dispatches(), 4 * ((complex.cells.size() + 999) / 1000));
}

// The mesher's call (host/cli/main.cpp): raw SDF values with the zero rule applied on the device,
// corner ids computed on the device for a uniform grid, only the subcase bytes and offsets back,
// and the values the SDF left on the device reused (ClassifyOptions::values_from_last_sdf). Every
// field equals core's classification of apply_zero_rule's values.
TEST(vulkan, ClassifyAUniformGridWithTheZeroRuleOnTheDevice) {
  const test::ZeroRuleGrid z = test::zero_rule_grid();
  const HexComplex& complex = z.complex;
  const std::vector<double>& values = z.values;
  ASSERT_GT(z.moved, 20u);
  const std::size_t n = complex.cells.size();
  const ClassifyOptions co = z.options();
  for (const std::size_t chunk : {std::size_t(0), std::size_t(1000)}) {
    SCOPED_TRACE("chunk " + std::to_string(chunk));
    VulkanBackend b(lavapipe_options(chunk));
    std::vector<CellCode> codes(n);
    std::vector<std::uint64_t> offsets(n + 1);
    classify_cells_codes(b, complex, values, codes, offsets, co);
    expect_same_as_reference(complex, z.ruled, codes, offsets);
    std::vector<std::uint8_t> subcases(n);
    std::vector<std::uint64_t> offsets2(n + 1);
    b.classify_cells(complex, values, {subcases, offsets2}, co);
    for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(subcases[i], static_cast<std::uint8_t>(codes[i].subcase)) << i;
    EXPECT_EQ(offsets2, offsets);
    // The SDF's own output, left on the device, classified without a second upload.
    std::vector<double> sdf(complex.points.size());
    SdfSource two;
    two.shape = ShapeKind::kTwoHoled;
    b.signed_distance(two, complex.points, sdf);
    ClassifyOptions resident = co;
    resident.values_from_last_sdf = true;
    classify_cells_codes(b, complex, sdf, codes, offsets, resident);
    expect_same_as_reference(complex, apply_zero_rule(complex, sdf), codes, offsets);
  }
}

TEST(vulkan, ClassifyRefusesNonFiniteValuesLikeTheReference) {
  HexComplex complex = separate_cells(2);
  std::vector<double> values(16, 1.0);
  values[11] = std::numeric_limits<double>::quiet_NaN();
  std::vector<CellCode> codes(2);
  std::vector<std::uint64_t> offsets(3);
  EXPECT_THROW(classify_cells_codes(lavapipe(), complex, values, codes, offsets), InputError);
  // A non-finite value at a point no cell uses is not an error (the reference never sees it).
  complex.points.push_back({});
  values.assign(17, 1.0);
  values[16] = std::numeric_limits<double>::infinity();
  EXPECT_NO_THROW(classify_cells_codes(lavapipe(), complex, values, codes, offsets));
  EXPECT_EQ(offsets[2], 16u);
}

TEST(vulkan, ReleasedBuffersAreReusedWithTheSizeAskedFor) {
  vk::Instance instance;
  const vk::PhysicalDevice* llvmpipe = nullptr;
  for (const vk::PhysicalDevice& d : instance.devices())
    if (d.driver_id == VK_DRIVER_ID_MESA_LLVMPIPE) llvmpipe = &d;
  ASSERT_NE(llvmpipe, nullptr);
  vk::Device device(instance, *llvmpipe, {});
  VkBuffer first = VK_NULL_HANDLE;
  {
    vk::Buffer a = device.make_buffer(1000);
    first = a.handle();
  }
  vk::Buffer b = device.make_buffer(900);  // the released one, sized as asked
  EXPECT_EQ(b.handle(), first);
  EXPECT_EQ(b.size(), 900u);
  vk::Buffer c = device.make_buffer(900);  // the pool is empty again
  EXPECT_NE(c.handle(), first);
  // A small request does not take a large buffer; a large one that fits does.
  const VkDeviceSize mib = VkDeviceSize(1) << 20;
  VkBuffer large = VK_NULL_HANDLE;
  {
    vk::Buffer l = device.make_buffer(64 * mib);
    large = l.handle();
  }
  vk::Buffer small = device.make_buffer(1000);
  EXPECT_NE(small.handle(), large);
  vk::Buffer fits = device.make_buffer(40 * mib);
  EXPECT_EQ(fits.handle(), large);
  EXPECT_EQ(fits.size(), 40 * mib);
  // Beyond the pool's limit a released buffer is freed, not kept.
  const VkDeviceSize kept = device.pooled_bytes();
  { vk::Buffer h = device.make_buffer(vk::BufferPool::kMaxBytes + 1); }
  EXPECT_EQ(device.pooled_bytes(), kept);
  { vk::Buffer h = device.make_buffer(mib); }
  EXPECT_EQ(device.pooled_bytes(), kept + mib);
}

// Memory type tables as drivers report them (vulkaninfo on each kind of device): the buffers take
// a host-cached type where one is allowed, else the first host-visible, host-coherent one.
TEST(vulkan, BuffersTakeHostCachedMemoryWhereTheDeviceHasIt) {
  constexpr VkMemoryPropertyFlags kLocal = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT,
                                  kVisible = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT,
                                  kCoherent = VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                                  kCached = VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
  auto table = [](std::initializer_list<VkMemoryPropertyFlags> types) {
    VkPhysicalDeviceMemoryProperties m{};
    for (VkMemoryPropertyFlags f : types) m.memoryTypes[m.memoryTypeCount++].propertyFlags = f;
    return m;
  };
  // A discrete NVIDIA GPU: device memory, write-combined system memory, cached system memory,
  // and the device memory the CPU sees through the BAR.
  const auto nvidia = table({0, kLocal, kLocal, kVisible | kCoherent, kVisible | kCoherent | kCached,
                             kLocal | kVisible | kCoherent});
  EXPECT_EQ(vk::buffer_memory_type(nvidia, ~0u), 4);
  EXPECT_EQ(vk::buffer_memory_type(nvidia, ~0u & ~(1u << 4)), 3);  // cached not allowed: the first mapped type
  EXPECT_EQ(vk::buffer_memory_type(nvidia, 1u << 5), 5);
  EXPECT_EQ(vk::buffer_memory_type(nvidia, 0b111), -1);  // only device memory allowed
  // A discrete AMD GPU lists its cached type last.
  const auto amd = table({kLocal, kVisible | kCoherent, kLocal | kVisible | kCoherent, kVisible | kCoherent | kCached});
  EXPECT_EQ(vk::buffer_memory_type(amd, ~0u), 3);
  // lavapipe: one type with every property.
  EXPECT_EQ(vk::buffer_memory_type(table({kLocal | kVisible | kCoherent | kCached}), ~0u), 0);
  // Host-visible but not coherent memory needs flushes the backend does not make: never taken.
  EXPECT_EQ(vk::buffer_memory_type(table({kLocal, kVisible | kCached}), ~0u), -1);
  EXPECT_EQ(vk::buffer_memory_type(table({}), ~0u), -1);

  // The real lavapipe device allocates from a host-cached type and says so in the report.
  vk::Instance instance;
  for (const vk::PhysicalDevice& d : instance.devices())
    if (d.driver_id == VK_DRIVER_ID_MESA_LLVMPIPE) {
      vk::Device device(instance, d, {});
      const VkMemoryPropertyFlags f = device.buffer_memory_flags();
      EXPECT_EQ(f & (kVisible | kCoherent | kCached), kVisible | kCoherent | kCached);
    }
  EXPECT_NE(lavapipe().device().kernels.find("buffers in host-visible, host-cached"), std::string::npos)
      << lavapipe().device().kernels;
}

TEST(vulkan, PipelineCacheIsWrittenAndReusedByASecondBackend) {
  const fs::path dir = scratch() / "cache-test";
  fs::remove_all(dir);
  {
    VulkanBackend first(lavapipe_options(0, dir));
    EXPECT_EQ(first.pipeline_cache_bytes_loaded(), 0u);  // nothing there yet
    ASSERT_TRUE(fs::exists(first.pipeline_cache_file())) << first.pipeline_cache_file();
    EXPECT_EQ(first.pipeline_cache_file().parent_path(), dir);
  }
  VulkanBackend second(lavapipe_options(0, dir));
  // The second backend loaded the whole file the first one wrote, and the driver accepted it.
  const std::uintmax_t file_bytes = fs::file_size(second.pipeline_cache_file());
  EXPECT_EQ(second.pipeline_cache_bytes_loaded(), file_bytes);
  // The file is this device's cache: VkPipelineCacheHeaderVersionOne (length 32, version 1,
  // vendor, device, pipelineCacheUUID) as the driver wrote it. Lavapipe (Mesa 22.3) keeps no
  // compiled code in a VkPipelineCache, so there the file is this header alone; a GPU driver
  // appends its binaries after it.
  ASSERT_GE(file_bytes, 32u);
  std::ifstream in(second.pipeline_cache_file(), std::ios::binary);
  std::array<unsigned char, 32> header{};
  in.read(reinterpret_cast<char*>(header.data()), 32);
  auto word = [&](int i) {
    return std::uint32_t(header[4 * i]) | std::uint32_t(header[4 * i + 1]) << 8 |
           std::uint32_t(header[4 * i + 2]) << 16 | std::uint32_t(header[4 * i + 3]) << 24;
  };
  EXPECT_EQ(word(0), 32u);
  EXPECT_EQ(word(1), 1u);  // VK_PIPELINE_CACHE_HEADER_VERSION_ONE
  const auto uuid = second.pipeline_cache_uuid();
  EXPECT_TRUE(std::equal(uuid.begin(), uuid.end(), header.begin() + 16));
}

namespace {

// Points that stress the closest-feature logic of a surface: its vertices, points on its edges and
// inside its triangles (exactly, and nudged off by tiny and small distances along the face
// normal), random points around it and far away.
std::vector<Vec3> adversarial_points(const TriangleSurface& s, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0, 1), box(-2, 2);
  std::vector<Vec3> pts;
  for (std::size_t t = 0; t < s.triangles.size(); t += 3) {
    const Vec3 a = s.vertices[s.triangles[t][0]], b = s.vertices[s.triangles[t][1]], c = s.vertices[s.triangles[t][2]];
    const Vec3 n = normalized(cross(b - a, c - a));
    const double r = u(rng), q = u(rng) * (1 - r);
    const Vec3 inside = a + r * (b - a) + q * (c - a);
    pts.push_back(a);
    pts.push_back(a + u(rng) * (b - a));
    pts.push_back(0.5 * (b + c));
    pts.push_back(inside);
    for (double off : {1e-14, -1e-14, 1e-9, -1e-9, 1e-3, -1e-3}) pts.push_back(inside + off * n);
  }
  for (int i = 0; i < 20000; ++i) pts.push_back({box(rng), box(rng), box(rng)});
  for (int i = 0; i < 200; ++i) pts.push_back({1e4 * box(rng), 1e4 * box(rng), 1e4 * box(rng)});
  pts.push_back({0, 0, 0});
  return pts;
}

void expect_bit_equal(const std::vector<double>& got, const std::vector<double>& want, const std::vector<Vec3>& pts) {
  ASSERT_EQ(got.size(), want.size());
  int wrong = 0;
  for (std::size_t i = 0; i < got.size() && wrong < 5; ++i)
    if (bits(got[i]) != bits(want[i])) {
      ++wrong;
      ADD_FAILURE() << "point " << i << " (" << pts[i].x << ", " << pts[i].y << ", " << pts[i].z
                    << "): device " << got[i] << " reference " << want[i];
    }
}

// Every variant's values at pts equal `want` (core's) bit for bit.
void expect_every_variant_gives(const SdfSource& source, const std::vector<Vec3>& pts, const std::vector<double>& want) {
  for (const SdfVariant& v : sdf_variants()) {
    SCOPED_TRACE(v.name);
    std::vector<double> got(pts.size());
    v.backend.signed_distance(source, pts, got);
    expect_bit_equal(got, want, pts);
  }
}

}  // namespace

TEST(vulkan, ShapeSdfIsBitIdenticalToTheReference) {
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> u(-1.6, 1.6);
  for (const ShapeInfo& info : shape_catalog()) {
    std::vector<Vec3> pts;
    for (int i = 0; i < 30000; ++i) pts.push_back({u(rng), u(rng), u(rng)});
    // Axes, planes of symmetry and the tube junction of the two-holed solid, and far points.
    for (int i = 0; i < 200; ++i) {
      pts.push_back({u(rng), 0, 0});
      pts.push_back({0, u(rng), 0});
      pts.push_back({0, 0, u(rng)});
      pts.push_back({u(rng), u(rng), 0});
      pts.push_back({1e6 * u(rng), 1e6 * u(rng), 1e6 * u(rng)});
    }
    const ShapeSdf reference(info.kind);
    std::vector<double> want(pts.size()), got(pts.size());
    reference.evaluate(pts, want);
    SdfSource source;
    source.shape = info.kind;
    lavapipe().signed_distance(source, pts, got);
    SCOPED_TRACE(std::string(info.name));
    expect_bit_equal(got, want, pts);
  }
}

// Closed, open (a band of triangles removed) and a soup (flipped, duplicated and zero-area
// triangles): the surfaces the surface-SDF tests compare on.
std::vector<std::pair<std::string, TriangleSurface>> closed_open_and_degenerate_surfaces() {
  std::vector<std::pair<std::string, TriangleSurface>> surfaces;
  surfaces.emplace_back("torus", tessellate(ShapeKind::kTorus, 48));
  surfaces.emplace_back("sphere", tessellate(ShapeKind::kSphere, 40));
  TriangleSurface open = tessellate(ShapeKind::kSphere, 24);
  open.triangles.erase(open.triangles.begin() + 40, open.triangles.begin() + 90);
  surfaces.emplace_back("open sphere", open);
  TriangleSurface soup = tessellate(ShapeKind::kTorus, 16);
  for (std::size_t t = 0; t < soup.triangles.size(); t += 7) std::swap(soup.triangles[t][1], soup.triangles[t][2]);
  for (std::size_t t = 0; t < 20; ++t) soup.triangles.push_back(soup.triangles[t]);
  soup.vertices.push_back({0.3, 0.3, 0.3});
  soup.vertices.push_back({0.6, 0.6, 0.6});
  soup.vertices.push_back({0.9, 0.9, 0.9});
  const std::uint32_t v0 = std::uint32_t(soup.vertices.size() - 3);
  soup.triangles.push_back({v0, v0 + 1, v0});      // repeated vertex
  soup.triangles.push_back({v0, v0 + 1, v0 + 2});  // collinear: zero area
  surfaces.emplace_back("soup", soup);
  return surfaces;
}

TEST(vulkan, SurfaceSdfIsBitIdenticalOnClosedOpenAndDegenerateSurfaces) {
  std::mt19937_64 rng(22);
  const auto surfaces = closed_open_and_degenerate_surfaces();
  // lavapipe has subgroup arithmetic (subgroups of 8), but the default is one walk per invocation
  // over texel buffers.
  EXPECT_FALSE(lavapipe().sdf_subgroup_walk());
  EXPECT_TRUE(lavapipe().sdf_texel_reads());
  const std::vector<SdfVariant> variants = sdf_variants();
  EXPECT_TRUE(variants[0].backend.sdf_subgroup_walk());
  EXPECT_FALSE(variants[1].backend.sdf_subgroup_walk());
  EXPECT_TRUE(variants[1].backend.sdf_texel_reads());
  EXPECT_FALSE(variants[2].backend.sdf_subgroup_walk());
  EXPECT_FALSE(variants[2].backend.sdf_texel_reads());
  for (const auto& [name, s] : surfaces) {
    SCOPED_TRACE(name);
    const std::vector<Vec3> pts = adversarial_points(s, rng);
    const SurfaceSdf reference(s);
    std::vector<double> want(pts.size());
    reference.evaluate(pts, want);
    SdfSource source;
    source.surface = &s;
    expect_every_variant_gives(source, pts, want);
  }
}

// The n^3 points of a grid over a surface's padded bounding cube (perf/bench_backends's workload).
std::vector<Vec3> grid_points_over(const TriangleSurface& s, int n) {
  const Box cube = padded_cube(s.bounds(), 0.1);
  std::vector<Vec3> pts;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        pts.push_back(cube.lo + Vec3{cube.size().x * i / (n - 1), cube.size().y * j / (n - 1), cube.size().z * k / (n - 1)});
  return pts;
}

// Grid points over a fine torus (perf/bench_backends's workload, smaller): many are exactly as far
// from two or more triangles (the grid and the tessellation share symmetry planes), so the tie
// rule decides, and each invocation's turns seed one another across the Morton order.
TEST(vulkan, SurfaceSdfOnAGridOverAFineTorusIsBitIdentical) {
  const TriangleSurface torus = tessellate(ShapeKind::kTorus, 256);
  const std::vector<Vec3> pts = grid_points_over(torus, 40);
  std::vector<double> want(pts.size());
  SurfaceSdf(torus).evaluate(pts, want);
  SdfSource source;
  source.surface = &torus;
  expect_every_variant_gives(source, pts, want);
}

TEST(vulkan, SurfaceSdfChunkedEqualsWholeAndEmptySurfaceIsOutside) {
  const TriangleSurface torus = tessellate(ShapeKind::kTorus, 32);
  std::mt19937_64 rng(23);
  const std::vector<Vec3> pts = adversarial_points(torus, rng);
  SdfSource source;
  source.surface = &torus;
  std::vector<double> whole(pts.size()), chunked(pts.size());
  lavapipe().signed_distance(source, pts, whole);
  VulkanBackend small(lavapipe_options(1000));
  const std::size_t before = small.dispatches();
  small.signed_distance(source, pts, chunked);
  EXPECT_EQ(small.dispatches() - before, (pts.size() + 999) / 1000);
  expect_bit_equal(chunked, whole, pts);

  const TriangleSurface empty;
  source.surface = &empty;
  std::vector<double> v(3, 0.0);
  lavapipe().signed_distance(source, std::vector<Vec3>(3), v);
  for (double x : v) EXPECT_EQ(x, -std::numeric_limits<double>::infinity());
}

// llvmpipe ends any shader's loops after 65,535 iterations in all (gallivm's loop limiter,
// LP_MAX_TGSI_LOOP_ITERATIONS, shared by every loop of an invocation) and carries on with what it
// has. Points at the centre of a finely tessellated sphere are the walk's worst case: every
// triangle is nearly as close as the nearest, so pruning opens almost the whole tree.
TEST(vulkan, SurfaceSdfAtTheCentreOfAFineSphereWhereTheWalkOpensTheWholeTree) {
  const TriangleSurface sphere = tessellate(ShapeKind::kSphere, 160);
  std::vector<Vec3> pts;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1e-3, 1e-3);
  for (int i = 0; i < 256; ++i) pts.push_back(i % 2 ? Vec3{0, 0, 0} : Vec3{u(rng), u(rng), u(rng)});
  // and easy ones, near the surface, which the device answers itself.
  for (int i = 0; i < 256; ++i) pts.push_back(Vec3{std::cos(0.1 * i), std::sin(0.1 * i), 0.01 * (i % 20)} * 1.05);
  const SurfaceSdf reference(sphere);
  std::vector<double> want(pts.size()), got(pts.size());
  reference.evaluate(pts, want);
  SdfSource source;
  source.surface = &sphere;
  SCOPED_TRACE(std::to_string(sphere.triangles.size()) + " triangles");
  for (const SdfVariant& v : sdf_variants()) {
    SCOPED_TRACE(v.name);
    VulkanBackend& b = v.backend;
    EXPECT_EQ(b.sdf_loop_budget(), 65535u - 1024u);  // llvmpipe: the budget is on, the whole limit usable
    std::fill(got.begin(), got.end(), 0.0);
    const std::size_t before = b.profile().host_points;
    b.signed_distance(source, pts, got);
    expect_bit_equal(got, want, pts);
    // Some searches here do run out of the budget (else this test would not test it); the rest
    // are the device's own answers.
    const std::size_t redone = b.profile().host_points - before;
    EXPECT_GT(redone, 0u);
    EXPECT_LT(redone, pts.size());
  }
}

// ---- The fp32 path (kernels/sdf_fp32.h, host/backends/fp32_path.h), forced on lavapipe ----------------

namespace {

VulkanBackend& lavapipe_fp32() {
  static VulkanBackend backend([] {
    VulkanOptions o = lavapipe_options();
    o.force_fp32 = true;
    return o;
  }());
  return backend;
}

// The capabilities a SPIR-V module declares (OpCapability, opcode 17: SPIR-V spec 2.3, 3.31).
std::set<std::uint32_t> capabilities(std::span<const std::uint32_t> words) {
  std::set<std::uint32_t> out;
  for (std::size_t i = 5; i < words.size();) {  // after the 5-word header
    const std::uint32_t count = words[i] >> 16, opcode = words[i] & 0xFFFF;
    if (count == 0) break;
    if (opcode == 17 && count == 2) out.insert(words[i + 1]);
    i += count;
  }
  return out;
}

// fp32 SDF of `pts` on `b`, with the stats of this call.
Fp32Stats fp32_sdf(VulkanBackend& b, const TriangleSurface& s, const std::vector<Vec3>& pts, std::vector<double>& got) {
  const Fp32Stats before = b.fp32_stats();
  got.assign(pts.size(), 0.0);
  SdfSource source;
  source.surface = &s;
  b.signed_distance(source, pts, got);
  Fp32Stats after = b.fp32_stats();
  after.points -= before.points;
  after.candidates -= before.candidates;
  after.host_points -= before.host_points;
  after.budget_points -= before.budget_points;
  return after;
}

}  // namespace

TEST(VulkanFp32, ForcedByTheOptionOrTheEnvironmentWithShadersFreeOfDoubleAndInt64) {
  EXPECT_EQ(lavapipe_fp32().device().precision, "fp32");
  EXPECT_EQ(lavapipe().device().precision, "fp64");
  // lavapipe runs the subgroup-counted shader under the whole loop limit.
  EXPECT_EQ(lavapipe_fp32().sdf_loop_budget(), 65535u - 1024u);
  // A device without shaderFloat64 or shaderInt64 must be able to load them: Float64 is
  // capability 10, Int64 11 (SPIR-V spec 3.31).
  for (const auto code : {spirv::surface_sdf32, spirv::surface_sdf32_counted}) {
    const std::set<std::uint32_t> caps = capabilities(code);
    EXPECT_TRUE(caps.count(1)) << "no Shader capability: the parse is wrong";
    EXPECT_FALSE(caps.count(10));
    EXPECT_FALSE(caps.count(11));
  }
  EXPECT_TRUE(capabilities(spirv::surface_sdf_single).count(10));  // the parse does see Float64
  // MCHEX_FORCE_FP32 (any value but empty and "0") does the same, and the device list says so.
  for (const char* value : {"1", "0"}) {
    ::setenv("MCHEX_FORCE_FP32", value, 1);
    const std::string want = std::string(value) == "1" ? "fp32" : "fp64";
    EXPECT_EQ(VulkanBackend(lavapipe_options()).device().precision, want) << value;
    for (const DeviceInfo& d : list_vulkan_devices())
      if (d.name.find("llvmpipe") != std::string::npos) {
        EXPECT_EQ(d.precision, want) << value;
      }
  }
  ::unsetenv("MCHEX_FORCE_FP32");
}

// Single precision finds the candidate triangles, the host computes the values in double: equal to
// core bit for bit on the adversarial points (vertices, edges, faces, +-1e-14 to 1e-3 off them,
// exact ties, far points), values at +-1e-10 of the diagonal off faces (the mesher's zero
// tolerance scale, inside the float guard band), on closed, open and degenerate surfaces; in
// chunks too.
TEST(VulkanFp32, SurfaceSdfIsBitIdenticalOnClosedOpenAndDegenerateSurfaces) {
  std::mt19937_64 rng(22);
  const auto surfaces = closed_open_and_degenerate_surfaces();
  VulkanBackend chunked([] {
    VulkanOptions o = lavapipe_options(1000);
    o.force_fp32 = true;
    return o;
  }());
  for (const auto& [name, s] : surfaces) {
    SCOPED_TRACE(name);
    std::vector<Vec3> pts = adversarial_points(s, rng);
    const double diag = s.bounds().diagonal();
    for (std::size_t t = 0; t < s.triangles.size(); t += 5) {
      const auto& tri = s.triangles[t];
      const Vec3 a = s.vertices[tri[0]], b = s.vertices[tri[1]], c = s.vertices[tri[2]];
      const Vec3 n = cross(b - a, c - a);
      if (!(squared_norm(n) > 0)) continue;
      for (double off : {1e-10, -1e-10}) pts.push_back((a + b + c) / 3.0 + off * diag * normalized(n));
    }
    std::vector<double> want(pts.size()), got;
    SurfaceSdf(s).evaluate(pts, want);
    const Fp32Stats st = fp32_sdf(lavapipe_fp32(), s, pts, got);
    expect_bit_equal(got, want, pts);
    EXPECT_EQ(st.points, pts.size());
    // The device really decided most points: the host evaluated few whole.
    EXPECT_LT(st.host_points, pts.size() / 4);
    std::printf("[ fp32 path ] %s: %zu points, %.2f candidates per point, %llu evaluated whole on the host "
                "(%llu out of budget)\n",
                name.c_str(), pts.size(), double(st.candidates) / double(pts.size() - st.host_points),
                (unsigned long long)st.host_points, (unsigned long long)st.budget_points);
    const std::size_t before = chunked.dispatches();
    fp32_sdf(chunked, s, pts, got);
    EXPECT_EQ(chunked.dispatches() - before, (pts.size() + 999) / 1000);
    expect_bit_equal(got, want, pts);
  }
}

// Grid points over a fine torus: many exact ties (the grid and the tessellation share symmetry
// planes), each invocation's 16 points seeding one another along the Morton order.
TEST(VulkanFp32, SurfaceSdfOnAGridOverAFineTorusIsBitIdentical) {
  const TriangleSurface torus = tessellate(ShapeKind::kTorus, 256);
  const std::vector<Vec3> pts = grid_points_over(torus, 40);
  std::vector<double> want(pts.size()), got;
  SurfaceSdf(torus).evaluate(pts, want);
  const Fp32Stats st = fp32_sdf(lavapipe_fp32(), torus, pts, got);
  expect_bit_equal(got, want, pts);
  EXPECT_LT(st.host_points, pts.size() / 4);
}

// The loop budget (kernels/sdf_fp32.h): near the centre of a finely tessellated sphere nearly every
// triangle is about as close as the nearest, so the walk opens most of the tree and would pass
// llvmpipe's loop limit; those searches stop short and say so, the host evaluates the points (and
// the later points of the same invocations: the limit counts the whole shader run of a batch).
// At the exact centre the candidates overflow instead (a whole ring of triangles ties).
TEST(VulkanFp32, SurfaceSdfAtTheCentreOfAFineSphereStopsWithinTheLoopBudget) {
  const TriangleSurface sphere = tessellate(ShapeKind::kSphere, 160);
  std::vector<Vec3> pts, easy;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1e-3, 1e-3);
  for (int i = 0; i < 256; ++i) pts.push_back(i % 2 ? Vec3{0, 0, 0} : Vec3{u(rng), u(rng), u(rng)});
  // and easy ones, near the surface.
  for (int i = 0; i < 256; ++i) easy.push_back(Vec3{std::cos(0.1 * i), std::sin(0.1 * i), 0.01 * (i % 20)} * 1.05);
  pts.insert(pts.end(), easy.begin(), easy.end());
  SCOPED_TRACE(std::to_string(sphere.triangles.size()) + " triangles");
  std::vector<double> want(pts.size()), got;
  SurfaceSdf(sphere).evaluate(pts, want);
  const Fp32Stats st = fp32_sdf(lavapipe_fp32(), sphere, pts, got);
  expect_bit_equal(got, want, pts);
  std::printf("[ fp32 path ] sphere centre: %llu of %zu points evaluated whole on the host, %llu out of budget\n",
              (unsigned long long)st.host_points, pts.size(), (unsigned long long)st.budget_points);
  EXPECT_GT(st.budget_points, 0u);        // the budget was really reached ...
  EXPECT_LT(st.host_points, pts.size());  // ... and the device answered points itself
  // The easy points alone never reach it.
  std::vector<double> easy_want(easy.size()), easy_got;
  SurfaceSdf(sphere).evaluate(easy, easy_want);
  const Fp32Stats easy_st = fp32_sdf(lavapipe_fp32(), sphere, easy, easy_got);
  expect_bit_equal(easy_got, easy_want, easy);
  EXPECT_EQ(easy_st.budget_points, 0u);
  EXPECT_LT(easy_st.host_points, easy.size() / 4);
}

// On the fp32 path the other stages are core's, on the host: shapes, refinement errors and the
// mesher's classification call (zero rule, uniform grid, values left by the SDF) equal the cpu
// backend's.
TEST(VulkanFp32, ShapesRefinementAndClassificationAreTheReferences) {
  const test::ZeroRuleGrid z = test::zero_rule_grid();
  const std::unique_ptr<Backend> cpu = make_cpu_backend();
  SdfSource two;
  two.shape = ShapeKind::kTwoHoled;
  std::vector<double> want(z.complex.points.size()), got(z.complex.points.size());
  cpu->signed_distance(two, z.complex.points, want);
  lavapipe_fp32().signed_distance(two, z.complex.points, got);
  expect_bit_equal(got, want, z.complex.points);

  ClassifyOptions co = z.options();
  co.values_from_last_sdf = true;
  const std::size_t n = z.complex.cells.size();
  std::vector<CellCode> codes(n);
  std::vector<std::uint64_t> offsets(n + 1);
  classify_cells_codes(lavapipe_fp32(), z.complex, got, codes, offsets, co);
  expect_same_as_reference(z.complex, apply_zero_rule(z.complex, got), codes, offsets);

  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<std::array<double, kChildLatticePoints>> lattice(500);
  std::vector<double> sizes(lattice.size()), e32(lattice.size()), e64(lattice.size());
  for (std::size_t i = 0; i < lattice.size(); ++i) {
    for (double& v : lattice[i]) v = u(rng);
    sizes[i] = std::ldexp(1.0, -int(i % 7));
  }
  lavapipe_fp32().refinement_error(lattice, sizes, e32);
  cpu->refinement_error(lattice, sizes, e64);
  for (std::size_t i = 0; i < lattice.size(); ++i) ASSERT_EQ(bits(e32[i]), bits(e64[i])) << i;
}
