// One conformance suite over every backend variant (core/device/backend.h: the device backends
// must give core's answers): cpu; opencl on PoCL, fp64 and the forced fp32 path; vulkan on
// lavapipe with each surface-SDF shader it can run (the subgroup walk, one walk per invocation
// over texel buffers, lavapipe's default, and the same over storage buffers) and the forced fp32
// path. Each question is asked of every variant, with the device's own chunk sizes and, where it
// says so, with small ones (chunk boundaries mid-batch and a short last chunk). Every comparison
// is exact: SDF values and refinement errors bit for bit (+0 and -0 differ), CellCodes field for
// field, offsets against an independent sum of core's hex counts. Inputs are random and
// adversarial: points on triangle vertices, edges and faces and just off them, far points; all 256
// sign patterns with random, tied, tiny and many-decade magnitudes and signed zeros.
//
// A variant whose device is absent (no PoCL, no lavapipe) or that is not built into this binary
// (CMake MCHEX_WITH_OPENCL / MCHEX_WITH_VULKAN OFF) is skipped with the reason, never passed;
// setup.sh installs both drivers, so on a full build nothing here may skip. The API-specific
// questions (program and pipeline caches, buffer pools, device listing, texel limits) stay in
// test_opencl.cpp and test_vulkan.cpp.
#include <unistd.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/cutting/local_refinement.h"
#include "core/cutting/mc33.h"
#include "core/cutting/mchex_mesher.h"
#include "core/grid/grid.h"
#include "core/grid/refinement_error.h"
#include "core/sdf/sdf.h"
#include "core/sdf/shapes.h"
#include "host/backends/cpu.h"
#include "tests/backend_samples.h"
#if MCHEX_WITH_OPENCL
#include "host/backends/opencl.h"
#endif
#if MCHEX_WITH_VULKAN
#include "host/backends/vulkan.h"
#endif

namespace fs = std::filesystem;
using namespace mchex;
using namespace mchex::test;

namespace {

// Before any device call: lavapipe's ICD only (as test_vulkan), Mesa's shader cache in the
// scratch folder, and no environment that would change a variant's path.
const auto* const kEnvironment = ::testing::AddGlobalTestEnvironment(new LavapipeEnvironment);

// The surface SDF's shader on vulkan (VulkanOptions::sdf_walk, sdf_storage_reads): kNone, the
// device's default (on lavapipe one walk per invocation over texel buffers).
enum class Walk { kNone, kSubgroup, kSingleStorage };

struct Variant {
  const char* name;  // the gtest parameter name
  const char* api;   // DeviceInfo::backend
  bool fp32;
  Walk walk;
};

std::string variant_name(const ::testing::TestParamInfo<Variant>& info) { return info.param.name; }
void PrintTo(const Variant& v, std::ostream* os) { *os << v.name; }

// The variant's backend with the device's own chunks (max_chunk 0) or at most max_chunk items per
// dispatch; made once per test process, variant and chunk (PoCL compiles its program in seconds). Empty with `why` set
// when the variant cannot run here.
Backend* backend_of(const Variant& v, std::size_t max_chunk, std::string& why) {
  static std::map<std::pair<std::string, std::size_t>, std::unique_ptr<Backend>> made;
  static std::map<std::pair<std::string, std::size_t>, std::string> failed;
  const auto key = std::pair{std::string(v.name), max_chunk};
  if (auto it = made.find(key); it != made.end()) return it->second.get();
  if (auto it = failed.find(key); it != failed.end()) {
    why = it->second;
    return nullptr;
  }
  std::unique_ptr<Backend> b;
  try {
    if (std::string(v.api) == "cpu") {
      b = make_cpu_backend();
    } else if (std::string(v.api) == "opencl") {
#if MCHEX_WITH_OPENCL
      OpenclOptions o;
      o.platform = "Portable Computing Language";
      o.cache_dir = (fs::temp_directory_path() / "mchex_test_opencl_cache").string();
      o.max_chunk = max_chunk;
      o.force_fp32 = v.fp32;
      b = std::make_unique<OpenclBackend>(o);
#else
      why = "the opencl backend is not built into this binary (MCHEX_WITH_OPENCL=OFF)";
#endif
    } else {
#if MCHEX_WITH_VULKAN
      VulkanOptions o;
      o.device = "llvmpipe";
      o.cache_dir = process_scratch() / "pipelines";
      o.max_chunk = max_chunk;
      o.force_fp32 = v.fp32;
      o.sdf_walk = v.walk == Walk::kSubgroup ? VulkanOptions::SdfWalk::kSubgroup
                   : v.walk == Walk::kNone   ? VulkanOptions::SdfWalk::kAuto
                                             : VulkanOptions::SdfWalk::kSingle;
      o.sdf_storage_reads = v.walk == Walk::kSingleStorage;
      b = std::make_unique<VulkanBackend>(o);
#else
      why = "the vulkan backend is not built into this binary (MCHEX_WITH_VULKAN=OFF)";
#endif
    }
  } catch (const InputError& e) {
    why = std::string("no device for this variant here: ") + e.what();
  }
  if (!b) {
    failed[key] = why;
    return nullptr;
  }
  return (made[key] = std::move(b)).get();
}

class Conformance : public ::testing::TestWithParam<Variant> {
 protected:
  void SetUp() override {
    std::string why;
    whole_ = backend_of(GetParam(), 0, why);
    if (!whole_) GTEST_SKIP() << GetParam().name << ": " << why;
  }
  Backend& whole() const { return *whole_; }
  // The same variant with at most n items per dispatch.
  Backend& chunked(std::size_t n) const {
    std::string why;
    Backend* b = backend_of(GetParam(), n, why);
    if (!b) throw std::runtime_error(why);
    return *b;
  }

 private:
  Backend* whole_ = nullptr;
};

// `b`'s classification of every cell equals core's classify() field for field, with the offsets
// summed here from core's hex counts; returns the codes.
std::vector<CellCode> expect_codes_are_cores(Backend& b, const HexComplex& complex, const std::vector<double>& values,
                                             const ClassifyOptions& options = {},
                                             const std::vector<double>* ruled = nullptr) {
  std::vector<CellCode> codes(complex.cells.size());
  std::vector<std::uint64_t> offsets(complex.cells.size() + 1);
  classify_cells_codes(b, complex, values, codes, offsets, options);
  expect_same_as_reference(complex, ruled ? *ruled : values, codes, offsets);
  return codes;
}

void expect_sdf_is(Backend& b, const SdfSource& source, const std::vector<Vec3>& pts, const std::vector<double>& want) {
  std::vector<double> got(pts.size());
  b.signed_distance(source, pts, got);
  expect_bit_equal(got, want, pts);
}

}  // namespace

// The device, precision and shaders each variant asks for are what it runs.
TEST_P(Conformance, RunsTheVariantItNames) {
  const DeviceInfo& d = whole().device();
  EXPECT_EQ(d.backend, GetParam().api);
  EXPECT_EQ(d.precision, GetParam().fp32 ? "fp32" : "fp64");
#if MCHEX_WITH_VULKAN
  if (auto* vk = dynamic_cast<VulkanBackend*>(&whole()); vk && !GetParam().fp32) {
    // lavapipe has subgroup arithmetic (subgroups of 8), but its default is one walk per
    // invocation over texel buffers.
    EXPECT_EQ(vk->sdf_subgroup_walk(), GetParam().walk == Walk::kSubgroup);
    EXPECT_EQ(vk->sdf_texel_reads(), GetParam().walk == Walk::kNone);
  }
#endif
}

// Closed, open (a band of triangles removed) and a soup (flipped, duplicated and zero-area
// triangles), at the adversarial points.
TEST_P(Conformance, SurfaceSdfIsCoresOnClosedOpenAndDegenerateSurfaces) {
  std::mt19937_64 rng(22);
  for (const auto& [name, s] : closed_open_and_degenerate_surfaces()) {
    SCOPED_TRACE(name);
    const std::vector<Vec3> pts = adversarial_points(s, rng);
    std::vector<double> want(pts.size());
    SurfaceSdf(s).evaluate(pts, want);
    SdfSource source;
    source.surface = &s;
    expect_sdf_is(whole(), source, pts, want);
  }
}

// Grid points over a fine torus (perf/bench_backends's workload, smaller): many are exactly as far
// from two or more triangles (the grid and the tessellation share symmetry planes), so the tie
// rule decides, and each invocation's turns seed one another across the Morton order.
TEST_P(Conformance, SurfaceSdfOnAGridOverAFineTorusIsCores) {
  const TriangleSurface torus = tessellate(ShapeKind::kTorus, 256);
  const std::vector<Vec3> pts = grid_points_over(torus, 40);
  std::vector<double> want(pts.size());
  SurfaceSdf(torus).evaluate(pts, want);
  SdfSource source;
  source.surface = &torus;
  expect_sdf_is(whole(), source, pts, want);
}

// Every vertex, points along every edge and inside every triangle, pushed off by tiny and moderate
// amounts, random and far points, on two tessellations and a real model.
TEST_P(Conformance, SurfaceSdfIsCoresOnModelsAtTheirFeatures) {
  for (const auto& [name, surface] :
       {std::pair{"torus", tessellate(ShapeKind::kTorus, 48)}, std::pair{"sphere", tessellate(ShapeKind::kSphere, 30)},
        std::pair{"gearwheel", gearwheel()}}) {
    SCOPED_TRACE(name);
    const std::vector<Vec3> pts = feature_points(surface, 20000, 7);
    std::vector<double> ref(pts.size()), got(pts.size());
    SurfaceSdf(surface).evaluate(pts, ref);
    SdfSource src;
    src.surface = &surface;
    whole().signed_distance(src, pts, got);
    const long i = first_difference(ref, got);
    EXPECT_EQ(i, -1) << "point " << i << " (" << (i >= 0 ? pts[i].x : 0) << ", " << (i >= 0 ? pts[i].y : 0) << ", "
                     << (i >= 0 ? pts[i].z : 0) << "): cpu " << (i >= 0 ? ref[i] : 0) << " device "
                     << (i >= 0 ? got[i] : 0);
    // The adversarial set really has points on the surface (value exactly 0) and both signs.
    std::size_t zeros = 0, inside = 0, outside = 0;
    for (double v : ref) zeros += v == 0, inside += v > 0, outside += v < 0;
    EXPECT_GT(zeros, surface.vertices.size() / 2);
    EXPECT_GT(inside, 1000u);
    EXPECT_GT(outside, 1000u);
  }
}

TEST_P(Conformance, SurfaceSdfOnAModelGridAcrossChunks) {
  const TriangleSurface surface = gearwheel();
  const UniformGrid grid(padded_cube(surface.bounds(), 0.1), 3);
  const std::vector<Vec3> pts = grid.vertices();
  std::vector<double> ref(pts.size()), got(pts.size());
  SurfaceSdf(surface).evaluate(pts, ref);
  SdfSource src;
  src.surface = &surface;
  chunked(1001).signed_distance(src, pts, got);  // chunk boundaries mid-row, and a short last chunk
  EXPECT_EQ(first_difference(ref, got), -1);
}

TEST_P(Conformance, EmptySurfaceIsOutsideEverywhere) {
  const TriangleSurface empty;
  SdfSource src;
  src.surface = &empty;
  std::vector<Vec3> pts = {{0, 0, 0}, {1, 2, 3}};
  std::vector<double> ref(2), got(2);
  SurfaceSdf(empty).evaluate(pts, ref);
  whole().signed_distance(src, pts, got);
  EXPECT_EQ(first_difference(ref, got), -1);
  EXPECT_EQ(got[0], -std::numeric_limits<double>::infinity());
}

TEST_P(Conformance, ShapeSdfIsCores) {
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
    std::vector<double> want(pts.size());
    reference.evaluate(pts, want);
    SdfSource source;
    source.shape = info.kind;
    SCOPED_TRACE(std::string(info.name));
    expect_sdf_is(whole(), source, pts, want);
  }
}

TEST_P(Conformance, ShapeSdfOnAxesPlanesAndAGridIsCores) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> coord(-1.6, 1.6);
  std::vector<Vec3> pts;
  for (int i = 0; i < 40000; ++i) pts.push_back({coord(rng), coord(rng), coord(rng)});
  // Symmetry planes, axes, the origin (the two-holed junction), and grid points.
  for (double t = -1.5; t <= 1.5; t += 0.125) {
    pts.push_back({t, 0, 0});
    pts.push_back({0, t, 0});
    pts.push_back({0, 0, t});
    pts.push_back({t, t, 0});
  }
  const UniformGrid grid(padded_cube(ShapeSdf(ShapeKind::kTorus).bounds(), 0.1), 3);
  for (const Vec3& p : grid.vertices()) pts.push_back(p);
  for (const ShapeInfo& s : shape_catalog()) {
    SCOPED_TRACE(std::string(s.name));
    std::vector<double> ref(pts.size()), got(pts.size());
    ShapeSdf(s.kind).evaluate(pts, ref);
    SdfSource src;
    src.shape = s.kind;
    whole().signed_distance(src, pts, got);
    EXPECT_EQ(first_difference(ref, got), -1);
  }
}

TEST_P(Conformance, RefinementErrorAtRandomScalesIsCores) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> v(-1, 1);
  std::vector<std::array<double, kChildLatticePoints>> lattice;
  std::vector<double> sizes;
  // Random values at random scales.
  for (int i = 0; i < 3000; ++i) {
    std::array<double, kChildLatticePoints> f;
    const double scale = std::pow(10.0, int(rng() % 12) - 6);
    for (double& x : f) x = scale * v(rng);
    lattice.push_back(f);
    sizes.push_back(std::pow(2.0, int(rng() % 10) - 5) * 0.37);
  }
  // Trilinear data (change exactly 0 at many points), constant data (zero gradient: 0 or
  // infinity), and the SDF of a real shape on real cells.
  for (int i = 0; i < 200; ++i) {
    std::array<double, kChildLatticePoints> f;
    const double a = v(rng), b = v(rng), c = v(rng), d = v(rng);
    for (int z = 0; z < 4; ++z)
      for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 4; ++x) f[child_lattice_index(x, y, z)] = a + b * x + c * y + d * z;
    lattice.push_back(f);
    sizes.push_back(0.5);
    std::array<double, kChildLatticePoints> flat;
    flat.fill(a);
    if (i % 2) flat[child_lattice_index(1, 2, 1)] += 1e-3;
    lattice.push_back(flat);
    sizes.push_back(1);
  }
  const ShapeSdf torus(ShapeKind::kTwoHoled);
  std::uniform_real_distribution<double> pos(-1.5, 1.2);
  for (int i = 0; i < 1000; ++i) {
    const Vec3 lo{pos(rng), pos(rng), pos(rng) / 3};
    const double h = 0.05 + 0.3 * std::abs(v(rng));
    std::array<double, kChildLatticePoints> f;
    for (int z = 0; z < 4; ++z)
      for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 4; ++x) f[child_lattice_index(x, y, z)] = torus(lo + Vec3{x * h / 3, y * h / 3, z * h / 3});
    lattice.push_back(f);
    sizes.push_back(h);
  }
  std::vector<double> ref(lattice.size()), got(lattice.size());
  make_cpu_backend()->refinement_error(lattice, sizes, ref);
  for (std::size_t i = 0; i < lattice.size(); ++i)
    ASSERT_TRUE(same_bits(ref[i], refinement_error(lattice[i], sizes[i])));
  whole().refinement_error(lattice, sizes, got);
  EXPECT_EQ(first_difference(ref, got), -1);
  std::size_t infinite = 0, zero = 0;
  for (double e : ref) infinite += std::isinf(e), zero += e == 0;
  EXPECT_GT(infinite, 50u);
  EXPECT_GT(zero, 100u);
}

TEST_P(Conformance, RefinementErrorOfSmoothRoughTrilinearAndFlatFieldsIsCores) {
  std::mt19937_64 rng(7);
  std::vector<std::array<double, kChildLatticePoints>> lattice;
  std::vector<double> sizes;
  add_smooth_rough_trilinear_and_flat_fields(rng, 3000, lattice, sizes);
  std::vector<double> device(lattice.size());
  whole().refinement_error(lattice, sizes, device);
  int infinite = 0;
  for (std::size_t i = 0; i < lattice.size(); ++i) {
    const double ref = refinement_error(lattice[i], sizes[i]);
    ASSERT_EQ(bits(device[i]), bits(ref)) << "cell " << i << ": " << device[i] << " vs " << ref;
    infinite += std::isinf(ref);
  }
  EXPECT_GT(infinite, 0);  // the zero-gradient rule was exercised
}

TEST_P(Conformance, ClassificationOfAll256PatternsWithRandomMagnitudes) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.001, 1);
  const CellBatch b = all_patterns(40, [&](int) { return u(rng); });
  expect_same_classification(whole(), b, "random");
}

TEST_P(Conformance, ClassificationWithTiesAndTinyValues) {
  std::mt19937_64 rng(9);
  // Magnitudes from a small set of powers of two: face tests tie (p0 p1 == n0 n1) and the
  // interior test's Q(t*) hits 0 often.
  const double small[] = {0.25, 0.5, 1, 2, 4};
  const CellBatch ties = all_patterns(30, [&](int) { return small[rng() % 5]; });
  expect_same_classification(whole(), ties, "power-of-two ties");
  // Exactly equal magnitudes everywhere: every ambiguous face is a tie.
  const CellBatch equal = all_patterns(1, [](int) { return 1.0; });
  expect_same_classification(whole(), equal, "all equal");
  // Tiny values of the mesher's zero perturbation next to O(1) values, and wide ranges.
  std::uniform_int_distribution<int> e(-10, 3);
  const CellBatch tiny =
      all_patterns(20, [&](int) { return rng() % 3 ? std::ldexp(1.0 + (rng() % 7) / 8.0, e(rng)) : 1e-10; });
  expect_same_classification(whole(), tiny, "tiny and wide");
  // Signed zeros count as outside, like any value <= 0.
  CellBatch zeros;
  for (int mask = 0; mask < 256; ++mask) {
    std::array<double, 8> f;
    for (int c = 0; c < 8; ++c) f[c] = (mask >> c & 1) ? 0.5 + c : (c % 2 ? 0.0 : -0.0);
    zeros.add(f);
  }
  expect_same_classification(whole(), zeros, "signed zeros");
}

TEST_P(Conformance, ClassificationReachesEverySubcaseAndTunnel) {
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> u(-1, 1);
  CellBatch b;
  for (int i = 0; i < 300000; ++i) {
    std::array<double, 8> f;
    for (double& x : f) x = u(rng);
    b.add(f);
  }
  expect_same_classification(whole(), b, "uniform random");
  std::vector<int> seen(kNumSubcases, 0);
  for (std::size_t i = 0; i < b.complex.cells.size(); ++i) {
    std::array<double, 8> f;
    for (int k = 0; k < 8; ++k) f[k] = b.values[b.complex.cells[i][k]];
    seen[int(classify(f).subcase)] = 1;
  }
  int reached = 0;
  for (int s : seen) reached += s;
  EXPECT_EQ(reached, kNumSubcases);  // every subcase (tunnels included) was compared
}

TEST_P(Conformance, ClassifyEverySignPatternWithRandomTiedAndGuardBandMagnitudes) {
  std::mt19937_64 rng(11);
  std::size_t cells = 0;
  const std::vector<double> values = adversarial_values(cells, rng);
  const HexComplex complex = separate_cells(cells);
  const std::vector<CellCode> codes = expect_codes_are_cores(whole(), complex, values);
  std::set<int> masks;
  for (const CellCode& c : codes) masks.insert(c.sign_mask);
  EXPECT_EQ(masks.size(), 256u);
}

TEST_P(Conformance, ClassifyRandomFieldsReachEverySubcaseIncludingTunnels) {
  // Random corner values hit all 32 subcase slots (the tunnel subcases are rare: many cells).
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  const std::size_t cells = 400000;
  HexComplex complex = separate_cells(cells);
  std::vector<double> values(8 * cells);
  for (double& v : values) v = u(rng);
  const std::vector<CellCode> codes = expect_codes_are_cores(whole(), complex, values);
  std::set<int> subcases;
  for (const CellCode& c : codes) subcases.insert(static_cast<int>(c.subcase));
  EXPECT_EQ(subcases.size(), std::size_t(kNumSubcases));
}

TEST_P(Conformance, ClassificationOfAGridAcrossChunks) {
  const UniformGrid grid(padded_cube(ShapeSdf(ShapeKind::kTwoHoled).bounds(), 0.1), 3);
  const HexComplex complex = uniform_complex(grid);
  std::vector<double> values(complex.points.size());
  ShapeSdf(ShapeKind::kTwoHoled).evaluate(complex.points, values);
  CellBatch batch{complex, values};
  expect_same_classification(chunked(777), batch, "two-holed grid, chunks of 777");
}

// The crossing parameters (ClassifyOptions' `crossings`): core's f_a / (f_a - f_b) bit for bit on
// every cut edge of every sign pattern (random, tied, tiny and wide magnitudes, signed zeros), and
// on the uniform grid with the zero rule applied by the backend, whole and in chunks.
TEST_P(Conformance, CrossingParametersAreCoresBitForBit) {
  std::mt19937_64 rng(31);
  std::uniform_int_distribution<int> e(-10, 3);
  const CellBatch patterns = all_patterns(20, [&](int c) {
    return c == 7 ? 1e-10 : rng() % 4 ? std::ldexp(1.0 + (rng() % 7) / 8.0, e(rng)) : (c % 2 ? 0.0 : -0.0);
  });
  EXPECT_GT(expect_crossings_are_cores(whole(), patterns.complex, patterns.values), 20000u);
  std::mt19937_64 rng2(12);
  std::size_t cells = 0;
  const std::vector<double> values = adversarial_values(cells, rng2);
  EXPECT_GT(expect_crossings_are_cores(whole(), separate_cells(cells), values), 20000u);
  const ZeroRuleGrid z = zero_rule_grid();
  const ClassifyOptions co = z.options();
  EXPECT_GT(expect_crossings_are_cores(whole(), z.complex, z.values, co), 1000u);
  EXPECT_GT(expect_crossings_are_cores(chunked(777), z.complex, z.values, co), 1000u);
  EXPECT_GT(expect_crossings_are_cores(chunked(1000), z.complex, z.values, co), 1000u);
}

// The mesher's call (host/cli/main.cpp): raw SDF values with the zero rule applied by the backend,
// corner ids computed for a uniform grid, only the subcase bytes and offsets back, and the values
// the SDF left on the device reused (ClassifyOptions::values_from_last_sdf). Every field equals
// core's classification of apply_zero_rule's values; whole and in chunks.
TEST_P(Conformance, ClassifyAUniformGridWithTheZeroRule) {
  const ZeroRuleGrid z = zero_rule_grid();
  const HexComplex& complex = z.complex;
  const std::vector<double>& values = z.values;
  ASSERT_GT(z.moved, 20u);
  const std::size_t n = complex.cells.size();
  const ClassifyOptions co = z.options();
  for (const std::size_t chunk : {std::size_t(0), std::size_t(1000)}) {
    SCOPED_TRACE("chunk " + std::to_string(chunk));
    Backend& b = chunk ? chunked(chunk) : whole();
    std::vector<CellCode> codes = expect_codes_are_cores(b, complex, values, co, &z.ruled);
    std::vector<std::uint8_t> subcases(n);
    std::vector<std::uint64_t> offsets(n + 1), offsets2(n + 1);
    std::vector<CellCode> unused(n);
    classify_cells_codes(b, complex, values, unused, offsets, co);
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
    const std::vector<double> ruled = apply_zero_rule(complex, sdf);
    expect_codes_are_cores(b, complex, sdf, resident, &ruled);
  }
  // A complex that is not the promised grid is refused.
  ClassifyOptions wrong = co;
  wrong.uniform_cells_per_axis = z.grid.cells_per_axis() + 1;
  std::vector<std::uint8_t> subcases(n);
  std::vector<std::uint64_t> offsets(n + 1);
  EXPECT_THROW(whole().classify_cells(complex, values, {subcases, offsets}, wrong), std::invalid_argument);
}

TEST_P(Conformance, NonFiniteValueIsAnInputErrorLikeTheReference) {
  CellBatch b;
  b.add({1, -1, 1, -1, 1, -1, 1, std::numeric_limits<double>::quiet_NaN()});
  std::vector<CellCode> one(1);
  std::vector<std::uint64_t> one_offsets(2);
  EXPECT_THROW(classify_cells_codes(whole(), b.complex, b.values, one, one_offsets), InputError);
  EXPECT_THROW(classify_cells_codes(*make_cpu_backend(), b.complex, b.values, one, one_offsets), InputError);

  HexComplex complex = separate_cells(2);
  std::vector<double> values(16, 1.0);
  values[11] = std::numeric_limits<double>::quiet_NaN();
  std::vector<CellCode> codes(2);
  std::vector<std::uint64_t> offsets(3);
  EXPECT_THROW(classify_cells_codes(whole(), complex, values, codes, offsets), InputError);
  // A non-finite value at a point no cell uses is not an error (the reference never sees it).
  complex.points.push_back({});
  values.assign(17, 1.0);
  values[16] = std::numeric_limits<double>::infinity();
  EXPECT_NO_THROW(classify_cells_codes(whole(), complex, values, codes, offsets));
  EXPECT_EQ(offsets[2], 16u);
}

// The stages the fp32 path runs on the host (shapes, refinement errors, the mesher's
// classification call with the values the SDF left), on every variant: the cpu backend's.
TEST_P(Conformance, ShapesRefinementAndClassificationAreTheReferences) {
  const ZeroRuleGrid z = zero_rule_grid();
  const std::unique_ptr<Backend> cpu = make_cpu_backend();
  SdfSource two;
  two.shape = ShapeKind::kTwoHoled;
  std::vector<double> want(z.complex.points.size()), got(z.complex.points.size());
  cpu->signed_distance(two, z.complex.points, want);
  whole().signed_distance(two, z.complex.points, got);
  expect_bit_equal(got, want, z.complex.points);

  ClassifyOptions co = z.options();
  co.values_from_last_sdf = true;
  const std::vector<double> ruled = apply_zero_rule(z.complex, got);
  expect_codes_are_cores(whole(), z.complex, got, co, &ruled);

  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<std::array<double, kChildLatticePoints>> lattice(500);
  std::vector<double> sizes(lattice.size()), e32(lattice.size()), e64(lattice.size());
  for (std::size_t i = 0; i < lattice.size(); ++i) {
    for (double& v : lattice[i]) v = u(rng);
    sizes[i] = std::ldexp(1.0, -int(i % 7));
  }
  whole().refinement_error(lattice, sizes, e32);
  cpu->refinement_error(lattice, sizes, e64);
  for (std::size_t i = 0; i < lattice.size(); ++i) ASSERT_EQ(bits(e32[i]), bits(e64[i])) << i;
}

// Wrong batch sizes are refused before any device work; empty batches need no device.
TEST_P(Conformance, BatchSizesAreChecked) {
  const std::vector<Vec3> pts(3);
  std::vector<double> two(2);
  SdfSource source;
  EXPECT_THROW(whole().signed_distance(source, pts, two), std::invalid_argument);
  const std::vector<std::array<double, kChildLatticePoints>> lattice(3);
  const std::vector<double> sizes(2, 1.0);
  std::vector<double> errors(3);
  EXPECT_THROW(whole().refinement_error(lattice, sizes, errors), std::invalid_argument);
  const HexComplex complex = separate_cells(2);
  std::vector<double> values(16, 1.0);
  std::vector<std::uint8_t> subcases(1);
  std::vector<std::uint64_t> offsets(3);
  EXPECT_THROW(whole().classify_cells(complex, values, {subcases, offsets}), std::invalid_argument);
  whole().signed_distance(source, {}, {});
  whole().refinement_error({}, {}, {});
  std::vector<std::uint64_t> one(1, 9);
  whole().classify_cells(HexComplex{}, {}, {{}, one});
  EXPECT_EQ(one[0], 0u);
}

INSTANTIATE_TEST_SUITE_P(Backends, Conformance,
                         ::testing::Values(Variant{"cpu", "cpu", false, Walk::kNone},
                                           Variant{"opencl", "opencl", false, Walk::kNone},
                                           Variant{"opencl_fp32", "opencl", true, Walk::kNone},
                                           Variant{"vulkan", "vulkan", false, Walk::kNone},
                                           Variant{"vulkan_subgroup", "vulkan", false, Walk::kSubgroup},
                                           Variant{"vulkan_storage", "vulkan", false, Walk::kSingleStorage},
                                           Variant{"vulkan_fp32", "vulkan", true, Walk::kNone}),
                         variant_name);
