// The mesher's stages on a uniform grid, as time shares of one run and as output hexes per
// second: SDF at the grid vertices, the method (RO, or MCHex cutting + midpoint subdivision),
// check (quality + conformity), and writing both meshes in each format. Prints a table and one
// JSON line.
//   bench_mesh [--depth D] [--shape NAME] [--method ro|mchex]
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>


#include "core/grid/grid.h"
#include "perf/bench_common.h"
#include "core/check/mesh_check.h"
#include "core/cutting/mchex_mesher.h"
#include "core/io/mesh_io.h"
#include "core/cutting/ro.h"
#include "core/sdf/shapes.h"
#include "core/base/parallel.h"

using namespace mchex;
using bench::seconds_of;

int main(int argc, char** argv) {
  int depth = 5;
  std::string shape = "torus", method = "ro";
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--depth")) depth = std::stoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--shape")) shape = argv[i + 1];
    if (!std::strcmp(argv[i], "--method")) method = argv[i + 1];
  }
  const ShapeSdf sdf(parse_shape(shape));
  const UniformGrid grid(padded_cube(sdf.bounds(), 0.1), depth);
  std::vector<double> f;
  const double t_sdf = seconds_of([&] {
    const auto pts = grid.vertices();
    f.resize(pts.size());
    sdf.evaluate(pts, f);
  });
  MeshPair m;
  MchexStats ms;
  const double t_ro = seconds_of([&] { m = method == "mchex" ? mesh_mchex(grid, f, 1e-3, &ms) : mesh_remove_outside(grid, f); });
  double t_serial = 0;
  if (method == "mchex") {
    // The same mesher on one thread, in the same run: the parallel speed-up as a ratio.
    ThreadLimit one(1);
    MchexStats s1;
    t_serial = seconds_of([&] { (void)mesh_mchex(grid, f, 1e-3, &s1); });
  }
  MeshCheck c;
  const Box box = grid.box();
  const double t_check = seconds_of([&] { c = check_mesh(m.inside, &m.outside, &box); });
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
  std::printf("%s mesher, %s at depth %d: %.0f hexes (%zu inside), check ok: %s\n", method.c_str(), shape.c_str(), depth, hexes,
              m.inside.hexes.size(), c.ok ? "yes" : "NO");
  std::printf("  stage          share of sdf+method+check+vtu   hexes/s\n");
  auto row = [&](const char* name, double t) {
    std::printf("  %-14s %6.1f%%                    %10.3g\n", name, 100 * t / total, hexes / t);
  };
  row("sdf (analytic)", t_sdf);
  row(method.c_str(), t_ro);
  row("check", t_check);
  for (int i = 0; i < 3; ++i) row((std::string("write ") + ext[i]).c_str(), t_write[i]);
  std::printf("  %s alone: %.3g output hexes/s\n", method.c_str(), hexes / t_ro);
  if (method == "mchex") {
    std::printf("  mchex stages: topology %.3f s, polyhedra + subdivision %.3f s (%.3g hexes/s), assembly %.3f s\n",
                ms.seconds_topology, ms.seconds_cells, hexes / ms.seconds_cells, ms.seconds_assembly);
    std::printf("  mchex on 1 thread: %.3g hexes/s; 2 threads / 1 thread speed-up %.2fx\n", hexes / t_serial, t_serial / t_ro);
  }
  std::printf("  end to end (sdf+method+check+write .vtu): %.3g hexes/s\n", hexes / total);
  std::printf("{\"bench\":\"mesh\",\"method\":\"%s\",\"shape\":\"%s\",\"depth\":%d,\"hexes\":%.0f,\"ok\":%s,"
              "\"share\":{\"sdf\":%.4f,\"method\":%.4f,\"check\":%.4f,\"write_vtu\":%.4f},"
              "\"method_hexes_per_s\":%.0f,\"cells_hexes_per_s\":%.0f,\"speedup_2_over_1_thread\":%.3f,\"hexes_per_s_end_to_end\":%.0f,\"write_ratio_mesh_vtu_msh\":[%.3f,1,%.3f]}\n",
              method.c_str(), shape.c_str(), depth, hexes, c.ok ? "true" : "false", t_sdf / total, t_ro / total, t_check / total,
              t_write[1] / total, hexes / t_ro, method == "mchex" ? hexes / ms.seconds_cells : 0.0,
              t_serial > 0 ? t_serial / t_ro : 0.0, hexes / total, t_write[0] / t_write[1], t_write[2] / t_write[1]);
  return c.ok ? 0 : 1;
}
