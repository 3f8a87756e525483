// The backend interface (core/device/backend.h) and its cpu reference: make_backend's names, the device
// list, the CellCode word layout the kernels write, and the cpu backend against core/ called
// directly (it must be exactly core's answers, since every other backend is tested against it).
#include <gtest/gtest.h>

#include <bit>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <random>
#include <regex>

#include "core/base/error.h"
#include "core/cutting/local_refinement.h"
#include "core/cutting/mc33.h"
#include "core/cutting/mchex_mesher.h"
#include "core/device/backend.h"
#include "core/device/cell_words.h"
#include "core/device/device_scene.h"
#include "core/grid/grid.h"
#include "core/grid/refinement_error.h"
#include "core/sdf/sdf.h"
#include "core/sdf/shapes.h"
#include "host/backends/cpu.h"
#include "host/backends/registry.h"
#include "tests/backend_samples.h"

using namespace mchex;

TEST(Backend, NamesAndErrors) {
  EXPECT_EQ(make_backend("cpu")->device().backend, "cpu");
  EXPECT_THROW(make_backend("cuda"), InputError);
  EXPECT_THROW(make_backend(""), InputError);
  // No GPU here: auto is the reference (a CPU driver is not faster than it on the same cores).
  bool gpu = false;
  for (const DeviceInfo& d : list_devices()) gpu = gpu || (d.type == "gpu" && d.fp64);
  if (!gpu) {
    EXPECT_EQ(make_backend("auto")->device().backend, "cpu");
  }
  // The program cache goes to $XDG_CACHE_HOME/mchex-gpu: keep it out of the user's home.
  setenv("XDG_CACHE_HOME", (std::filesystem::temp_directory_path() / "mchex_test_backend_cache").c_str(), 1);
  // A backend configured out (CMake MCHEX_WITH_OPENCL / MCHEX_WITH_VULKAN OFF) is a known name
  // that says it is not built, as one InputError line.
  auto expect_not_built = [](const std::string& name) {
    try {
      make_backend(name);
      ADD_FAILURE() << name << ": expected InputError";
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).find("backend '" + name + "' is not built into this binary"), 0u) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    }
  };
#if MCHEX_WITH_OPENCL
  EXPECT_EQ(make_backend("opencl")->device().backend, "opencl");
#else
  expect_not_built("opencl");
#endif
#if MCHEX_WITH_VULKAN
  EXPECT_EQ(make_backend("vulkan")->device().backend, "vulkan");
#else
  expect_not_built("vulkan");
#endif
  (void)expect_not_built;
}

TEST(Backend, DeviceListStartsWithTheReference) {
  const auto list = list_devices();
  ASSERT_FALSE(list.empty());
  EXPECT_EQ(list[0].backend, "cpu");
  EXPECT_TRUE(list[0].fp64);
  std::size_t not_built = 0;
  for (const DeviceInfo& d : list) {
    if (d.note.find("not built into this binary") != std::string::npos) {
      // The one entry of a backend configured out: no device, never usable.
      EXPECT_TRUE((d.backend == "opencl" && !MCHEX_WITH_OPENCL) || (d.backend == "vulkan" && !MCHEX_WITH_VULKAN))
          << d.backend;
      EXPECT_TRUE(d.name.empty());
      ++not_built;
      continue;
    }
    EXPECT_FALSE(d.name.empty());
    EXPECT_TRUE(d.type == "cpu" || d.type == "gpu" || d.type == "other");
    // A device without fp64 is usable: the fp32 path (host/backends/fp32_path.h).
    EXPECT_TRUE(d.precision == "fp64" || d.precision == "fp32") << d.name;
    if (!d.fp64) {
      EXPECT_EQ(d.precision, "fp32") << d.name;
    }
  }
  EXPECT_EQ(not_built, std::size_t(!MCHEX_WITH_OPENCL) + std::size_t(!MCHEX_WITH_VULKAN));
}

// The word layout of core/device/device_scene.h, packed here by hand from its comment, decodes to the
// same CellCode, for every subcase, sign mask, face mask, tunnel, inversion, symmetry and cut-edge
// bit.
TEST(Backend, CellCodeWordsRoundTrip) {
  std::mt19937 rng(1);
  for (int s = 0; s < kNumSubcases; ++s)
    for (int mask = 0; mask < 256; ++mask)
      for (int tunnel = -1; tunnel <= 1; ++tunnel) {
        CellCode c;
        c.subcase = Subcase(s);
        c.sign_mask = uint8_t(mask);
        c.face_joins = uint8_t(rng() % 64);
        c.tunnel = int8_t(tunnel);
        c.inverted = uint8_t(rng() % 2);
        c.symmetry = uint8_t(rng() % 49 == 48 ? 255 : rng() % 48);
        c.cut_edges = uint16_t(rng() % 4096);
        const uint32_t w0 = uint32_t(s) | uint32_t(mask) << 8 | uint32_t(c.face_joins) << 16 |
                            uint32_t(tunnel + 1) << 24 | uint32_t(c.inverted) << 26;
        const uint32_t w1 = uint32_t(c.symmetry) | uint32_t(c.cut_edges) << 16;
        ASSERT_EQ(decode_cell_words(w0, w1), c);
      }
}

TEST(Backend, PackedConfigsAreCoreTable) {
  const auto words = packed_mc33_configs();
  ASSERT_EQ(words.size(), std::size_t(kConfigWords + kNumSubcases));
  for (int s = 0; s < kNumSubcases; ++s) {
    const uint32_t w = words[kConfigSubcaseBase + s];
    EXPECT_EQ(w & 0xFF, uint32_t(kSubcaseInfo[s].tunnel_partner)) << s;
    EXPECT_EQ(int(w >> kConfigTunnelShift & 0xFF) - 1, kSubcaseInfo[s].tunnel) << s;
    EXPECT_EQ(int(w >> kConfigHexesShift), local_refinement_hexes(Subcase(s))) << s;
  }
  for (int mask = 0; mask < 256; ++mask)
    for (int faces = 0; faces < 64; ++faces) {
      const Mc33Config& c = mc33_config(uint8_t(mask), uint8_t(faces));
      const uint32_t w = words[mask * 64 + faces];
      ASSERT_EQ(w & 0xFF, uint32_t(c.subcase));
      ASSERT_EQ(w >> 8 & 0xFF, c.map[0]);
      ASSERT_EQ(w >> 16 & 0xFF, c.map[1]);
      ASSERT_EQ(w >> 24, c.preferred);
    }
}

TEST(BackendCpu, SignedDistanceIsCoreSdf) {
  auto cpu = make_cpu_backend();
  const TriangleSurface torus = tessellate(ShapeKind::kTorus, 32);
  const UniformGrid grid(padded_cube(torus.bounds(), 0.1), 3);
  const std::vector<Vec3> pts = grid.vertices();
  std::vector<double> ref(pts.size()), got(pts.size()), again(pts.size());
  SurfaceSdf(torus).evaluate(pts, ref);
  SdfSource src;
  src.surface = &torus;
  cpu->signed_distance(src, pts, got);
  cpu->signed_distance(src, pts, again);  // the cached BVH
  EXPECT_EQ(std::memcmp(ref.data(), got.data(), 8 * ref.size()), 0);
  EXPECT_EQ(std::memcmp(ref.data(), again.data(), 8 * ref.size()), 0);
  // A caller's own reference is used as is.
  const ShapeSdf sphere(ShapeKind::kSphere);
  src.reference = &sphere;
  cpu->signed_distance(src, pts, got);
  sphere.evaluate(pts, ref);
  EXPECT_EQ(std::memcmp(ref.data(), got.data(), 8 * ref.size()), 0);
  SdfSource shape;
  shape.shape = ShapeKind::kRoundedBox;
  cpu->signed_distance(shape, pts, got);
  ShapeSdf(ShapeKind::kRoundedBox).evaluate(pts, ref);
  EXPECT_EQ(std::memcmp(ref.data(), got.data(), 8 * ref.size()), 0);
  std::vector<double> wrong(3);
  EXPECT_THROW(cpu->signed_distance(shape, pts, wrong), std::invalid_argument);
}

TEST(BackendCpu, ClassifyCellsIsCoreClassify) {
  auto cpu = make_cpu_backend();
  const UniformGrid grid(padded_cube(ShapeSdf(ShapeKind::kTorus).bounds(), 0.1), 3);
  const HexComplex complex = uniform_complex(grid);
  std::vector<double> values(complex.points.size());
  ShapeSdf(ShapeKind::kTorus).evaluate(complex.points, values);
  std::vector<CellCode> codes(complex.cells.size());
  std::vector<std::uint64_t> offsets(complex.cells.size() + 1);
  classify_cells_codes(*cpu, complex, values, codes, offsets);
  std::uint64_t run = 0;
  std::size_t cut = 0;
  for (std::size_t i = 0; i < complex.cells.size(); ++i) {
    std::array<double, 8> f;
    for (int c = 0; c < 8; ++c) f[c] = values[complex.cells[i][c]];
    const CellClass k = classify(f);
    ASSERT_EQ(codes[i], encode_cell(k));
    ASSERT_EQ(offsets[i], run);
    // A cell cut directly gives 8 + 2 * cut edges hexes (docs/mc33.md); one refined
    // locally the sum over its leaves.
    if (!needs_local_refinement(k)) {
      ASSERT_EQ(local_refinement_hexes(k.subcase), 8 + 2 * std::popcount(unsigned(k.cut_edges)));
    }
    run += std::uint64_t(local_refinement_hexes(k.subcase));
    cut += k.cut_edges != 0;
  }
  EXPECT_EQ(offsets.back(), run);
  EXPECT_GT(cut, 100u);
  // With the crossing parameters asked for: core's, and the same subcases.
  EXPECT_GT(test::expect_crossings_are_cores(*cpu, complex, values), 100u);
  // The total is what the mesher really makes of these values.
  const MeshPair meshes = mesh_mchex(complex, values, 1e-3);
  EXPECT_EQ(offsets.back(), meshes.inside.hexes.size() + meshes.outside.hexes.size());
}

TEST(BackendCpu, RefinementErrorIsCore) {
  auto cpu = make_cpu_backend();
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<std::array<double, kChildLatticePoints>> lattice(500);
  std::vector<double> sizes(500), errors(500);
  for (auto& f : lattice)
    for (double& x : f) x = u(rng);
  for (double& s : sizes) s = 0.1 + std::abs(u(rng));
  cpu->refinement_error(lattice, sizes, errors);
  for (std::size_t i = 0; i < lattice.size(); ++i) {
    const double e = refinement_error(lattice[i], sizes[i]);
    ASSERT_EQ(std::memcmp(&e, &errors[i], 8), 0);
  }
}

// core/cutting/mchex_mesher.h DeviceClassification: a backend's classification handed to the mesher is
// checked, not trusted. The true one gives the very same mesh; one wrong subcase or one wrong
// prefix sum is a logic_error that names the cell(s).
TEST(BackendCpu, MesherChecksADeviceClassification) {
  auto cpu = make_cpu_backend();
  const UniformGrid grid(padded_cube(ShapeSdf(ShapeKind::kTwoHoled).bounds(), 0.1), 2);
  const HexComplex complex = uniform_complex(grid);
  std::vector<double> values(complex.points.size());
  ShapeSdf(ShapeKind::kTwoHoled).evaluate(complex.points, values);
  const std::vector<double> ruled = apply_zero_rule(complex, values);
  std::vector<CellCode> codes(complex.cells.size());
  std::vector<std::uint64_t> offsets(complex.cells.size() + 1);
  classify_cells_codes(*cpu, complex, ruled, codes, offsets);
  std::vector<std::uint8_t> subcases(codes.size());
  for (std::size_t i = 0; i < codes.size(); ++i) subcases[i] = static_cast<std::uint8_t>(codes[i].subcase);

  const MeshPair plain = mesh_mchex(complex, values, 1e-3);
  const MeshPair checked = mesh_mchex(complex, values, 1e-3, nullptr, {subcases, offsets});
  EXPECT_EQ(plain.inside.hexes, checked.inside.hexes);
  EXPECT_EQ(plain.outside.hexes, checked.outside.hexes);
  EXPECT_EQ(plain.inside.points.size(), checked.inside.points.size());

  // One cut cell's subcase changed.
  std::size_t cut = 0;
  while (codes[cut].cut_edges == 0) ++cut;
  std::vector<std::uint8_t> wrong = subcases;
  wrong[cut] = static_cast<std::uint8_t>(wrong[cut] == 1 ? 2 : 1);
  try {
    mesh_mchex(complex, values, 1e-3, nullptr, {wrong, {}});
    ADD_FAILURE() << "a wrong device subcase was accepted";
  } catch (const std::logic_error& e) {
    EXPECT_NE(std::string(e.what()).find("cell " + std::to_string(cut) + ":"), std::string::npos) << e.what();
  }
  // One hex too many in the device's count from that cell on.
  std::vector<std::uint64_t> shifted = offsets;
  for (std::size_t i = cut + 1; i < shifted.size(); ++i) ++shifted[i];
  try {
    mesh_mchex(complex, values, 1e-3, nullptr, {{}, shifted});
    ADD_FAILURE() << "a wrong device prefix sum was accepted";
  } catch (const std::logic_error& e) {
    // The named range of cells holds the first cell whose count is off.
    std::smatch m;
    const std::string what = e.what();
    const std::regex range(R"(cells (\d+) to (\d+) made)");
    const bool named = std::regex_search(what, m, range);
    ASSERT_TRUE(named) << what;
    EXPECT_LE(std::stoul(m[1]), cut) << what;
    EXPECT_GE(std::stoul(m[2]), cut) << what;
  }
  // Sizes that do not match the complex are a caller's error.
  EXPECT_THROW(mesh_mchex(complex, values, 1e-3, nullptr, {std::span(subcases).first(3), {}}), std::invalid_argument);
}
