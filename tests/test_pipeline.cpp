// The one mesh pipeline (core/pipeline/pipeline.h run_pipeline) and its report
// (core/pipeline/report.h). The reference for each run is the same chain of core calls written out
// here stage by stage (grid, SDF, mesher), independent of the pipeline's code: the pipeline's
// meshes must equal it bit for bit (points, hexes, labels) on an analytic shape (uniform, MCHex),
// a triangle surface read from a file, the adaptive grid, and the RO method; the meshes must pass
// their check; the report must carry its keys with the run's values; the stage times must not
// add up to more than the wall time; and each error must come as its exception type, before any
// backend is opened where the request is refused up front.
#include <unistd.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/base/error.h"
#include "core/base/parallel.h"
#include "core/check/fidelity.h"
#include "core/cutting/mchex_mesher.h"
#include "core/cutting/ro.h"
#include "core/grid/grid.h"
#include "core/grid/octree.h"
#include "core/io/mesh_io.h"
#include "core/io/surface_io.h"
#include "core/mesh/orientation.h"
#include "core/mesh/quality.h"
#include "core/optimize/optimize.h"
#include "core/pipeline/pipeline.h"
#include "core/pipeline/report.h"
#include "core/sdf/sdf.h"
#include "core/sdf/shapes.h"
#include "host/backends/registry.h"

namespace mchex {
namespace {

namespace fs = std::filesystem;

const std::string kGearwheel = std::string(MCHEX_TEST_DATA) + "/npm/node_modules/stl-models/objects/gearwheel.bin.stl";

void expect_same_mesh(const HexMesh& a, const HexMesh& b, const char* which) {
  EXPECT_EQ(a.points.size(), b.points.size()) << which;
  EXPECT_EQ(a.hexes.size(), b.hexes.size()) << which;
  EXPECT_TRUE(a.points == b.points) << which << ": points differ";
  EXPECT_TRUE(a.hexes == b.hexes) << which << ": hexes differ";
  EXPECT_TRUE(a.region == b.region) << which << ": labels differ";
}

void expect_same_pair(const MeshPair& a, const MeshPair& b) {
  expect_same_mesh(a.inside, b.inside, "inside");
  expect_same_mesh(a.outside, b.outside, "outside");
}

// The run with its wall time, on the cpu backend (the reference the other backends equal).
struct Timed {
  MeshRun run;
  double wall = 0;
};

Timed run_timed(MeshRequest request) {
  const std::unique_ptr<Backend> cpu = make_backend("cpu");
  request.backend = cpu.get();
  request.options.quiet = true;
  const auto t0 = std::chrono::steady_clock::now();
  MeshRun run = run_pipeline(request);
  return {std::move(run), std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()};
}

// What every run must satisfy: the meshes pass their check, the report carries the run's values,
// the stages fit in the wall time.
void expect_sound(const Timed& t) {
  const MeshRun& run = t.run;
  EXPECT_TRUE(run.check.ok) << (run.check.errors.empty() ? "" : run.check.errors.front());
  EXPECT_GT(run.meshes.inside.hexes.size(), 0u);
  EXPECT_GT(run.meshes.outside.hexes.size(), 0u);
  EXPECT_LE(run.clock.total(), t.wall);
  EXPECT_GT(run.peak_memory_bytes, 0u);
  EXPECT_EQ(run.device.backend, "cpu");

  const MeshOutputs outputs{"in.mesh", "out.vtu", {}};
  const nlohmann::json r = report_json(run, &outputs);
  for (const char* key :
       {"input", "method", "backend", "grid", "elements", "check", "outputs", "times", "peak_memory_bytes"})
    EXPECT_TRUE(r.contains(key)) << key;
  EXPECT_EQ(r["method"], run.options.method);
  EXPECT_EQ(r["backend"]["name"], "cpu");
  EXPECT_EQ(r["elements"]["inside_hexes"], run.meshes.inside.hexes.size());
  EXPECT_EQ(r["elements"]["outside_hexes"], run.meshes.outside.hexes.size());
  EXPECT_EQ(r["elements"]["inside_vertices"], run.meshes.inside.points.size());
  EXPECT_EQ(r["elements"]["outside_vertices"], run.meshes.outside.points.size());
  EXPECT_EQ(r["check"], to_json(run.check));
  EXPECT_EQ(r["outputs"]["inside"], "in.mesh");
  EXPECT_EQ(r["outputs"]["outside"], "out.vtu");
  EXPECT_EQ(r["grid"]["kind"], run.adaptive ? "adaptive" : "uniform");
  EXPECT_EQ(r["times"]["total"], run.clock.total());
  for (const char* stage : {"sdf", "check"}) EXPECT_TRUE(r["times"].contains(stage)) << stage;
  EXPECT_TRUE(r["times"].contains(run.options.method));
  EXPECT_EQ(r.contains("cases"), run.options.method == "mchex");
  EXPECT_EQ(r.contains("mchex"), run.options.method == "mchex");
  EXPECT_EQ(r.contains("fidelity"), run.fidelity.has_value());
  EXPECT_FALSE(report_json(run).contains("outputs"));
}

std::vector<double> values_at(const SignedDistance& sdf, const UniformGrid& grid) {
  const std::vector<Vec3> points = grid.vertices();
  std::vector<double> v(points.size());
  sdf.evaluate(points, v);
  return v;
}

TEST(Pipeline, ShapeOnAUniformGridIsTheMesherCalledDirectly) {
  MeshRequest request;
  request.solid.shape = "two-holed";
  request.options.depth = 2;
  request.options.fidelity = true;
  const Timed t = run_timed(request);
  expect_sound(t);

  const ShapeSdf sdf(ShapeKind::kTwoHoled);
  const UniformGrid grid(padded_cube(sdf.bounds(), 0.1), 2);
  MchexStats stats;
  MeshPair direct = mesh_mchex(grid, values_at(sdf, grid), 1e-3, &stats);
  const SnapStats snapped = snap_boundary(direct, sdf);  // then the boundary snapped onto the shape
  expect_same_pair(t.run.meshes, direct);
  ASSERT_TRUE(t.run.snap);
  EXPECT_EQ(t.run.snap->moved, snapped.moved);
  EXPECT_GT(snapped.moved, 0u);
  EXPECT_EQ(t.run.mchex.cases, stats.cases);
  EXPECT_EQ(t.run.mchex.refined_cells, stats.refined_cells);

  const nlohmann::json r = report_json(t.run);
  EXPECT_EQ(r["input"], (nlohmann::json{{"shape", "two-holed"}, {"analytic", true}}));
  EXPECT_EQ(r["grid"]["cells"], grid.cell_count());
  EXPECT_EQ(r["grid"]["cells_per_axis"], 9);
  EXPECT_EQ(r["mchex"]["eps"], 1e-3);
  EXPECT_FALSE(r["times"].contains("read"));  // a shape is not read, nor is a BVH built
  ASSERT_TRUE(t.run.fidelity);
  EXPECT_EQ(r["fidelity"], fidelity_json(*t.run.fidelity));
  // The measures as core/check/fidelity.h gives them for the direct mesh, with the CLI's sampling
  // (1/400 of the cube's diagonal, the shape sampled over its own 5%-padded cube).
  const Box& cube = grid.box();
  const double spacing = cube.diagonal() / 400;
  const Fidelity f = measure_fidelity(direct.inside, sdf, sample_surface(sdf, padded_cube(sdf.bounds(), 0.05), spacing),
                                      cube, 128, spacing);
  EXPECT_EQ(t.run.fidelity->iou, f.iou);
  EXPECT_EQ(t.run.fidelity->hausdorff, f.hausdorff);
  EXPECT_EQ(t.run.fidelity->lattice, 128u);
}

// The fidelity measures do not depend on the thread count, the count of unresolved samples
// included. A hex skips samples another hex already covered, so counting failed inversions as they
// happened depended on which of two hexes came first: CI once saw 590 against 589 for the same
// files (tests/test_python.py). That order cannot be forced here; the runs below check that the
// count (uncovered samples where an inversion failed) is the same on one thread and on many.
// The mesher's hexes no longer fail to invert (fidelity.cpp's rounding floor), so one hex is added
// whose map cannot be inverted: its top face turned half round, so that the Jacobian is singular
// at its centre, where Newton starts. It straddles the sphere's boundary: inside, the samples in
// it are the mesh's too (covered by the mesher's hexes); outside, no hex covers them and they are
// unresolved.
TEST(Pipeline, FidelityIsTheSameOnOneThreadAndMany) {
  const ShapeSdf sdf(ShapeKind::kSphere);
  const UniformGrid grid(padded_cube(sdf.bounds(), 0.1), 3);
  MeshPair m = mesh_mchex(grid, values_at(sdf, grid), 1e-3);
  const auto first = static_cast<uint32_t>(m.inside.points.size());
  for (const Vec3 p : {Vec3{0.7, -0.3, -0.2}, Vec3{1.3, -0.3, -0.2}, Vec3{1.3, 0.3, -0.2}, Vec3{0.7, 0.3, -0.2}})
    m.inside.points.push_back(p);
  for (int c = 0; c < 4; ++c) {  // the bottom corner opposite, lifted: turned half round the axis
    const Vec3 b = m.inside.points[first + (c + 2) % 4];
    m.inside.points.push_back({b.x, b.y, 0.2});
  }
  m.inside.hexes.push_back({first, first + 1, first + 2, first + 3, first + 4, first + 5, first + 6, first + 7});
  m.inside.region.push_back(kInside);
  const Box& cube = grid.box();
  const double spacing = cube.diagonal() / 400;
  const auto samples = sample_surface(sdf, padded_cube(sdf.bounds(), 0.05), spacing);
  const Fidelity many = measure_fidelity(m.inside, sdf, samples, cube, 128, spacing);
  EXPECT_GT(many.unresolved, 0u);
  for (int run = 0; run < 3; ++run) {
    const Fidelity again = measure_fidelity(m.inside, sdf, samples, cube, 128, spacing);
    EXPECT_EQ(again.unresolved, many.unresolved);
    EXPECT_EQ(again.iou, many.iou);
  }
  ThreadLimit one(1);
  const Fidelity single = measure_fidelity(m.inside, sdf, samples, cube, 128, spacing);
  EXPECT_EQ(single.unresolved, many.unresolved);
  EXPECT_EQ(single.iou, many.iou);
  EXPECT_EQ(single.hausdorff, many.hausdorff);
}

TEST(Pipeline, NoSourceMeansTheDefaultShape) {
  const Timed t = run_timed({});
  EXPECT_EQ(t.run.input.name, kDefaultShape);
  EXPECT_TRUE(t.run.input.analytic);
}

TEST(Pipeline, SurfaceFromAFileIsTheMesherCalledDirectly) {
  if (!fs::exists(kGearwheel)) GTEST_SKIP() << kGearwheel << " not installed (setup.sh)";
  MeshRequest request;
  request.solid.path = kGearwheel;
  request.options.depth = 2;
  const Timed t = run_timed(request);
  expect_sound(t);

  std::size_t welded = 0;
  const TriangleSurface surface = read_surface(kGearwheel, &welded);
  const SurfaceSdf sdf(surface);
  const UniformGrid grid(padded_cube(sdf.bounds(), 0.1), 2);
  MeshPair direct = mesh_mchex(grid, values_at(sdf, grid), 1e-3);
  snap_boundary(direct, sdf);
  expect_same_pair(t.run.meshes, direct);

  const nlohmann::json r = report_json(t.run);
  EXPECT_EQ(r["input"]["file"], kGearwheel);
  EXPECT_EQ(r["input"]["triangles"], surface.triangles.size());
  EXPECT_EQ(r["input"]["welded_vertices"], welded);
  EXPECT_EQ(r["input"]["closed"], validate_surface(surface).closed);
  for (const char* stage : {"read", "bvh"}) EXPECT_TRUE(r["times"].contains(stage)) << stage;
}

TEST(Pipeline, AdaptiveGridIsTheOctreeAndMesherCalledDirectly) {
  MeshRequest request;
  request.solid.shape = "sphere";
  request.options.threshold = 0.05;
  request.options.max_depth = 3;
  const Timed t = run_timed(request);
  expect_sound(t);
  ASSERT_TRUE(t.run.adaptive);
  EXPECT_FALSE(t.run.uniform);

  const ShapeSdf sdf(ShapeKind::kSphere);
  const Box cube = padded_cube(sdf.bounds(), 0.1);
  Octree tree = refine_octree(sdf, cube, {0.05, 3});
  balance_octree(tree);
  AdaptiveGrid g = build_adaptive_complex(tree);
  const std::size_t unsampled = g.unsampled.size();
  evaluate_unsampled(g, sdf);
  MeshPair direct = mesh_mchex(g.complex, g.values, 1e-3);
  snap_boundary(direct, sdf);
  expect_same_pair(t.run.meshes, direct);
  EXPECT_EQ(t.run.adaptive->complex.cells.size(), g.complex.cells.size());

  const nlohmann::json r = report_json(t.run);
  EXPECT_EQ(r["grid"]["cells"], g.complex.cells.size());
  EXPECT_EQ(r["grid"]["levels"], g.levels);
  EXPECT_EQ(r["grid"]["max_depth"], 3);
  EXPECT_EQ(r["grid"]["threshold"], 0.05);
  EXPECT_GT(unsampled, 0u);
  EXPECT_EQ(t.run.unsampled_points, unsampled);
  EXPECT_EQ(r["grid"]["points_sampled_in_refinement"], g.complex.points.size() - unsampled);
  EXPECT_TRUE(r["times"].contains("octree"));
  // The octree's parts, SDF batches apart, fit in its stage.
  const OctreeTimes& o = t.run.octree_times;
  EXPECT_GT(o.sdf, 0);
  EXPECT_LE(o.refine + o.balance + o.complex + o.sdf, t.run.clock.seconds("octree"));
}

TEST(Pipeline, RemoveOutsideIsTheMesherCalledDirectly) {
  MeshRequest request;
  request.solid.shape = "torus";
  request.options.method = "ro";
  request.options.depth = 3;
  const Timed t = run_timed(request);
  expect_sound(t);

  const ShapeSdf sdf(ShapeKind::kTorus);
  const UniformGrid grid(padded_cube(sdf.bounds(), 0.1), 3);
  expect_same_pair(t.run.meshes, mesh_remove_outside(grid, values_at(sdf, grid)));
  EXPECT_FALSE(report_json(t.run)["times"].contains("mchex"));
}

// The named device backend, or null (with a line saying why) where this machine has none.
std::unique_ptr<Backend> device_if_here(const char* name) {
  try {
    return make_backend(name);
  } catch (const InputError& e) {
    std::printf("%s: not here (%s)\n", name, e.what());
    return nullptr;
  }
}

// On a device backend the pipeline also classifies the cells there and the mesher cross-checks
// them; the meshes stay those of the cpu backend, bit for bit.
TEST(Pipeline, ADeviceBackendGivesTheCpuMeshes) {
  for (const char* name : {"opencl", "vulkan"}) {
    const std::unique_ptr<Backend> device = device_if_here(name);
    if (!device) continue;
    for (const double threshold : {0.0, 0.05}) {
      MeshRequest request;
      request.solid.shape = "torus";
      request.options.depth = 2;
      request.options.threshold = threshold;
      request.options.max_depth = 3;
      const Timed cpu = run_timed(request);
      request.backend = device.get();
      request.options.quiet = true;
      const MeshRun run = run_pipeline(request);
      EXPECT_EQ(run.device.backend, name);
      EXPECT_GT(run.clock.seconds("classify"), 0) << name;
      EXPECT_TRUE(report_json(run)["times"].contains("classify"));
      expect_same_pair(run.meshes, cpu.run.meshes);
      EXPECT_EQ(run.mchex.cases, cpu.run.mchex.cases);
    }
  }
}

TEST(Pipeline, OneSolidServesSeveralRunsWithTheSameMeshes) {
  const TriangleSurface surface = tessellate(ShapeKind::kTorus, 48);
  StageClock clock(true);
  const Solid solid(SolidSource::in_memory(surface, "torus-mesh"), clock, true);
  const std::unique_ptr<Backend> cpu = make_backend("cpu");
  MeshRequest request;
  request.backend = cpu.get();
  request.options.depth = 2;
  request.options.quiet = true;
  const MeshRun a = run_pipeline(request, solid), b = run_pipeline(request, solid);
  expect_same_pair(a.meshes, b.meshes);
  EXPECT_EQ(a.input.name, "torus-mesh");
  EXPECT_EQ(a.input.surface.triangles, surface.triangles.size());
  EXPECT_EQ(report_json(a)["input"]["file"], "torus-mesh");
  // The in-memory surface through a request equals it too.
  request.solid = SolidSource::in_memory(surface, "torus-mesh");
  expect_same_pair(run_pipeline(request).meshes, a.meshes);
}

// A surface that needs repair and the winding-number sign (a third of its faces flipped, a run of
// faces removed: open): the pipeline is repair_orientation and SurfaceSdf(kWindingNumber) called
// directly, the caller's surface is left alone, the report says what repair did, every device
// backend gives the cpu meshes (the host re-signs their values), and --no-repair --sign
// pseudonormal is the plain pseudonormal SDF of the surface as given.
TEST(Pipeline, ARepairedOpenSurfaceIsRepairAndTheWindingSignCalledDirectly) {
  TriangleSurface broken = tessellate(ShapeKind::kTorus, 48);
  for (std::size_t t = 0; t < broken.triangles.size(); t += 3)
    std::swap(broken.triangles[t][1], broken.triangles[t][2]);
  broken.triangles.erase(broken.triangles.begin() + 100, broken.triangles.begin() + 140);
  const TriangleSurface given = broken;
  MeshRequest request;
  request.solid = SolidSource::in_memory(broken, "broken-torus");
  request.options.depth = 2;
  request.options.snap = false;  // the cut itself (the snap: the tests above)
  const Timed t = run_timed(request);
  expect_sound(t);
  EXPECT_TRUE(broken.triangles == given.triangles && broken.vertices == given.vertices);

  TriangleSurface repaired = broken;
  const OrientationReport repair = repair_orientation(repaired);
  EXPECT_GT(repair.flipped_triangles, 0u);
  EXPECT_GT(repair.boundary_loops, 0u);
  const SurfaceSdf winding(repaired, SignRule::kWindingNumber);
  const UniformGrid grid(padded_cube(winding.bounds(), 0.1), 2);
  expect_same_pair(t.run.meshes, mesh_mchex(grid, values_at(winding, grid), 1e-3));
  const nlohmann::json r = report_json(t.run);
  EXPECT_EQ(r["input"]["sign"], "winding");
  EXPECT_EQ(r["input"]["repair"]["flipped_triangles"], repair.flipped_triangles);
  EXPECT_EQ(r["input"]["repair"]["boundary_loops"], repair.boundary_loops);
  EXPECT_EQ(r["input"]["repair"]["summary"], describe(repair));
  EXPECT_EQ(r["input"]["triangles"], repaired.triangles.size());
  EXPECT_TRUE(r["times"].contains("repair"));

  for (const char* name : {"opencl", "vulkan"}) {
    const std::unique_ptr<Backend> device = device_if_here(name);
    if (!device) continue;
    for (const double threshold : {0.0, 0.05}) {
      MeshRequest on_device = request;
      on_device.options.threshold = threshold;
      on_device.options.max_depth = 3;
      const Timed cpu = run_timed(on_device);
      on_device.backend = device.get();
      on_device.options.quiet = true;
      const MeshRun run = run_pipeline(on_device);
      EXPECT_EQ(run.device.backend, name);
      expect_same_pair(run.meshes, cpu.run.meshes);
    }
  }

  request.options.input = {false, SignRule::kPseudonormal};
  const Timed plain = run_timed(request);
  const SurfaceSdf pseudonormal(broken);
  expect_same_pair(plain.run.meshes, mesh_mchex(grid, values_at(pseudonormal, grid), 1e-3));
  EXPECT_EQ(report_json(plain.run)["input"]["sign"], "pseudonormal");
  EXPECT_TRUE(report_json(plain.run)["input"]["repair"].is_null());
}

TEST(Pipeline, WriteMeshesWritesWhatWasCheckedAndRefusesAFailedCheck) {
  MeshRequest request;
  request.solid.shape = "sphere";
  request.options.depth = 1;
  Timed t = run_timed(request);
  const fs::path dir = fs::temp_directory_path() / ("mchex_test_pipeline_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  write_meshes(t.run, dir / "in.mesh", dir / "out.vtu");
  EXPECT_TRUE(t.run.clock.to_json().contains("write"));
  EXPECT_EQ(read_hex_mesh(dir / "in.mesh").hexes, t.run.meshes.inside.hexes);
  EXPECT_EQ(read_hex_mesh(dir / "out.vtu").hexes, t.run.meshes.outside.hexes);
  t.run.check.ok = false;
  EXPECT_THROW(write_meshes(t.run, dir / "in2.mesh", dir / "out2.mesh"), std::logic_error);
  EXPECT_FALSE(fs::exists(dir / "in2.mesh"));
  fs::remove_all(dir);
}

TEST(Pipeline, CheckedScaledJacobiansWriteTheVtuTheWriterWouldCompute) {
  MeshRequest request;
  request.solid.shape = "torus";
  request.options.depth = 2;
  Timed plain = run_timed(request);
  request.options.keep_scaled_jacobians = true;
  Timed kept = run_timed(request);
  ASSERT_TRUE(plain.run.check.inside.scaled_jacobians.empty());
  const std::vector<double>& sj = kept.run.check.inside.scaled_jacobians;
  ASSERT_EQ(sj.size(), kept.run.meshes.inside.hexes.size());
  ASSERT_EQ(kept.run.check.outside->scaled_jacobians.size(), kept.run.meshes.outside.hexes.size());
  for (std::size_t h = 0; h < sj.size(); h += 97)
    EXPECT_EQ(sj[h], hex_quality(kept.run.meshes.inside.corners(h)).scaled_jacobian) << "hex " << h;
  const fs::path dir = fs::temp_directory_path() / ("mchex_test_pipeline_sj_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  write_meshes(plain.run, dir / "a.vtu", dir / "a_out.vtu");
  write_meshes(kept.run, dir / "b.vtu", dir / "b_out.vtu");
  auto bytes = [](const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(f), {});
  };
  EXPECT_EQ(bytes(dir / "a.vtu"), bytes(dir / "b.vtu"));
  EXPECT_EQ(bytes(dir / "a_out.vtu"), bytes(dir / "b_out.vtu"));
  // Released once written.
  EXPECT_TRUE(kept.run.check.inside.scaled_jacobians.empty());
  EXPECT_TRUE(kept.run.check.outside->scaled_jacobians.empty());
  fs::remove_all(dir);
}

// Runs a request whose backend is opened only on demand; says whether it was.
bool opens_backend(MeshRequest request) {
  bool opened = false;
  request.options.quiet = true;
  request.open_backend = [&] {
    opened = true;
    return make_backend("cpu");
  };
  try {
    (void)run_pipeline(request);
  } catch (...) {
    EXPECT_FALSE(opened) << "the request was refused after the backend was opened";
    throw;
  }
  return opened;
}

TEST(Pipeline, ErrorsAreTheirExceptionTypesBeforeAnyDeviceIsProbed) {
  MeshRequest missing;
  missing.solid.path = "/nonexistent/surface.stl";
  EXPECT_THROW(opens_backend(missing), InputError);
  MeshRequest unknown;
  unknown.solid.shape = "cube";
  EXPECT_THROW(opens_backend(unknown), InputError);
  MeshRequest both;
  both.solid.shape = "sphere";
  both.solid.path = kGearwheel;
  EXPECT_THROW(opens_backend(both), InputError);
  MeshRequest method;
  method.options.method = "marching";
  EXPECT_THROW(opens_backend(method), InputError);
  MeshRequest deep;
  deep.options.depth = kMaxUniformDepth + 1;
  EXPECT_THROW(opens_backend(deep), InputError);
  // 729^3 cells, about 620 GB for MCHex: refused up front on any machine that runs these tests.
  MeshRequest huge;
  huge.options.depth = 6;
  EXPECT_THROW(opens_backend(huge), ResourceError);
  MeshRequest fine;
  fine.options.depth = 1;
  EXPECT_TRUE(opens_backend(fine));

  // Neither a backend nor a way to open one, or both: a caller's mistake.
  MeshRequest none;
  none.options.quiet = true;
  EXPECT_THROW((void)run_pipeline(none), std::invalid_argument);
  const std::unique_ptr<Backend> cpu = make_backend("cpu");
  MeshRequest two = none;
  two.backend = cpu.get();
  two.open_backend = [] { return make_backend("cpu"); };
  EXPECT_THROW((void)run_pipeline(two), std::invalid_argument);
}

}  // namespace
}  // namespace mchex
