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

#include "core/error.h"
#include "core/grid.h"
#include "core/hex_complex.h"
#include "core/mc33.h"
#include "core/refinement_error.h"
#include "host/backend_vulkan.h"

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
    total += 8 + 2 * static_cast<std::uint64_t>(std::popcount(r.cut_edges));
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
  b.classify_cells(complex, values, out.codes, out.offsets);
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

TEST(vulkan, ClassifyRefusesNonFiniteValuesLikeTheReference) {
  HexComplex complex = separate_cells(2);
  std::vector<double> values(16, 1.0);
  values[11] = std::numeric_limits<double>::quiet_NaN();
  std::vector<CellCode> codes(2);
  std::vector<std::uint64_t> offsets(3);
  EXPECT_THROW(lavapipe().classify_cells(complex, values, codes, offsets), InputError);
  // A non-finite value at a point no cell uses is not an error (the reference never sees it).
  complex.points.push_back({});
  values.assign(17, 1.0);
  values[16] = std::numeric_limits<double>::infinity();
  EXPECT_NO_THROW(lavapipe().classify_cells(complex, values, codes, offsets));
  EXPECT_EQ(offsets[2], 16u);
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
