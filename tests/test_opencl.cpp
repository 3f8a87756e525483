// The opencl backend against the cpu reference, on PoCL (selected by platform name; a missing
// PoCL is a failure, never a skip: setup.sh installs it). Every comparison is exact: SDF values,
// refinement errors and offsets bit for bit (memcmp, so +0 and -0 differ), CellCodes field for
// field. Inputs are random and adversarial: points on triangle vertices, edges and faces, far
// points, all 256 sign patterns with random, tie-inducing and tiny magnitudes and signed zeros,
// chunk boundaries. Then whole CLI runs: `mesh --backend opencl` and `--backend cpu` write
// byte-identical files.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <bit>
#include <cmath>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

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
#include "core/device/backend.h"
#include "host/backends/cpu.h"
#include "host/backends/opencl.h"
#include "core/io/surface_io.h"
#include "host/backends/registry.h"

namespace fs = std::filesystem;
using namespace mchex;

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

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Index of the first value that differs in bits, or -1.
long first_difference(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return 0;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!same_bits(a[i], b[i])) return long(i);
  return -1;
}

TriangleSurface gearwheel() {
  return read_surface(fs::path(MCHEX_TEST_DATA) / "npm/node_modules/stl-models/objects/gearwheel.bin.stl");
}

// Points that stress the closest-point regions and the tie rule: every vertex, points along
// every edge (its ends, midpoint and quarter points), barycentric points inside every triangle,
// the same points pushed off along the face normal by tiny and moderate amounts, random points
// in and around the box, and far points.
std::vector<Vec3> adversarial_points(const TriangleSurface& s, std::size_t random_count, unsigned seed) {
  std::vector<Vec3> pts;
  for (const Vec3& v : s.vertices) pts.push_back(v);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0, 1);
  const Box box = s.bounds();
  const double diag = box.diagonal();
  for (std::size_t t = 0; t < s.triangles.size(); t += 3) {
    const auto& tri = s.triangles[t];
    const Vec3 a = s.vertices[tri[0]], b = s.vertices[tri[1]], c = s.vertices[tri[2]];
    for (double u : {0.25, 0.5, 0.75}) pts.push_back(a + u * (b - a));
    pts.push_back(b + 0.5 * (c - b));
    const Vec3 centre = (a + b + c) / 3.0;
    pts.push_back(centre);
    const Vec3 n = normalized(cross(b - a, c - a));
    for (double off : {1e-12, -1e-12, 1e-6, -1e-6, 1e-2, -1e-2}) pts.push_back(centre + off * diag * n);
    pts.push_back(a + unit(rng) * (b - a));
  }
  for (std::size_t i = 0; i < random_count; ++i) {
    const Vec3 r{unit(rng), unit(rng), unit(rng)};
    pts.push_back(box.lo - 0.2 * box.size() + Vec3{1.4 * r.x * box.size().x, 1.4 * r.y * box.size().y, 1.4 * r.z * box.size().z});
  }
  for (double far : {10.0, 1e3}) {
    pts.push_back(box.center() + Vec3{far * diag, 0, 0});
    pts.push_back(box.center() - Vec3{0.3 * far * diag, far * diag, 0.7 * far * diag});
  }
  return pts;
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

TEST(Opencl, SurfaceSdfEqualsReferenceBitForBit) {
  for (const auto& [name, surface] : {std::pair{"torus", tessellate(ShapeKind::kTorus, 48)},
                                      std::pair{"sphere", tessellate(ShapeKind::kSphere, 30)},
                                      std::pair{"gearwheel", gearwheel()}}) {
    SCOPED_TRACE(name);
    const std::vector<Vec3> pts = adversarial_points(surface, 20000, 7);
    std::vector<double> ref(pts.size()), got(pts.size());
    SurfaceSdf(surface).evaluate(pts, ref);
    SdfSource src;
    src.surface = &surface;
    device().signed_distance(src, pts, got);
    const long i = first_difference(ref, got);
    EXPECT_EQ(i, -1) << "point " << i << " (" << (i >= 0 ? pts[i].x : 0) << ", " << (i >= 0 ? pts[i].y : 0) << ", "
                     << (i >= 0 ? pts[i].z : 0) << "): cpu " << (i >= 0 ? ref[i] : 0) << " opencl " << (i >= 0 ? got[i] : 0);
    // The adversarial set really has points on the surface (value exactly 0) and both signs.
    std::size_t zeros = 0, inside = 0, outside = 0;
    for (double v : ref) zeros += v == 0, inside += v > 0, outside += v < 0;
    EXPECT_GT(zeros, surface.vertices.size() / 2);
    EXPECT_GT(inside, 1000u);
    EXPECT_GT(outside, 1000u);
  }
}

TEST(Opencl, SurfaceSdfOnAGridAcrossChunks) {
  const TriangleSurface surface = gearwheel();
  const UniformGrid grid(padded_cube(surface.bounds(), 0.1), 3);
  const std::vector<Vec3> pts = grid.vertices();
  std::vector<double> ref(pts.size()), got(pts.size());
  SurfaceSdf(surface).evaluate(pts, ref);
  OpenclOptions o = pocl();
  o.max_chunk = 1001;  // chunk boundaries mid-row, and a short last chunk
  OpenclBackend b(o);
  SdfSource src;
  src.surface = &surface;
  b.signed_distance(src, pts, got);
  EXPECT_EQ(first_difference(ref, got), -1);
}

TEST(Opencl, EmptySurfaceIsOutsideEverywhere) {
  const TriangleSurface empty;
  SdfSource src;
  src.surface = &empty;
  std::vector<Vec3> pts = {{0, 0, 0}, {1, 2, 3}};
  std::vector<double> ref(2), got(2);
  SurfaceSdf(empty).evaluate(pts, ref);
  device().signed_distance(src, pts, got);
  EXPECT_EQ(first_difference(ref, got), -1);
}

TEST(Opencl, ShapeSdfEqualsReferenceBitForBit) {
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
    device().signed_distance(src, pts, got);
    EXPECT_EQ(first_difference(ref, got), -1);
  }
}

TEST(Opencl, RefinementErrorEqualsReferenceBitForBit) {
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
  for (std::size_t i = 0; i < lattice.size(); ++i) ASSERT_TRUE(same_bits(ref[i], refinement_error(lattice[i], sizes[i])));
  device().refinement_error(lattice, sizes, got);
  EXPECT_EQ(first_difference(ref, got), -1);
  std::size_t infinite = 0, zero = 0;
  for (double e : ref) infinite += std::isinf(e), zero += e == 0;
  EXPECT_GT(infinite, 50u);
  EXPECT_GT(zero, 100u);
}

namespace {

// A complex of independent cells (8 private points each) whose corner values are `cells`.
struct CellBatch {
  HexComplex complex;
  std::vector<double> values;
  void add(const std::array<double, 8>& f) {
    CellCorners c;
    for (int k = 0; k < 8; ++k) {
      c[k] = uint32_t(complex.points.size());
      complex.points.push_back({double(complex.cells.size()), double(k), 0});
      values.push_back(f[k]);
    }
    complex.cells.push_back(c);
  }
};

void expect_same_classification(Backend& backend, const CellBatch& batch, const char* what) {
  SCOPED_TRACE(what);
  const std::size_t n = batch.complex.cells.size();
  std::vector<CellCode> ref(n), got(n);
  std::vector<std::uint64_t> ref_off(n + 1), got_off(n + 1);
  classify_cells_codes(*make_cpu_backend(), batch.complex, batch.values, ref, ref_off);
  classify_cells_codes(backend, batch.complex, batch.values, got, got_off);
  std::size_t mismatches = 0;
  for (std::size_t i = 0; i < n && mismatches < 5; ++i)
    if (!(ref[i] == got[i])) {
      ++mismatches;
      ADD_FAILURE() << "cell " << i << ": cpu subcase " << int(ref[i].subcase) << " sym " << int(ref[i].symmetry)
                    << " faces " << int(ref[i].face_joins) << " tunnel " << int(ref[i].tunnel) << "; opencl subcase "
                    << int(got[i].subcase) << " sym " << int(got[i].symmetry) << " faces " << int(got[i].face_joins)
                    << " tunnel " << int(got[i].tunnel);
    }
  EXPECT_EQ(ref_off, got_off);
  // The offsets are the exclusive sum of the hexes the mesher makes of each cell
  // (local_refinement_hexes of core's subcase), computed here independently.
  std::uint64_t run = 0;
  for (std::size_t i = 0; i < n; ++i) {
    ASSERT_EQ(ref_off[i], run);
    std::array<double, 8> f;
    for (int k = 0; k < 8; ++k) f[k] = batch.values[batch.complex.cells[i][k]];
    run += std::uint64_t(local_refinement_hexes(classify(f).subcase));
  }
  EXPECT_EQ(ref_off[n], run);
}

// All 256 sign patterns, each with magnitudes drawn by `magnitude`.
template <class M>
CellBatch all_patterns(int repeats, M magnitude) {
  CellBatch b;
  for (int r = 0; r < repeats; ++r)
    for (int mask = 0; mask < 256; ++mask) {
      std::array<double, 8> f;
      for (int c = 0; c < 8; ++c) f[c] = (mask >> c & 1 ? 1 : -1) * magnitude(c);
      b.add(f);
    }
  return b;
}

}  // namespace

TEST(Opencl, ClassificationOfAll256PatternsWithRandomMagnitudes) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.001, 1);
  const CellBatch b = all_patterns(40, [&](int) { return u(rng); });
  expect_same_classification(device(), b, "random");
}

TEST(Opencl, ClassificationWithTiesAndTinyValues) {
  std::mt19937_64 rng(9);
  // Magnitudes from a small set of powers of two: face tests tie (p0 p1 == n0 n1) and the
  // interior test's Q(t*) hits 0 often.
  const double small[] = {0.25, 0.5, 1, 2, 4};
  const CellBatch ties = all_patterns(30, [&](int) { return small[rng() % 5]; });
  expect_same_classification(device(), ties, "power-of-two ties");
  // Exactly equal magnitudes everywhere: every ambiguous face is a tie.
  const CellBatch equal = all_patterns(1, [](int) { return 1.0; });
  expect_same_classification(device(), equal, "all equal");
  // Tiny values of the mesher's zero perturbation next to O(1) values, and wide ranges.
  std::uniform_int_distribution<int> e(-10, 3);
  const CellBatch tiny = all_patterns(20, [&](int) { return rng() % 3 ? std::ldexp(1.0 + (rng() % 7) / 8.0, e(rng)) : 1e-10; });
  expect_same_classification(device(), tiny, "tiny and wide");
  // Signed zeros count as outside, like any value <= 0.
  CellBatch zeros;
  for (int mask = 0; mask < 256; ++mask) {
    std::array<double, 8> f;
    for (int c = 0; c < 8; ++c) f[c] = (mask >> c & 1) ? 0.5 + c : (c % 2 ? 0.0 : -0.0);
    zeros.add(f);
  }
  expect_same_classification(device(), zeros, "signed zeros");
}

TEST(Opencl, ClassificationReachesEverySubcaseAndTunnel) {
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> u(-1, 1);
  CellBatch b;
  for (int i = 0; i < 300000; ++i) {
    std::array<double, 8> f;
    for (double& x : f) x = u(rng);
    b.add(f);
  }
  expect_same_classification(device(), b, "uniform random");
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

// The crossing parameters (ClassifyOptions' `crossings`): core's f_a / (f_a - f_b) bit for bit on
// every cut edge of every sign pattern (random, tied, tiny and wide magnitudes, signed zeros), and
// on the uniform grid with the zero rule applied on the device, whole and in chunks.
TEST(Opencl, CrossingParametersAreCoresBitForBit) {
  std::mt19937_64 rng(31);
  std::uniform_int_distribution<int> e(-10, 3);
  const CellBatch patterns = all_patterns(20, [&](int c) {
    return c == 7 ? 1e-10 : rng() % 4 ? std::ldexp(1.0 + (rng() % 7) / 8.0, e(rng)) : (c % 2 ? 0.0 : -0.0);
  });
  EXPECT_GT(test::expect_crossings_are_cores(device(), patterns.complex, patterns.values), 20000u);
  const test::ZeroRuleGrid z = test::zero_rule_grid();
  const ClassifyOptions co = z.options();
  EXPECT_GT(test::expect_crossings_are_cores(device(), z.complex, z.values, co), 1000u);
  OpenclOptions o = pocl();
  o.max_chunk = 777;
  OpenclBackend chunked(o);
  EXPECT_GT(test::expect_crossings_are_cores(chunked, z.complex, z.values, co), 1000u);
}

TEST(Opencl, ClassificationOfAGridAcrossChunks) {
  const UniformGrid grid(padded_cube(ShapeSdf(ShapeKind::kTwoHoled).bounds(), 0.1), 3);
  const HexComplex complex = uniform_complex(grid);
  std::vector<double> values(complex.points.size());
  ShapeSdf(ShapeKind::kTwoHoled).evaluate(complex.points, values);
  OpenclOptions o = pocl();
  o.max_chunk = 777;
  OpenclBackend b(o);
  CellBatch batch{complex, values};
  expect_same_classification(b, batch, "two-holed grid, chunks of 777");
}

// The mesher's call (host/cli/main.cpp): raw SDF values with the zero rule applied on the device,
// corner ids computed on the device for a uniform grid, only the subcase bytes and offsets back;
// and the values the SDF left on the device reused (ClassifyOptions::values_from_last_sdf, which
// only a device with its own buffers has: zero_copy off runs that path on PoCL). Every field equals
// core's classification of apply_zero_rule's values.
TEST(Opencl, UniformGridWithTheZeroRuleOnTheDevice) {
  const test::ZeroRuleGrid z = test::zero_rule_grid();
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

TEST(Opencl, NonFiniteValueIsAnInputError) {
  CellBatch b;
  b.add({1, -1, 1, -1, 1, -1, 1, std::numeric_limits<double>::quiet_NaN()});
  std::vector<CellCode> codes(1);
  std::vector<std::uint64_t> offsets(2);
  EXPECT_THROW(classify_cells_codes(device(), b.complex, b.values, codes, offsets), InputError);
  EXPECT_THROW(classify_cells_codes(*make_cpu_backend(), b.complex, b.values, codes, offsets), InputError);
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

TEST(OpenclFp32, RunsTheSinglePrecisionProgram) {
  EXPECT_EQ(fp32_device().device().precision, "fp32");
  EXPECT_EQ(device().device().precision, "fp64");
}

// Single precision finds the candidate triangles, the host computes the values in double: equal to
// core bit for bit on points at vertices, on edges, inside faces, +-1e-12 and +-1e-6 of the
// diagonal off faces (values inside the float guard band), exact ties (every vertex is equally
// near all its triangles) and far points; the UV sphere's poles have 30 triangles around one
// vertex (more than the kernel's candidate list: those points go to the host whole).
TEST(OpenclFp32, SurfaceSdfEqualsReferenceBitForBit) {
  for (const auto& [name, surface] : {std::pair{"torus", tessellate(ShapeKind::kTorus, 48)},
                                      std::pair{"sphere", tessellate(ShapeKind::kSphere, 30)},
                                      std::pair{"gearwheel", gearwheel()}}) {
    SCOPED_TRACE(name);
    std::vector<Vec3> pts = adversarial_points(surface, 20000, 17);
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
    const std::string cmd = (k ? env + " " : std::string()) + "XDG_CACHE_HOME=" + (fs::temp_directory_path() / "mchex_test_opencl_cli_cache").string() + " " + MCHEX_BINARY +
                            " --quiet mesh " + input_args + " --backend " + backend + " -o " + in.string() +
                            " --outside " + out.string();
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

// The fp32 path end to end: the surface SDF from float candidates and host doubles, the shape's
// values on the host; the meshes are the cpu reference's byte for byte.
TEST(OpenclCli, Fp32PathMeshIsByteIdenticalToCpu) {
  const fs::path gear = fs::path(MCHEX_TEST_DATA) / "npm/node_modules/stl-models/objects/gearwheel.bin.stl";
  expect_same_mesh_files(gear.string() + " --depth 3 --method mchex", "gearwheel-fp32", "MCHEX_FORCE_FP32=1");
  expect_same_mesh_files("--shape two-holed --depth 3 --method mchex", "two-holed-fp32", "MCHEX_FORCE_FP32=1");
}

TEST(OpenclCli, UnknownBackendExitsOne) {
  const std::string cmd = std::string(MCHEX_BINARY) + " --quiet mesh --shape sphere --backend cuda -o /dev/null 2>/dev/null";
  EXPECT_EQ(WEXITSTATUS(std::system(cmd.c_str())), 1);
}
