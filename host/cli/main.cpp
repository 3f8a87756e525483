// mchex-gpu: the command line. Subcommands:
//   mesh   surface or analytic shape -> inside and outside all-hex meshes (+ JSON report)
//   check  validate hex meshes: structure, quality (Bernstein certificate), conformity, fidelity
//   convert  a hex mesh from one file format to another
//   devices  the compute backends and devices found (core/device/backend.h)
// Every failure is one line on stderr and a non-zero exit: 1 bad input or usage, 2 resource limit.
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/grid/cell_types.h"
#include "core/cutting/certify.h"
#include "core/base/error.h"
#include "core/check/fidelity.h"
#include "core/grid/grid.h"
#include "core/cutting/mchex_mesher.h"
#include "core/check/mesh_check.h"
#include "core/io/mesh_io.h"
#include "core/grid/octree.h"
#include "core/base/stage_clock.h"
#include "core/cutting/ro.h"
#include "core/sdf/sdf.h"
#include "core/sdf/shapes.h"
#include "core/mesh/surface.h"
#include "core/device/backend.h"
#include "core/io/atomic_file.h"
#include "core/io/surface_io.h"
#include "host/backends/registry.h"
#include "core/base/parallel.h"

namespace fs = std::filesystem;
using nlohmann::json;
using namespace mchex;

namespace {

constexpr const char* kDefaultShape = "torus";

// The solid a command works on: a surface file or a built-in shape.
struct Solid {
  std::string name;
  std::optional<TriangleSurface> surface;
  SurfaceReport report;
  std::size_t welded = 0;
  std::unique_ptr<SignedDistance> sdf;

  bool analytic() const { return !surface; }
  json to_json() const {
    if (analytic()) return {{"shape", name}, {"analytic", true}};
    return {{"file", name},
            {"triangles", report.triangles},
            {"vertices", report.vertices},
            {"welded_vertices", welded},
            {"closed", report.closed},
            {"consistently_oriented", report.consistently_oriented},
            {"boundary_edges", report.boundary_edges},
            {"nonmanifold_edges", report.nonmanifold_edges},
            {"degenerate_faces", report.degenerate_faces},
            {"inconsistent_edges", report.inconsistent_edges},
            {"components", report.components},
            {"volume", report.volume}};
  }
};

Solid load_solid(const std::string& input, const std::string& shape, StageClock& clock, bool quiet) {
  Solid s;
  if (input.empty()) {
    s.name = shape.empty() ? kDefaultShape : shape;
    s.sdf = std::make_unique<ShapeSdf>(parse_shape(s.name));
    return s;
  }
  s.name = input;
  s.surface = clock.run("read", [&] { return read_surface(input, &s.welded); });
  s.report = validate_surface(*s.surface);
  if (!quiet && !(s.report.closed && s.report.consistently_oriented))
    std::fprintf(stderr,
                 "mchex-gpu: warning: %s is not a closed, consistently oriented surface (%zu boundary, "
                 "%zu non-manifold, %zu inconsistent edges); inside/outside follows the nearest triangle\n",
                 input.c_str(), s.report.boundary_edges, s.report.nonmanifold_edges, s.report.inconsistent_edges);
  s.sdf = clock.run("bvh", [&] { return std::make_unique<SurfaceSdf>(*s.surface); });
  return s;
}

std::vector<Vec3> reference_samples(const Solid& s, double spacing) {
  if (s.surface) return sample_surface(*s.surface, spacing);
  return sample_surface(*s.sdf, padded_cube(s.sdf->bounds(), 0.05), spacing);
}

fs::path default_outside(const fs::path& inside) {
  return inside.parent_path() / ("outside" + inside.extension().string());
}

// Memory the mesher will need for a uniform grid, against what the machine has: refuse early
// (exit 2) rather than die half-way.
// Per output hex: the hex and its label, about one point, and the checker's face records; MCHex
// makes at least 8 hexes per cell (midpoint subdivision of the uncut cube) plus a key map entry
// per point, RO one hex per cell.
void check_memory_budget(const UniformGrid& grid, const std::string& method) {
  const double hexes_per_cell = method == "mchex" ? 8 : 1, bytes_per_hex = method == "mchex" ? 200 : 80;
  const double bytes = double(grid.vertex_count()) * (3 * 24 + 8) + double(grid.cell_count()) * hexes_per_cell * bytes_per_hex;
  const double physical = double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGE_SIZE));
  if (physical > 0 && bytes > 0.8 * physical)
    throw ResourceError(fmt::format("depth {} needs about {:.1f} GiB, more than 80% of this machine's {:.1f} GiB; use a smaller --depth",
                                    grid.depth(), bytes / (1 << 30), physical / (1 << 30)));
}

json fidelity_json(const Fidelity& f) {
  return {{"iou", f.iou},
          {"hausdorff", f.hausdorff},
          {"hausdorff_ratio", f.hausdorff_ratio},
          {"mesh_to_surface", f.mesh_to_surface},
          {"surface_to_mesh", f.surface_to_mesh},
          {"mesh_volume", f.mesh_volume},
          {"solid_volume", f.solid_volume},
          {"lattice", f.lattice},
          {"unresolved_samples", f.unresolved}};
}

Fidelity measure(const HexMesh& inside, const Solid& solid, const Box& box, std::size_t lattice) {
  const double spacing = box.diagonal() / 400;
  const auto samples = reference_samples(solid, spacing);
  return measure_fidelity(inside, *solid.sdf, samples, box, lattice, spacing);
}

std::string first_error(const MeshCheck& c) {
  return c.errors.empty() ? std::string("unknown error") : c.errors.front();
}

std::string describe(const char* label, const MeshStats& m) {
  const QualityStats& q = m.quality;
  const BoundaryStats& b = m.boundary;
  std::string s = fmt::format("  {} quality: min scaled Jacobian {:.4f} (mean {:.4f}), Bernstein-certified {}/{} ({:.2f}%), max edge ratio {:.3g}\n",
                              label, q.min_scaled_jacobian, q.mean_scaled_jacobian, q.certified, q.count,
                              q.count ? 100.0 * q.certified / q.count : 100.0, q.max_edge_ratio);
  s += fmt::format("  {} boundary: {} quads, {}, Euler characteristic {}, {} component(s)\n", label, b.quads,
                   b.closed_manifold() ? "closed 2-manifold"
                                       : fmt::format("not a closed 2-manifold ({} edges, {} vertices off)", b.bad_edges, b.bad_vertices),
                   b.euler_characteristic, b.components);
  return s;
}

// The human-readable lines of a check, shared by `mesh` and `check`.
std::string summary(const MeshCheck& c) {
  std::string s = describe("inside ", c.inside);
  if (c.outside) s += describe("outside", *c.outside);
  if (c.combined)
    s += fmt::format("  conformity: {} interface faces, {} gap, {} overlap faces, volume error {:.2e}\n",
                     c.combined->interface_faces, c.combined->gap_faces, c.combined->overlap_faces,
                     c.combined->volume_relative_error);
  s += c.ok ? "  structure: ok\n" : fmt::format("  structure: {} error(s), first: {}\n", c.error_count, first_error(c));
  return s;
}

void write_json(const fs::path& path, const json& j) {
  AtomicFile out(path);
  out.write(j.dump(2) + "\n");
  out.commit();
}

// The report's "grid" for the adaptive complex: levels, cells per cell type and per template.
json adaptive_grid_json(const AdaptiveGrid& g, const OctreeStats& stats, double threshold, int max_depth) {
  json per_type = json::object(), per_level = json::array(), per_template = json::object();
  const auto types = cell_types();
  std::vector<std::size_t> count(types.size());
  for (std::uint8_t t : g.cell_type) ++count[t];
  for (std::size_t t = 0; t < types.size(); ++t) per_type[types[t].name] = count[t];
  for (int k = 0; k < kNumTemplateKinds; ++k)
    per_template[std::string(template_name(static_cast<TemplateKind>(k)))] = g.leaves_per_template[k];
  for (const OctreeLevelStats& l : stats.levels)
    per_level.push_back({{"candidates", l.candidates}, {"sampled", l.sampled}, {"sdf_points", l.sdf_points}, {"refined_by_error", l.refined_by_error},
                         {"refined_by_balance", l.refined_by_balance}, {"marks_added", l.marks_added}, {"leaves", l.leaves}});
  const Box& cube = g.complex.box;
  return {{"kind", "adaptive"},
          {"threshold", threshold},
          {"threshold_relative_to", "finest cell size"},
          {"tolerance", adaptive_tolerance(g.complex.box, {threshold, max_depth})},
          {"points_sampled_in_refinement", g.complex.points.size() - g.unsampled.size()},
          {"max_depth", max_depth},
          {"levels", g.levels},
          {"cells", g.complex.cells.size()},
          {"points", g.complex.points.size()},
          {"cells_per_type", per_type},
          {"leaves_per_template", per_template},
          {"per_level", per_level},
          {"balance_rounds", stats.balance_rounds},
          {"box", {{"lo", {cube.lo.x, cube.lo.y, cube.lo.z}}, {"hi", {cube.hi.x, cube.hi.y, cube.hi.z}}}},
          {"finest_cell_size", (cube.hi.x - cube.lo.x) / std::pow(3.0, g.levels - 1)}};
}

struct MeshCommand {
  std::string input, shape, inside = "inside.mesh", outside, report, method = "mchex", backend = "auto";
  int depth = 3;
  double threshold = 0;  // > 0: adaptive grid (refine while error > threshold * finest cell size)
  int max_depth = 5;
  double pad = 0.1;
  double eps = 1e-3;  // --method mchex: crossings clamped to [eps, 1 - eps]
  bool fidelity = false;
  std::size_t lattice = 128;
};

int run_mesh(const MeshCommand& o, bool quiet) {
  if (!o.input.empty() && !o.shape.empty()) throw InputError("give either INPUT or --shape, not both");
  const fs::path inside_path = o.inside;
  const fs::path outside_path = o.outside.empty() ? default_outside(inside_path) : fs::path(o.outside);
  // Reject bad output names before any work.
  for (const fs::path& out : {inside_path, outside_path}) {
    mesh_format(out);
    if (!out.parent_path().empty() && !fs::is_directory(out.parent_path()))
      throw InputError(out.string() + ": the folder " + out.parent_path().string() + " does not exist");
  }
  if (fs::weakly_canonical(inside_path) == fs::weakly_canonical(outside_path))
    throw InputError("the inside and outside meshes need different file names");

  StageClock clock(quiet);
  const Solid solid = load_solid(o.input, o.shape, clock, quiet);
  const Box cube = padded_cube(solid.sdf->bounds(), o.pad);
  const bool adaptive = o.threshold > 0;
  const UniformGrid grid(cube, adaptive ? 0 : o.depth);
  if (!adaptive) check_memory_budget(grid, o.method);
  json grid_json = {{"kind", "uniform"},
                    {"levels", grid.depth()},
                    {"cells_per_axis", grid.cells_per_axis()},
                    {"cells", grid.cell_count()},
                    {"cells_per_type", {{"cube", grid.cell_count()}}},
                    {"box", {{"lo", {cube.lo.x, cube.lo.y, cube.lo.z}}, {"hi", {cube.hi.x, cube.hi.y, cube.hi.z}}}},
                    {"cell_size", grid.cell_size()}};
  // --threshold: the adaptive 3-refinement grid (core/grid/octree.h) as a HexComplex.
  std::optional<AdaptiveGrid> agrid;
  if (adaptive) {
    OctreeStats ostats;
    agrid = clock.run("octree", [&] {
      Octree tree = refine_octree(*solid.sdf, cube, {o.threshold, o.max_depth}, &ostats);
      balance_octree(tree, &ostats);
      return build_adaptive_complex(tree);
    });
    grid_json = adaptive_grid_json(*agrid, ostats, o.threshold, o.max_depth);
  }

  // The SDF batch runs on the chosen backend; every backend gives the cpu reference's values bit
  // for bit (tests/test_opencl.cpp), so the mesh does not depend on the choice.
  const std::unique_ptr<Backend> backend = make_backend(o.backend);
  SdfSource source;
  source.reference = solid.sdf.get();
  if (solid.surface) source.surface = &*solid.surface;
  else source.shape = static_cast<const ShapeSdf&>(*solid.sdf).kind();
  // The adaptive grid already holds the values the refinement sampled (bit for bit what a new
  // evaluation gives: same points); only the points it never sampled need this batch.
  const std::vector<double> values = clock.run("sdf", [&] {
    if (adaptive) {
      const std::vector<Vec3> points = unsampled_points(*agrid);
      std::vector<double> v(points.size());
      if (!points.empty()) backend->signed_distance(source, points, v);
      set_unsampled_values(*agrid, v);
      return std::move(agrid->values);
    }
    const std::vector<Vec3> points = grid.vertices();
    std::vector<double> v(points.size());
    backend->signed_distance(source, points, v);
    return v;
  });
  MchexStats mchex_stats;
  // --method mchex on a device backend: MC33 classification and the hex-count prefix sum run on
  // the device too (from the values after the mesher's zero rule), and the mesher checks every
  // cell's subcase and every chunk's hex count against it (core/cutting/mchex_mesher.h
  // DeviceClassification). The cpu backend's classification would be core's own: not repeated.
  std::optional<HexComplex> uniform;
  std::vector<std::uint8_t> device_subcases;
  std::vector<std::uint64_t> device_offsets;
  if (o.method == "mchex" && backend->device().backend != "cpu") {
    const HexComplex& cx = adaptive ? agrid->complex : uniform.emplace(uniform_complex(grid));
    clock.run("classify", [&] {
      // The device applies the zero rule itself, reads the values the SDF left on it, and computes
      // a uniform grid's corner ids (core/device/backend.h ClassifyOptions).
      ClassifyOptions co;
      co.zero_tolerance = zero_tolerance_of(cx);
      co.uniform_cells_per_axis = adaptive ? 0 : grid.cells_per_axis();
      co.values_from_last_sdf = true;
      device_subcases.resize(cx.cells.size());
      device_offsets.resize(cx.cells.size() + 1);
      backend->classify_cells(cx, values, {device_subcases, device_offsets}, co);
    });
  }
  auto run_method = [&](const auto& where) {
    if (o.method != "mchex") return clock.run("ro", [&] { return mesh_remove_outside(where, values); });
    return clock.run("mchex", [&] {
      if constexpr (std::is_same_v<std::decay_t<decltype(where)>, HexComplex>)
        return mesh_mchex(where, values, o.eps, &mchex_stats, {device_subcases, device_offsets});
      else
        return mesh_mchex(where, values, o.eps, &mchex_stats);
    });
  };
  const MeshPair meshes = adaptive ? run_method(agrid->complex) : uniform ? run_method(*uniform) : run_method(grid);
  const MeshCheck check = clock.run("check", [&] { return check_mesh(meshes.inside, &meshes.outside, &cube); });
  std::optional<Fidelity> fid;
  if (o.fidelity) fid = clock.run("fidelity", [&] { return measure(meshes.inside, solid, cube, o.lattice); });
  // A mesh that fails its own check is never written: the report (if asked for) says why.
  if (check.ok)
    clock.run("write", [&] {
      write_hex_mesh(meshes.inside, inside_path);
      write_hex_mesh(meshes.outside, outside_path);
    });

  json report = {
      {"input", solid.to_json()},
      {"method", o.method},
      {"backend",
       {{"name", backend->device().backend},
        {"platform", backend->device().platform},
        {"device", backend->device().name},
        {"precision", backend->device().precision},
        {"kernels", backend->device().kernels},
        {"threads", hardware_threads()}}},
      {"grid", grid_json},
      {"elements",
       {{"inside_hexes", meshes.inside.hexes.size()},
        {"outside_hexes", meshes.outside.hexes.size()},
        {"inside_vertices", meshes.inside.points.size()},
        {"outside_vertices", meshes.outside.points.size()}}},
      {"check", to_json(check)},
      {"outputs", {{"inside", inside_path.string()}, {"outside", outside_path.string()}}},
  };
  if (o.method == "mchex") {
    // Cells per MC33 subcase (paper Section 5: 31 subcases), and the tunnel cells meshed with
    // their partner's topology instead of the paper's local refinement (a known gap).
    json cases = json::object();
    for (int i = 0; i < kMchexCaseSlots; ++i)
      cases[std::string(mchex_case_name(i))] = mchex_stats.cases[i];
    report["cases"] = cases;
    report["mchex"] = {{"eps", o.eps},
                       {"refined_cells", mchex_stats.refined_cells},
                       {"refined_cells_two_levels", mchex_stats.refined_cells_two_levels},
                       {"moved_volume_centres", mchex_stats.moved_centres},
                       {"uncertified_polyhedra", mchex_stats.uncertified_polyhedra},
                       {"perturbed_zero_values", mchex_stats.perturbed_values},
                       {"points", mchex_stats.points},
                       {"seconds", {{"topology", mchex_stats.seconds_topology},
                                    {"cells", mchex_stats.seconds_cells},
                                    {"assembly", mchex_stats.seconds_assembly}}}};
  }
  if (fid) report["fidelity"] = fidelity_json(*fid);
  report["times"] = clock.to_json();
  report["peak_memory_bytes"] = peak_memory_bytes();
  if (!o.report.empty()) write_json(o.report, report);

  if (!quiet) {
    if (adaptive)
      fmt::print("mchex-gpu: {} -> adaptive grid of {} cells, {} levels (threshold {}, max depth {}), method {}\n",
                 solid.name, agrid->complex.cells.size(), agrid->levels, o.threshold, o.max_depth, o.method);
    else
      fmt::print("mchex-gpu: {} -> {} grid of {}^3 cells (depth {}), method {}\n", solid.name,
                 "uniform", grid.cells_per_axis(), grid.depth(), o.method);
    fmt::print("  inside : {:>10} hexes {:>10} vertices -> {}\n", meshes.inside.hexes.size(),
               meshes.inside.points.size(), inside_path.string());
    fmt::print("  outside: {:>10} hexes {:>10} vertices -> {}\n", meshes.outside.hexes.size(),
               meshes.outside.points.size(), outside_path.string());
    fmt::print("{}", summary(check));
    if (fid)
      fmt::print("  fidelity: IoU {:.4f}, Hausdorff {:.4g} ({:.3f}% of the input diagonal)\n", fid->iou,
                 fid->hausdorff, 100 * fid->hausdorff_ratio);
    fmt::print("  time: {:.2f} s, peak memory {:.0f} MiB\n", clock.total(), peak_memory_bytes() / 1048576.0);
  }
  if (!check.ok)
    throw std::runtime_error(
        "the mesh fails its own check, so nothing was written: " + first_error(check));
  return 0;
}

struct CheckCommand {
  std::string mesh, outside, input, shape;
  bool json = false;
  std::size_t lattice = 128;
};

int run_check(const CheckCommand& o, bool quiet) {
  if (!o.input.empty() && !o.shape.empty()) throw InputError("give either --input or --shape, not both");
  StageClock clock(true);
  const HexMesh inside = read_hex_mesh(o.mesh);
  std::optional<HexMesh> outside;
  if (!o.outside.empty()) outside = read_hex_mesh(o.outside);
  const MeshCheck check = check_mesh(inside, outside ? &*outside : nullptr, nullptr);
  json j = {{"mesh", o.mesh}, {"check", to_json(check)}};
  if (outside) j["outside"] = o.outside;
  std::optional<Fidelity> fid;
  if (!o.input.empty() || !o.shape.empty()) {
    const Solid solid = load_solid(o.input, o.shape, clock, quiet || o.json);
    Box box;
    for (const Vec3& p : inside.points) box.extend(p);
    if (outside)
      for (const Vec3& p : outside->points) box.extend(p);
    box.extend(solid.sdf->bounds().lo);
    box.extend(solid.sdf->bounds().hi);
    fid = measure(inside, solid, box, o.lattice);
    j["input"] = solid.to_json();
    j["fidelity"] = fidelity_json(*fid);
  }
  if (o.json) {
    fmt::print("{}\n", j.dump(2));
  } else if (!quiet) {
    fmt::print("mchex-gpu check: {}{}\n", o.mesh, outside ? " + " + o.outside : "");
    fmt::print("{}", summary(check));
    if (fid)
      fmt::print("  fidelity: IoU {:.4f}, Hausdorff {:.4g} ({:.3f}% of the input diagonal)\n", fid->iou,
                 fid->hausdorff, 100 * fid->hausdorff_ratio);
  }
  if (!check.ok) {
    std::fprintf(stderr, "mchex-gpu: %s: check failed: %s\n", o.mesh.c_str(), first_error(check).c_str());
    return 1;
  }
  return 0;
}

int run_devices(bool as_json) {
  const std::vector<DeviceInfo> list = list_devices();
  if (as_json) {
    json j = json::array();
    for (const DeviceInfo& d : list)
      j.push_back({{"backend", d.backend},
                   {"platform", d.platform},
                   {"device", d.name},
                   {"type", d.type},
                   {"fp64", d.fp64},
                   {"precision", d.precision},
                   {"max_buffer_bytes", d.max_buffer_bytes},
                   {"global_memory_bytes", d.global_memory_bytes},
                   {"compute_units", d.compute_units ? json(d.compute_units) : json(nullptr)},
                   {"version", d.version},
                   {"usable", d.note.empty()},
                   {"note", d.note}});
    fmt::print("{}\n", j.dump(2));
    return 0;
  }
  fmt::print("{:<8} {:<30} {:<36} {:<5} {:<4} {:<9} {:>5} {:>12} {:>12}\n", "backend", "platform", "device", "type",
             "fp64", "precision", "units", "max buffer", "memory");
  for (const DeviceInfo& d : list) {
    auto mib = [](std::uint64_t b) { return b ? fmt::format("{} MiB", b >> 20) : std::string("-"); };
    fmt::print("{:<8} {:<30} {:<36} {:<5} {:<4} {:<9} {:>5} {:>12} {:>12}\n", d.backend, d.platform, d.name, d.type,
               d.fp64 ? "yes" : "no", d.precision, d.compute_units ? std::to_string(d.compute_units) : std::string("-"),
               mib(d.max_buffer_bytes), mib(d.global_memory_bytes));
    if (!d.version.empty()) fmt::print("         {}\n", d.version);
    if (!d.note.empty()) fmt::print("         not usable: {}\n", d.note);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mchex-gpu: all-hex meshes of a solid and of the box around it (MCHex, Tong & Zhang 2025)"};
  app.require_subcommand(1);
  app.fallthrough();  // --quiet and --threads also after the subcommand name
  bool quiet = false;
  int threads = 0;
  app.add_flag("--quiet,-q", quiet, "no summary and no progress lines");
  app.add_option("--threads", threads, "worker threads (default: all cores)")->check(CLI::Range(1, 1024));

  MeshCommand mo;
  auto* mesh = app.add_subcommand("mesh", "mesh a surface (STL, OBJ, OFF, PLY) or a built-in shape");
  mesh->add_option("input", mo.input, "input surface file; without it, --shape (default: torus)");
  mesh->add_option("--shape", mo.shape, "built-in analytic shape: sphere, torus, rounded-box, two-holed");
  mesh->add_option("-o,--output", mo.inside, "inside mesh (.mesh, .vtu or .msh)")->capture_default_str();
  mesh->add_option("--outside", mo.outside, "outside mesh (default: outside.EXT beside the inside mesh)");
  mesh->add_option("--method", mo.method,
                   "mchex: cut every cell by the isosurface (MC33, local refinement where the paper "
                   "needs it) and split the pieces into hexes; ro: keep the cells whose 8 corner "
                   "values sum above 0 (the paper's baseline)")
      ->check(CLI::IsMember({"ro", "mchex"}))->capture_default_str();
  mesh->add_option("--eps", mo.eps, "--method mchex: clamp edge crossings to [eps, 1 - eps], eps in (0, 0.5)")
      ->check(CLI::Range(0.0, 0.5))->capture_default_str();
  mesh->add_option("--depth", mo.depth, "uniform 3-refinement depth: 3^depth cells per axis")
      ->check(CLI::Range(0, kMaxUniformDepth))->capture_default_str();
  mesh->add_option("--threshold", mo.threshold,
                   "adaptive 3-refinement instead of --depth: a cell the surface may pass through is refined while the "
                   "paper's refinement error (how far its trilinear isosurface lies from its 27 children's) exceeds "
                   "THRESHOLD times the finest cell size (box edge / 3^max-depth); cells the surface misses are never "
                   "refined. --max-depth sets the resolution, THRESHOLD the accuracy asked of coarser cells in units of "
                   "it; dimensionless, so it suits a model of any size (the paper's batch run: 0.05)")
      ->check(CLI::PositiveNumber);
  mesh->add_option("--max-depth", mo.max_depth, "--threshold: deepest refinement level")
      ->check(CLI::Range(0, kMaxAdaptiveDepth))->capture_default_str();
  mesh->add_option("--pad", mo.pad, "padding around the input, as a fraction of its largest extent")
      ->check(CLI::Range(0.0, 10.0))->capture_default_str();
  mesh->add_option("--backend", mo.backend,
                   "where the SDF runs: cpu (the reference), opencl, vulkan, or auto (a GPU with fp64 if "
                   "one is found, else cpu); every backend gives the same mesh")
      ->check(CLI::IsMember({"auto", "cpu", "opencl", "vulkan"}))->capture_default_str();
  mesh->add_option("--report", mo.report, "write a JSON report to this file");
  mesh->add_flag("--fidelity", mo.fidelity, "measure IoU and Hausdorff distance against the input");
  mesh->add_option("--lattice", mo.lattice, "samples per axis for the IoU")->check(CLI::Range(8, 1024))->capture_default_str();

  CheckCommand co;
  auto* check = app.add_subcommand("check", "validate a hex mesh (and its outside mesh) and measure its quality");
  check->add_option("mesh", co.mesh, "hex mesh (.mesh, .vtu or .msh)")->required();
  check->add_option("--outside", co.outside, "the outside mesh: check that both conform and fill their box");
  check->add_option("--input", co.input, "the input surface: measure IoU and Hausdorff distance");
  check->add_option("--shape", co.shape, "the built-in shape the mesh was made from, as --input");
  check->add_flag("--json", co.json, "print the results as JSON");
  check->add_option("--lattice", co.lattice, "samples per axis for the IoU")->check(CLI::Range(8, 1024))->capture_default_str();

  CertifyOptions certify_options;
  auto* certify_cmd = app.add_subcommand(
      "certify", "re-check the positivity proof: every cell type x 24 rotations x MC33 subcase, crossings from random "
                 "and extreme corner values; every Bernstein coefficient of det J must be > 0 (exit 3 when not)");
  certify_cmd->add_option("--eps", certify_options.eps, "crossings clamped to [eps, 1 - eps], as mesh --eps")
      ->check(CLI::Range(0.0, 0.5))->capture_default_str();

  std::string convert_in, convert_out;
  auto* convert = app.add_subcommand("convert", "convert a hex mesh between .mesh, .vtu and .msh");
  convert->add_option("input", convert_in, "hex mesh to read")->required();
  convert->add_option("output", convert_out, "hex mesh to write; the format follows the extension")->required();

  bool devices_json = false;
  auto* devices = app.add_subcommand("devices", "list the compute backends, platforms and devices found");
  devices->add_flag("--json", devices_json, "print the list as JSON");

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "mchex-gpu: %s (see --help)\n", e.what());
    return 1;
  }
  try {
    std::optional<ThreadLimit> limit;
    if (threads > 0) limit.emplace(threads);
    if (mesh->parsed()) return run_mesh(mo, quiet);
    if (devices->parsed()) return run_devices(devices_json);
    if (certify_cmd->parsed()) {
      const CertifyResult r = certify(certify_options);
      if (!quiet) fmt::print("{}", certify_report(r));
      return r.passed() ? 0 : 3;
    }
    if (convert->parsed()) {
      mesh_format(convert_out);
      write_hex_mesh(read_hex_mesh(convert_in), convert_out);
      return 0;
    }
    return run_check(co, quiet);
  } catch (const InputError& e) {
    std::fprintf(stderr, "mchex-gpu: %s\n", e.what());
    return 1;
  } catch (const ResourceError& e) {
    std::fprintf(stderr, "mchex-gpu: %s\n", e.what());
    return 2;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "mchex-gpu: out of memory\n");
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mchex-gpu: %s\n", e.what());
    return 3;
  }
}
