// The mesher's stages on a uniform grid, as time shares of one run and as output hexes per
// second: SDF at the grid vertices, the method (RO, or MCHex cutting + midpoint subdivision),
// check (quality + conformity), and writing both meshes in each format. The stages are those of
// one core/pipeline/pipeline.h run_pipeline, as `mchex-gpu mesh` runs them. Prints a table and one
// JSON line.
//   bench_mesh [--depth D] [--shape NAME] [--method ro|mchex] [--backend cpu|opencl|vulkan|auto]
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>

#include "core/base/parallel.h"
#include "core/io/mesh_io.h"
#include "core/pipeline/pipeline.h"
#include "host/backends/registry.h"
#include "perf/bench_common.h"

using namespace mchex;
using bench::seconds_of;

int main(int argc, char** argv) {
  MeshRequest request;
  request.options.depth = 5;
  request.options.method = "ro";
  request.options.quiet = true;
  request.solid.shape = "torus";
  std::string backend_name = "cpu";
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--depth")) request.options.depth = std::stoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--shape")) request.solid.shape = argv[i + 1];
    if (!std::strcmp(argv[i], "--method")) request.options.method = argv[i + 1];
    if (!std::strcmp(argv[i], "--backend")) backend_name = argv[i + 1];
  }
  const std::string& method = request.options.method;
  const std::unique_ptr<Backend> backend = make_backend(backend_name);
  request.backend = backend.get();
  const MeshRun run = run_pipeline(request);
  const MeshPair& m = run.meshes;
  const MchexStats& ms = run.mchex;
  const double t_sdf = run.clock.seconds("sdf"), t_ro = run.clock.seconds(method) + run.clock.seconds("classify");
  double t_serial = 0;
  if (method == "mchex") {
    // The same pipeline on one thread, in the same run: the mesher's parallel speed-up as a ratio.
    ThreadLimit one(1);
    const MeshRun serial = run_pipeline(request);
    t_serial = serial.clock.seconds("mchex") + serial.clock.seconds("classify");
  }
  const double t_check = run.clock.seconds("check");
  const auto dir = std::filesystem::temp_directory_path() / "mchex_bench_mesh";
  std::filesystem::create_directories(dir);
  double t_write[3] = {};
  const char* ext[3] = {".mesh", ".vtu", ".msh"};
  for (int i = 0; i < 3; ++i)
    t_write[i] = seconds_of([&] {
      write_hex_mesh(m.inside, dir / (std::string("in") + ext[i]));
      write_hex_mesh(m.outside, dir / (std::string("out") + ext[i]));
    });
  std::filesystem::remove_all(dir);
  const double hexes = double(m.inside.hexes.size() + m.outside.hexes.size());
  const double total = t_sdf + t_ro + t_check + t_write[1];
  const std::string& shape = run.input.name;
  const int depth = request.options.depth;
  const bool ok = run.check.ok;
  std::printf("%s mesher, %s at depth %d: %.0f hexes (%zu inside), check ok: %s\n", method.c_str(), shape.c_str(),
              depth, hexes, m.inside.hexes.size(), ok ? "yes" : "NO");
  std::printf("  stage          share of sdf+method+check+vtu   hexes/s\n");
  auto row = [&](const char* name, double t) {
    std::printf("  %-14s %6.1f%%                    %10.3g\n", name, 100 * t / total, hexes / t);
  };
  row(("sdf (" + run.device.backend + ")").c_str(), t_sdf);
  row(method.c_str(), t_ro);
  row("check", t_check);
  for (int i = 0; i < 3; ++i) row((std::string("write ") + ext[i]).c_str(), t_write[i]);
  std::printf("  %s alone: %.3g output hexes/s\n", method.c_str(), hexes / t_ro);
  if (method == "mchex") {
    std::printf("  mchex stages: topology %.3f s, polyhedra + subdivision %.3f s (%.3g hexes/s), assembly %.3f s\n",
                ms.seconds_topology, ms.seconds_cells, hexes / ms.seconds_cells, ms.seconds_assembly);
    std::printf("  mchex on 1 thread: %.3g hexes/s; 2 threads / 1 thread speed-up %.2fx\n", hexes / t_serial,
                t_serial / t_ro);
  }
  std::printf("  end to end (sdf+method+check+write .vtu): %.3g hexes/s\n", hexes / total);
  std::printf(
      "{\"bench\":\"mesh\",\"method\":\"%s\",\"shape\":\"%s\",\"backend\":\"%s\",\"depth\":%d,\"hexes\":%.0f,\"ok\":%s,"
      "\"share\":{\"sdf\":%.4f,\"method\":%.4f,\"check\":%.4f,\"write_vtu\":%.4f},"
      "\"method_hexes_per_s\":%.0f,\"cells_hexes_per_s\":%.0f,\"speedup_2_over_1_thread\":%.3f,\"hexes_per_s_end_to_end\":%.0f,\"write_ratio_mesh_vtu_msh\":[%.3f,1,%.3f]}\n",
      method.c_str(), shape.c_str(), run.device.backend.c_str(), depth, hexes, ok ? "true" : "false", t_sdf / total,
      t_ro / total, t_check / total, t_write[1] / total, hexes / t_ro,
      method == "mchex" ? hexes / ms.seconds_cells : 0.0, t_serial > 0 ? t_serial / t_ro : 0.0, hexes / total,
      t_write[0] / t_write[1], t_write[2] / t_write[1]);
  return ok ? 0 : 1;
}
