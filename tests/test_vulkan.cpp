// What only the vulkan backend has, really run on Mesa lavapipe (selected explicitly: its ICD is
// the only one the loader sees in this process, and the device is picked by name; no lavapipe
// means these tests FAIL, they never skip): the device list, the buffer pool and memory types, the
// pipeline cache, the surface-SDF shader each option picks, dispatch counts of chunked batches,
// llvmpipe's loop budget, and the fp32 path's shaders and division of work. The questions every
// backend answers (surface and shape SDF, refinement error, classification, crossings, chunking,
// against core bit for bit) are tests/test_backends.cpp's, asked there of each shader variant
// and of the fp32 path on lavapipe.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/cutting/local_refinement.h"
#include "core/cutting/mc33.h"
#include "core/cutting/mchex_mesher.h"
#include "core/grid/grid.h"
#include "core/grid/hex_complex.h"
#include "core/grid/refinement_error.h"
#include "core/mesh/surface.h"
#include "core/sdf/sdf.h"
#include "core/sdf/shapes.h"
#include "host/backends/cpu.h"
#include "host/backends/vk_context.h"
#include "host/backends/vk_spirv.h"
#include "host/backends/vulkan.h"
#include "tests/backend_samples.h"

namespace fs = std::filesystem;
using namespace mchex;
using namespace mchex::test;

namespace {

fs::path scratch() { return process_scratch(); }
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

struct Classified {
  std::vector<CellCode> codes;
  std::vector<std::uint64_t> offsets;
};

Classified run_classify(Backend& b, const HexComplex& complex, const std::vector<double>& values) {
  Classified out{std::vector<CellCode>(complex.cells.size()), std::vector<std::uint64_t>(complex.cells.size() + 1)};
  classify_cells_codes(b, complex, values, out.codes, out.offsets);
  return out;
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

// Refinement errors in chunks of 97 cells: one dispatch per chunk, the bits of the whole batch's
// (test_backends compares both with core's on every backend).
TEST(vulkan, RefinementErrorInChunksIsOneDispatchPerChunk) {
  std::mt19937_64 rng(7);
  std::vector<std::array<double, kChildLatticePoints>> lattice;
  std::vector<double> sizes;
  add_smooth_rough_trilinear_and_flat_fields(rng, 3000, lattice, sizes);
  std::vector<double> device(lattice.size());
  lavapipe().refinement_error(lattice, sizes, device);
  VulkanBackend small(lavapipe_options(97));
  std::vector<double> chunked(lattice.size());
  const std::size_t before = small.dispatches();
  small.refinement_error(lattice, sizes, chunked);
  EXPECT_EQ(small.dispatches() - before, (lattice.size() + 96) / 97);
  for (std::size_t i = 0; i < lattice.size(); ++i) ASSERT_EQ(bits(chunked[i]), bits(device[i])) << i;
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
  const auto nvidia =
      table({0, kLocal, kLocal, kVisible | kCoherent, kVisible | kCoherent | kCached, kLocal | kVisible | kCoherent});
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

// lavapipe has subgroup arithmetic (subgroups of 8), but the default is one walk per invocation
// over texel buffers; the options pick each of the other shaders.
TEST(vulkan, SdfWalkOptionsPickTheirShaders) {
  EXPECT_FALSE(lavapipe().sdf_subgroup_walk());
  EXPECT_TRUE(lavapipe().sdf_texel_reads());
  const std::vector<SdfVariant> variants = sdf_variants();
  EXPECT_TRUE(variants[0].backend.sdf_subgroup_walk());
  EXPECT_FALSE(variants[1].backend.sdf_subgroup_walk());
  EXPECT_TRUE(variants[1].backend.sdf_texel_reads());
  EXPECT_FALSE(variants[2].backend.sdf_subgroup_walk());
  EXPECT_FALSE(variants[2].backend.sdf_texel_reads());
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
