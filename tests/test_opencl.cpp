// What only the opencl backend has, on PoCL (selected by platform name; a missing PoCL is a
// failure, never a skip: setup.sh installs it): the device list, the program binary cache, the
// no-fma face test, the zero-copy and device-buffer paths of the mesher's classification call,
// the fp32 path's division of work, and whole CLI runs (`mesh --backend opencl` and `--backend cpu`
// write byte-identical files). The questions every backend answers (surface and shape SDF,
// refinement error, classification, crossings, chunking, against core bit for bit) are
// tests/test_backends.cpp's, asked of opencl and its forced fp32 path there.
#include <sys/wait.h>
#include <unistd.h>
#include <gtest/gtest.h>

#include <bit>
#include <cmath>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "core/base/error.h"
#include "core/cutting/local_refinement.h"
#include "core/cutting/mc33.h"
#include "core/cutting/mchex_mesher.h"
#include "core/device/backend.h"
#include "core/grid/grid.h"
#include "core/grid/hex_complex.h"
#include "core/grid/refinement_error.h"
#include "core/io/surface_io.h"
#include "core/mesh/surface.h"
#include "core/sdf/sdf.h"
#include "core/sdf/shapes.h"
#include "host/backends/cpu.h"
#include "host/backends/opencl.h"
#include "host/backends/registry.h"
#include "tests/backend_samples.h"

namespace fs = std::filesystem;
using namespace mchex;
using namespace mchex::test;

namespace {

constexpr const char* kPocl = "Portable Computing Language";

fs::path scratch(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("mchex_test_opencl_" + std::to_string(::getpid())) / name;
  fs::create_directories(p);
  return p;
}

OpenclOptions pocl(std::string build_options = {}) {
  OpenclOptions o;
  o.platform = kPocl;
  // Shared by the test processes (ctest runs each test alone), so the program is compiled once.
  o.cache_dir = (fs::temp_directory_path() / "mchex_test_opencl_cache").string();
  o.build_options = std::move(build_options);
  return o;
}

// One backend per test binary: building the program takes seconds on PoCL.
OpenclBackend& device() {
  static OpenclBackend b(pocl());
  return b;
}

}  // namespace

TEST(Opencl, RunsOnPocl) {
  const DeviceInfo& d = device().device();
  EXPECT_EQ(d.backend, "opencl");
  EXPECT_EQ(d.platform, kPocl);
  EXPECT_TRUE(d.fp64);
  EXPECT_GT(d.max_buffer_bytes, 0u);
}

TEST(Opencl, ListsPoclWithItsLimits) {
  bool found = false;
  for (const DeviceInfo& d : list_devices())
    if (d.backend == "opencl" && d.platform == kPocl) {
      found = true;
      EXPECT_TRUE(d.fp64);
      EXPECT_GT(d.global_memory_bytes, 0u);
      EXPECT_GT(d.compute_units, 0u);
      EXPECT_TRUE(d.note.empty());
    }
  EXPECT_TRUE(found);
}

TEST(Opencl, SecondBuildHitsTheProgramCache) {
  OpenclOptions o = pocl();
  o.cache_dir = scratch("cache-second-build").string();
  fs::remove_all(o.cache_dir);
  OpenclBackend first(o);
  EXPECT_FALSE(first.program_from_cache());
  ASSERT_FALSE(first.cache_file().empty());
  EXPECT_TRUE(fs::is_regular_file(first.cache_file()));
  OpenclBackend second(o);
  EXPECT_TRUE(second.program_from_cache());
  EXPECT_EQ(second.cache_file(), first.cache_file());
  // The cached program computes the same thing.
  const std::vector<Vec3> pts = {{0.1, 0.2, 0.3}, {1.5, 0, 0}, {0.4, -0.9, 0.05}};
  std::vector<double> a(3), b(3);
  SdfSource torus;
  torus.shape = ShapeKind::kTorus;
  first.signed_distance(torus, pts, a);
  second.signed_distance(torus, pts, b);
  EXPECT_EQ(first_difference(a, b), -1);
  // A different build (other options) is another cache entry.
  OpenclOptions other = o;
  other.build_options = "-DMCHEX_NO_FMA";
  OpenclBackend third(other);
  EXPECT_FALSE(third.program_from_cache());
  EXPECT_NE(third.cache_file(), first.cache_file());
}

TEST(Opencl, CorruptCacheFileIsRebuilt) {
  OpenclOptions o = pocl();
  o.cache_dir = scratch("cache-corrupt").string();
  fs::remove_all(o.cache_dir);
  std::string file;
  {
    OpenclBackend b(o);
    file = b.cache_file();
  }
  std::ofstream(file, std::ios::binary | std::ios::trunc) << "not a program binary";
  OpenclBackend b(o);
  EXPECT_FALSE(b.program_from_cache());
  OpenclBackend c(o);
  EXPECT_TRUE(c.program_from_cache());
}

TEST(Opencl, ClassificationWithoutFmaGivesTheSameDecisions) {
  // The Dekker/expansion face test that GLSL uses, run on PoCL: the same exact sign.
  OpenclBackend no_fma(pocl("-DMCHEX_NO_FMA"));
  std::mt19937_64 rng(13);
  const double small[] = {0.25, 0.5, 1, 2, 4};
  const CellBatch ties = all_patterns(30, [&](int) { return small[rng() % 5]; });
  expect_same_classification(no_fma, ties, "ties, no fma");
  std::uniform_real_distribution<double> u(1e-6, 1);
  const CellBatch random = all_patterns(30, [&](int) { return u(rng); });
  expect_same_classification(no_fma, random, "random, no fma");
}

// The mesher's call (host/cli/main.cpp): raw SDF values with the zero rule applied on the device,
// corner ids computed on the device for a uniform grid, only the subcase bytes and offsets back;
// and the values the SDF left on the device reused (ClassifyOptions::values_from_last_sdf, which
// only a device with its own buffers has: zero_copy off runs that path on PoCL). Every field equals
// core's classification of apply_zero_rule's values.
TEST(Opencl, UniformGridWithTheZeroRuleOnTheDevice) {
  const ZeroRuleGrid z = zero_rule_grid();
  const HexComplex& complex = z.complex;
  const std::vector<double>& values = z.values;
  ASSERT_GT(z.moved, 20u);
  const std::size_t n = complex.cells.size();
  std::vector<CellCode> ref(n);
  std::vector<std::uint64_t> ref_off(n + 1);
  classify_cells_codes(*make_cpu_backend(), complex, z.ruled, ref, ref_off);
  std::vector<std::uint8_t> ref_subcases(n);
  for (std::size_t i = 0; i < n; ++i) ref_subcases[i] = static_cast<std::uint8_t>(ref[i].subcase);
  const ClassifyOptions co = z.options();
  for (const bool zero_copy : {true, false})
    for (const std::size_t chunk : {std::size_t(0), std::size_t(1000)}) {
      SCOPED_TRACE(std::string(zero_copy ? "zero copy" : "copies") + ", chunk " + std::to_string(chunk));
      OpenclOptions o = pocl();
      o.zero_copy = zero_copy;
      o.max_chunk = chunk;
      OpenclBackend b(o);
      std::vector<CellCode> got(n);
      std::vector<std::uint64_t> got_off(n + 1);
      classify_cells_codes(b, complex, values, got, got_off, co);
      EXPECT_TRUE(got == ref);
      EXPECT_EQ(got_off, ref_off);
      std::vector<std::uint8_t> subcases(n);
      std::vector<std::uint64_t> offsets(n + 1);
      b.classify_cells(complex, values, {subcases, offsets}, co);
      EXPECT_EQ(subcases, ref_subcases);
      EXPECT_EQ(offsets, ref_off);
      // The SDF's own output, left on the device, classified without a second upload.
      std::vector<double> sdf(complex.points.size());
      SdfSource two;
      two.shape = ShapeKind::kTwoHoled;
      b.signed_distance(two, complex.points, sdf);
      ClassifyOptions resident = co;
      resident.values_from_last_sdf = true;
      b.classify_cells(complex, sdf, {subcases, offsets}, resident);
      std::vector<CellCode> direct(n);
      std::vector<std::uint64_t> direct_off(n + 1);
      classify_cells_codes(*make_cpu_backend(), complex, apply_zero_rule(complex, sdf), direct, direct_off);
      for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(subcases[i], static_cast<std::uint8_t>(direct[i].subcase)) << i;
      EXPECT_EQ(offsets, direct_off);
    }
  // A complex that is not the promised grid is refused.
  ClassifyOptions wrong = co;
  wrong.uniform_cells_per_axis = z.grid.cells_per_axis() + 1;
  std::vector<std::uint8_t> subcases(n);
  std::vector<std::uint64_t> offsets(n + 1);
  EXPECT_THROW(device().classify_cells(complex, values, {subcases, offsets}, wrong), std::invalid_argument);
}

// ---- The fp32 path (kernels/sdf_fp32.h), forced on PoCL -----------------------------------

namespace {

OpenclBackend& fp32_device() {
  static OpenclBackend b([] {
    OpenclOptions o = pocl();
    o.force_fp32 = true;
    return o;
  }());
  return b;
}

}  // namespace

// Single precision finds the candidate triangles, the host computes the values in double: equal to
// core bit for bit on points at vertices, on edges, inside faces, +-1e-12 and +-1e-6 of the
// diagonal off faces (values inside the float guard band), exact ties (every vertex is equally
// near all its triangles) and far points; the UV sphere's poles have 30 triangles around one
// vertex (more than the kernel's candidate list: those points go to the host whole).
TEST(OpenclFp32, SurfaceSdfEqualsReferenceBitForBit) {
  for (const auto& [name, surface] :
       {std::pair{"torus", tessellate(ShapeKind::kTorus, 48)}, std::pair{"sphere", tessellate(ShapeKind::kSphere, 30)},
        std::pair{"gearwheel", gearwheel()}}) {
    SCOPED_TRACE(name);
    std::vector<Vec3> pts = feature_points(surface, 20000, 17);
    // Values at +-1e-10 (the mesher's zero tolerance scale) off the faces.
    const double diag = surface.bounds().diagonal();
    for (std::size_t t = 0; t < surface.triangles.size(); t += 5) {
      const auto& tri = surface.triangles[t];
      const Vec3 a = surface.vertices[tri[0]], b = surface.vertices[tri[1]], c = surface.vertices[tri[2]];
      const Vec3 n = normalized(cross(b - a, c - a));
      for (double off : {1e-10, -1e-10}) pts.push_back((a + b + c) / 3.0 + off * diag * n);
    }
    std::vector<double> ref(pts.size()), got(pts.size());
    SurfaceSdf(surface).evaluate(pts, ref);
    SdfSource src;
    src.surface = &surface;
    fp32_device().reset_profile();
    fp32_device().signed_distance(src, pts, got);
    const long i = first_difference(ref, got);
    EXPECT_EQ(i, -1) << "point " << i << ": cpu " << (i >= 0 ? ref[i] : 0) << " fp32 path " << (i >= 0 ? got[i] : 0);
    const Fp32Stats& st = fp32_device().fp32_stats();
    EXPECT_EQ(st.points, pts.size());
    // The device really decided most points: the host evaluated few whole.
    EXPECT_LT(st.host_points, pts.size() / 4);
    std::printf("[ fp32 path ] %s: %zu points, %.2f candidates per point, %llu (%.2f%%) evaluated whole on the host\n",
                name, pts.size(), double(st.candidates) / double(pts.size() - st.host_points),
                (unsigned long long)st.host_points, 100.0 * double(st.host_points) / double(pts.size()));
  }
}

TEST(Opencl, MissingPlatformIsAnInputError) {
  OpenclOptions o;
  o.platform = "no such platform";
  EXPECT_THROW(OpenclBackend b(o), InputError);
}

// ---- Whole CLI runs ------------------------------------------------------------------------

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// env: prepended to the opencl run's command (MCHEX_FORCE_FP32=1: the fp32 path).
void expect_same_mesh_files(const std::string& input_args, const std::string& tag, const std::string& env = "") {
  const fs::path dir = scratch("cli-" + tag);
  std::string files[2][2];
  for (int k = 0; k < 2; ++k) {
    const std::string backend = k ? "opencl" : "cpu";
    const fs::path in = dir / (backend + "-inside.mesh"), out = dir / (backend + "-outside.mesh");
    const std::string cmd = (k ? env + " " : std::string()) +
                            "XDG_CACHE_HOME=" + (fs::temp_directory_path() / "mchex_test_opencl_cli_cache").string() +
                            " " + MCHEX_BINARY + " --quiet mesh " + input_args + " --backend " + backend + " -o " +
                            in.string() + " --outside " + out.string();
    ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
    files[k][0] = slurp(in);
    files[k][1] = slurp(out);
    ASSERT_GT(files[k][0].size(), 100u);
  }
  EXPECT_TRUE(files[0][0] == files[1][0]) << "inside meshes differ";
  EXPECT_TRUE(files[0][1] == files[1][1]) << "outside meshes differ";
}

}  // namespace

TEST(OpenclCli, ShapeMeshIsByteIdenticalToCpu) {
  expect_same_mesh_files("--shape two-holed --depth 3 --method mchex", "two-holed");
  expect_same_mesh_files("--shape torus --depth 3 --method ro", "torus");
}

TEST(OpenclCli, ModelMeshIsByteIdenticalToCpu) {
  const fs::path gear = fs::path(MCHEX_TEST_DATA) / "npm/node_modules/stl-models/objects/gearwheel.bin.stl";
  expect_same_mesh_files(gear.string() + " --depth 3 --method mchex", "gearwheel");
}

// Exact crossings search the field's zero on every cut edge through the run's SDF batch (on the
// device here): the same points, so the same meshes.
TEST(OpenclCli, ExactCrossingsMeshIsByteIdenticalToCpu) {
  const fs::path gear = fs::path(MCHEX_TEST_DATA) / "npm/node_modules/stl-models/objects/gearwheel.bin.stl";
  expect_same_mesh_files(gear.string() + " --depth 3 --crossings exact", "gearwheel-exact");
  expect_same_mesh_files("--shape torus --depth 3 --crossings exact --repel", "torus-exact");
}

// The fp32 path end to end: the surface SDF from float candidates and host doubles, the shape's
// values on the host; the meshes are the cpu reference's byte for byte.
TEST(OpenclCli, Fp32PathMeshIsByteIdenticalToCpu) {
  const fs::path gear = fs::path(MCHEX_TEST_DATA) / "npm/node_modules/stl-models/objects/gearwheel.bin.stl";
  expect_same_mesh_files(gear.string() + " --depth 3 --method mchex", "gearwheel-fp32", "MCHEX_FORCE_FP32=1");
  expect_same_mesh_files("--shape two-holed --depth 3 --method mchex", "two-holed-fp32", "MCHEX_FORCE_FP32=1");
}

TEST(OpenclCli, UnknownBackendExitsOne) {
  const std::string cmd =
      std::string(MCHEX_BINARY) + " --quiet mesh --shape sphere --backend cuda -o /dev/null 2>/dev/null";
  EXPECT_EQ(WEXITSTATUS(std::system(cmd.c_str())), 1);
}
