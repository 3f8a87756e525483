// Inputs and core-reference checks shared by the backend tests (test_backends, test_opencl,
// test_vulkan).
#pragma once

#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <glob.h>
#include <unistd.h>
#include <gtest/gtest.h>

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

namespace mchex::test {

// The scratch folder of this test process: pipeline caches and Mesa's shader cache live here, so
// runs never depend on (or fill) the user's caches. LavapipeEnvironment removes it at the end.
inline const std::filesystem::path& process_scratch() {
  static const std::filesystem::path dir = [] {
    std::filesystem::path d = std::filesystem::temp_directory_path() / ("mchex-test-" + std::to_string(::getpid()));
    std::filesystem::remove_all(d);
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

// Before any Vulkan call: only lavapipe's ICD, Mesa's caches in the scratch folder, and no
// environment that would change which device or path a test's backend takes.
class LavapipeEnvironment : public ::testing::Environment {
 public:
  void SetUp() override {
    glob_t g{};
    std::string icd;
    if (::glob("/usr/share/vulkan/icd.d/lvp_icd.*.json", 0, nullptr, &g) == 0 && g.gl_pathc > 0) icd = g.gl_pathv[0];
    globfree(&g);
    // An empty VK_DRIVER_FILES would let the loader take every ICD; the tests' device-name
    // checks still fail then.
    ::setenv("VK_DRIVER_FILES", icd.c_str(), 1);
    ::setenv("VK_ICD_FILENAMES", icd.c_str(), 1);  // loaders before 1.3.207 read this name
    ::setenv("MESA_SHADER_CACHE_DIR", (process_scratch() / "mesa").c_str(), 1);
    ::unsetenv("MCHEX_VULKAN_DEVICE");
    ::unsetenv("MCHEX_FORCE_FP32");  // the fp64 tests run fp64; the fp32 ones ask for it
  }
  void TearDown() override { std::filesystem::remove_all(process_scratch()); }
};

// The two-holed solid on the uniform depth-3 grid, with values near the surface replaced by ones
// the zero rule moves (0, -0, +-tiny/2) and ones it keeps (+-tiny exactly), next to cut cells;
// `ruled` is apply_zero_rule's result, what every backend's classification must reproduce.
struct ZeroRuleGrid {
  UniformGrid grid;
  HexComplex complex;
  std::vector<double> values, ruled;
  double tiny = 0;
  std::size_t moved = 0;
  // The mesher's classification call on this grid: the zero rule and the uniform numbering on
  // the device.
  ClassifyOptions options() const {
    ClassifyOptions co;
    co.zero_tolerance = tiny;
    co.uniform_cells_per_axis = grid.cells_per_axis();
    return co;
  }
};

inline ZeroRuleGrid zero_rule_grid() {
  const ShapeSdf shape(ShapeKind::kTwoHoled);
  ZeroRuleGrid z{UniformGrid(padded_cube(shape.bounds(), 0.1), 3), {}, {}, {}, 0, 0};
  z.complex = uniform_complex(z.grid);
  z.values.resize(z.complex.points.size());
  shape.evaluate(z.complex.points, z.values);
  z.tiny = zero_tolerance_of(z.complex);
  const double specials[] = {0.0, -0.0, 0.5 * z.tiny, -0.5 * z.tiny, z.tiny, -z.tiny};
  for (std::size_t p = 0; p < z.values.size(); ++p)
    if (std::abs(z.values[p]) < 2 * z.grid.cell_size() && p % 7 == 0) z.values[p] = specials[(p / 7) % 6];
  z.ruled = apply_zero_rule(z.complex, z.values, &z.moved);
  return z;
}

// Asks `b` for the crossing parameters of every cell of the complex and compares them with core's
// classify() of the cell's values after the zero rule of `options`: bit for bit on cut edges, NaN
// on the others; the subcases must be core's too. Returns how many cut edges were compared.
inline std::size_t expect_crossings_are_cores(Backend& b, const HexComplex& complex, const std::vector<double>& values,
                                              const ClassifyOptions& options = {}) {
  const std::size_t n = complex.cells.size();
  std::vector<std::uint8_t> subcases(n);
  std::vector<std::uint64_t> offsets(n + 1);
  std::vector<double> crossings(12 * n, 7.0);  // no entry may keep this
  b.classify_cells(complex, values, {subcases, offsets, {}, crossings}, options);
  std::size_t compared = 0, wrong = 0;
  for (std::size_t i = 0; i < n; ++i) {
    std::array<double, 8> f;
    for (int c = 0; c < 8; ++c) {
      const double v = values[complex.cells[i][c]];
      f[c] = std::abs(v) < options.zero_tolerance ? -options.zero_tolerance : v;
    }
    const CellClass want = classify(f);
    if (subcases[i] != static_cast<std::uint8_t>(want.subcase)) ++wrong;
    for (int e = 0; e < 12; ++e) {
      const double got = crossings[12 * i + std::size_t(e)];
      const bool cut = (want.cut_edges >> e & 1) != 0;
      const bool same = cut ? std::memcmp(&got, &want.crossing[std::size_t(e)], sizeof got) == 0 : std::isnan(got);
      if (!same && ++wrong <= 5)
        ADD_FAILURE() << "cell " << i << " edge " << e << ": got " << got << ", core " << want.crossing[std::size_t(e)];
      compared += cut ? 1 : 0;
    }
  }
  EXPECT_EQ(wrong, 0u);
  return compared;
}

inline std::uint64_t bits(double x) { return std::bit_cast<std::uint64_t>(x); }

// A complex whose cells own their 8 points, so each cell's values are set independently.
inline HexComplex separate_cells(std::size_t cells) {
  HexComplex c;
  c.points.resize(8 * cells);
  c.cells.resize(cells);
  for (std::size_t i = 0; i < cells; ++i)
    for (int k = 0; k < 8; ++k) c.cells[i][k] = static_cast<std::uint32_t>(8 * i + k);
  return c;
}

inline void expect_same_as_reference(const HexComplex& complex, const std::vector<double>& values,
                                     const std::vector<CellCode>& codes, const std::vector<std::uint64_t>& offsets) {
  ASSERT_EQ(codes.size(), complex.cells.size());
  ASSERT_EQ(offsets.size(), complex.cells.size() + 1);
  std::uint64_t total = 0;
  int wrong = 0;
  for (std::size_t i = 0; i < complex.cells.size() && wrong < 5; ++i) {
    std::array<double, 8> f;
    for (int c = 0; c < 8; ++c) f[c] = values[complex.cells[i][c]];
    const CellClass r = classify(f);
    const CellCode& g = codes[i];
    const bool same = g.subcase == r.subcase && g.sign_mask == r.sign_mask && g.face_joins == r.face_joins &&
                      g.tunnel == r.tunnel && g.symmetry == r.symmetry && (g.inverted != 0) == r.inverted &&
                      g.cut_edges == r.cut_edges && offsets[i] == total;
    if (!same) {
      ++wrong;
      ADD_FAILURE() << "cell " << i << ": device subcase " << int(g.subcase) << " mask " << int(g.sign_mask)
                    << " faces " << int(g.face_joins) << " tunnel " << int(g.tunnel) << " symmetry " << int(g.symmetry)
                    << " inverted " << int(g.inverted) << " cut " << g.cut_edges << " offset " << offsets[i]
                    << "; reference " << int(r.subcase) << " " << int(r.sign_mask) << " " << int(r.face_joins) << " "
                    << int(r.tunnel) << " " << int(r.symmetry) << " " << r.inverted << " " << r.cut_edges << " "
                    << total;
    }
    total += static_cast<std::uint64_t>(local_refinement_hexes(r.subcase));  // the mesher's count
  }
  if (wrong == 0) {
    EXPECT_EQ(offsets.back(), total);
  }
}

// Every sign pattern, each with several magnitude rules: random, all equal (every face test a
// tie), powers of two (exact products: ties and near-ties of the asymptotic decider), values at
// the zero tolerance of the mesher's zero rule (1e-10 of the cell size) mixed with O(1) ones, and
// magnitudes spread over many decades.
inline std::vector<double> adversarial_values(std::size_t& cells, std::mt19937_64& rng) {
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

// Closed, open (a band of triangles removed) and a soup (flipped, duplicated and zero-area
// triangles): the surfaces the surface-SDF tests compare on.
inline std::vector<std::pair<std::string, TriangleSurface>> closed_open_and_degenerate_surfaces() {
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

// Points that stress the closest-feature logic of a surface: its vertices, points on its edges and
// inside its triangles (exactly, and nudged off by tiny and small distances along the face
// normal), random points around it and far away.
inline std::vector<Vec3> adversarial_points(const TriangleSurface& s, std::mt19937_64& rng) {
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

inline void expect_bit_equal(const std::vector<double>& got, const std::vector<double>& want,
                             const std::vector<Vec3>& pts) {
  ASSERT_EQ(got.size(), want.size());
  int wrong = 0;
  for (std::size_t i = 0; i < got.size() && wrong < 5; ++i)
    if (bits(got[i]) != bits(want[i])) {
      ++wrong;
      ADD_FAILURE() << "point " << i << " (" << pts[i].x << ", " << pts[i].y << ", " << pts[i].z << "): device "
                    << got[i] << " reference " << want[i];
    }
}

// The n^3 points of a grid over a surface's padded bounding cube (perf/bench_backends's workload).
inline std::vector<Vec3> grid_points_over(const TriangleSurface& s, int n) {
  const Box cube = padded_cube(s.bounds(), 0.1);
  std::vector<Vec3> pts;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        pts.push_back(cube.lo +
                      Vec3{cube.size().x * i / (n - 1), cube.size().y * j / (n - 1), cube.size().z * k / (n - 1)});
  return pts;
}

inline bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Index of the first value that differs in bits, or -1.
inline long first_difference(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return 0;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!same_bits(a[i], b[i])) return long(i);
  return -1;
}

inline TriangleSurface gearwheel() {
  return read_surface(std::filesystem::path(MCHEX_TEST_DATA) / "npm/node_modules/stl-models/objects/gearwheel.bin.stl");
}

// Points that stress the closest-point regions and the tie rule: every vertex, points along
// every edge (its ends, midpoint and quarter points), barycentric points inside every triangle,
// the same points pushed off along the face normal by tiny and moderate amounts, random points
// in and around the box, and far points.
inline std::vector<Vec3> feature_points(const TriangleSurface& s, std::size_t random_count, unsigned seed) {
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
    pts.push_back(box.lo - 0.2 * box.size() +
                  Vec3{1.4 * r.x * box.size().x, 1.4 * r.y * box.size().y, 1.4 * r.z * box.size().z});
  }
  for (double far : {10.0, 1e3}) {
    pts.push_back(box.center() + Vec3{far * diag, 0, 0});
    pts.push_back(box.center() - Vec3{0.3 * far * diag, far * diag, 0.7 * far * diag});
  }
  return pts;
}

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

inline void expect_same_classification(Backend& backend, const CellBatch& batch, const char* what) {
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
                    << " faces " << int(ref[i].face_joins) << " tunnel " << int(ref[i].tunnel) << "; device subcase "
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
inline CellBatch all_patterns(int repeats, M magnitude) {
  CellBatch b;
  for (int r = 0; r < repeats; ++r)
    for (int mask = 0; mask < 256; ++mask) {
      std::array<double, 8> f;
      for (int c = 0; c < 8; ++c) f[c] = (mask >> c & 1 ? 1 : -1) * magnitude(c);
      b.add(f);
    }
  return b;
}

// Child lattices of a sphere's distance in random cells (smooth), random fields (rough),
// trilinear fields (error 0 up to rounding), constants (0) and flat parents with a bump (infinite
// error), 5 * count cells.
inline void add_smooth_rough_trilinear_and_flat_fields(std::mt19937_64& rng, int count,
                                                       std::vector<std::array<double, kChildLatticePoints>>& lattice,
                                                       std::vector<double>& sizes) {
  std::uniform_real_distribution<double> u(-1, 1);
  auto add = [&](auto&& value, double size) {
    std::array<double, kChildLatticePoints> f;
    for (int c = 0; c < 4; ++c)
      for (int b = 0; b < 4; ++b)
        for (int a = 0; a < 4; ++a) f[child_lattice_index(a, b, c)] = value(a / 3.0, b / 3.0, c / 3.0);
    lattice.push_back(f);
    sizes.push_back(size);
  };
  for (int i = 0; i < count; ++i) {
    const double size = std::ldexp(1.0, -(i % 7)) * (0.5 + 0.5 * std::abs(u(rng)));
    const double cx = u(rng), cy = u(rng), cz = u(rng);
    add(
        [&](double x, double y, double z) {
          return 0.7 - std::sqrt((cx + size * x) * (cx + size * x) + (cy + size * y) * (cy + size * y) +
                                 (cz + size * z) * (cz + size * z));
        },
        size);
    add([&](double, double, double) { return u(rng); }, size);
    const double a = u(rng), b = u(rng), c = u(rng), d = u(rng);
    add([&](double x, double y, double z) { return a + b * x + c * y * z + d * x * y * z; }, size);
    add([&](double, double, double) { return cx; }, size);
    add([&](double x, double y, double z) { return (x > 0 && x < 1 && y > 0 && y < 1 && z > 0 && z < 1) ? cy : cx; },
        size);
  }
}

}  // namespace mchex::test
