// mchex-gpu: the command line. Subcommands:
//   mesh     surface or analytic shape -> inside and outside all-hex meshes (+ JSON report)
//   check    validate hex meshes: structure, quality (Bernstein certificate), conformity, fidelity
//   certify  re-check the positivity proof (core/cutting/certify.h)
//   optimize move vertices to raise the scaled Jacobian, every hex still certified
//   convert  a hex mesh from one file format to another
//   devices  the compute backends and devices found (core/device/backend.h)
// This file parses the command line and maps errors to exit codes; each subcommand is in its own
// file (host/cli/commands.h). Every failure is one line on stderr and a non-zero exit: 1 bad input
// or usage, 2 resource limit, 3 an internal failure (a mesh that fails its own check, a failed
// certificate). SIGINT and SIGTERM leave no file behind (core/io/atomic_file.h): `mesh` writes
// all of its outputs or none.
#include <algorithm>
#include <cstdio>
#include <map>
#include <new>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/base/error.h"
#include "core/base/parallel.h"
#include "core/cutting/certify.h"
#include "core/cutting/repel.h"
#include "core/grid/grid.h"
#include "core/grid/octree.h"
#include "core/io/atomic_file.h"
#include "core/io/mesh_io.h"
#include "core/pipeline/estimate.h"
#include "core/pipeline/fit.h"
#include "host/backends/registry.h"
#include "host/cli/commands.h"

using namespace mchex;
using namespace mchex::cli;

// Gmsh's own command line writes binary files with -bin ("when possible"); so here.
constexpr const char* kBinaryHelp =
    "write .msh as Gmsh 4.1 binary, as gmsh -bin does (.vtu, .meshb and .exo are always binary, .mesh and .inp "
    "always ascii)";

namespace {

// mesh --repel's value: empty (the option alone) is the default delta.
double parse_repel_delta(const std::string& text) {
  if (text.empty()) return kDefaultRepelDelta;
  std::size_t used = 0;
  double delta = 0;
  try {
    delta = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || !(delta > 0 && delta <= kMaxRepelDelta))
    throw InputError(fmt::format("--repel: DELTA must be a number in (0, {}], got '{}'", kMaxRepelDelta, text));
  return delta;
}

}  // namespace

int main(int argc, char** argv) {
  install_signal_cleanup();
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
  mesh->add_option("-o,--output", mo.inside, "inside mesh (.mesh, .meshb, .vtu, .msh, .exo or .inp)")
      ->capture_default_str();
  mesh->add_flag("--binary", mo.write.binary, kBinaryHelp);
  mesh->add_option("--outside", mo.outside, "outside mesh (default: outside.EXT beside the inside mesh)");
  mesh->add_option("--method", mo.options.method,
                   "mchex: cut every cell by the isosurface (MC33, local refinement where the paper "
                   "needs it) and split the pieces into hexes; ro: keep the cells whose 8 corner "
                   "values sum above 0 (the paper's baseline)")
      ->check(CLI::IsMember({"ro", "mchex"}))
      ->capture_default_str();
  auto* eps = mesh->add_option("--eps", mo.options.eps,
                               fmt::format("--method mchex: clamp edge crossings to [eps, 1 - eps], eps in (0, 0.5); "
                                           "with --optimize the default is {}",
                                           kOptimizeEps))
                  ->check(CLI::Range(0.0, 0.5))
                  ->capture_default_str();
  auto* depth = mesh->add_option("--depth", mo.options.depth,
                                 "uniform 3-refinement depth: 3^depth cells per axis (instead of the fitted adaptive "
                                 "grid of --hausdorff)")
                    ->check(CLI::Range(0, kMaxUniformDepth));
  auto* threshold =
      mesh->add_option(
              "--threshold", mo.options.threshold,
              "adaptive 3-refinement instead of --depth: a cell the surface may pass through is refined while the "
              "paper's refinement error (how far its trilinear isosurface lies from its 27 children's) exceeds "
              "THRESHOLD times the finest cell size (box edge / 3^max-depth); cells the surface misses are never "
              "refined. --max-depth sets the resolution, THRESHOLD the accuracy asked of coarser cells in units of "
              "it; dimensionless, so it suits a model of any size (the paper's batch run: 0.05)")
          ->check(CLI::PositiveNumber);
  auto* max_depth = mesh->add_option("--max-depth", mo.options.max_depth, "--threshold: deepest refinement level")
                        ->check(CLI::Range(0, kMaxAdaptiveDepth))
                        ->capture_default_str();
  auto* volume_threshold =
      mesh->add_option("--volume-threshold", mo.options.volume_threshold,
                       "--threshold: also refine a cell when its refinement error times its area exceeds V times "
                       "the box volume")
          ->check(CLI::NonNegativeNumber);
  auto* surface_tolerance =
      mesh->add_option("--surface-tolerance", mo.options.surface_tolerance,
                       "--threshold: also refine a cell when a point of the input surface in it lies farther than S "
                       "x the input's diagonal from the cell's trilinear isosurface")
          ->check(CLI::NonNegativeNumber);
  auto* hausdorff =
      mesh->add_option("--hausdorff", mo.options.hausdorff,
                       fmt::format("the default grid: the adaptive grid fitted to this target Hausdorff ratio (the "
                                   "two-sided Hausdorff distance between mesh boundary and input over the input's "
                                   "bounding-box diagonal): finest cell about H x diagonal (default {})",
                                   kDefaultHausdorffRatio))
          ->check(CLI::PositiveNumber);
  auto* max_hexes = mesh->add_option("--max-hexes", mo.options.max_hexes,
                                     "at most N output hexes (both meshes): the adaptive grid is coarsened where its "
                                     "error is smallest until its predicted output fits (exit 2 when nothing does)")
                        ->check(CLI::Range(std::size_t{1}, std::size_t{1} << 40))
                        ->type_name("N");
  // One grid setting: a uniform depth, an explicit adaptive one, or the fitted default.
  depth->excludes(threshold)->excludes(max_depth)->excludes(hausdorff)->excludes(max_hexes);
  hausdorff->excludes(threshold)->excludes(max_depth);
  max_depth->needs(threshold);
  volume_threshold->needs(threshold);
  surface_tolerance->needs(threshold);
  mesh->add_option("--pad", mo.options.pad, "padding around the input, as a fraction of its largest extent")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  const std::vector<std::string> backends = built_backend_names();
  mesh->add_option("--backend", mo.backend,
                   fmt::format("where the SDF runs: {} (auto: a GPU with fp64 if one is found, else cpu; cpu: "
                               "the reference); every backend gives the same mesh",
                               fmt::join(backends, ", ")))
      ->check(CLI::Validator(
          [backends](std::string& name) -> std::string {
            // A known backend configured out is left to make_backend, whose one line says it was
            // not built and which CMake option would build it; anything else is not a backend.
            if (std::find(backends.begin(), backends.end(), name) != backends.end() || name == "opencl" ||
                name == "vulkan")
              return "";
            return name + " not in {" + fmt::format("{}", fmt::join(backends, ",")) + "}";
          },
          "{" + fmt::format("{}", fmt::join(backends, ",")) + "}"))
      ->capture_default_str();
  mesh->add_option_function<std::string>(
          "--max-memory",
          [&](const std::string& text) {
            const auto bytes = parse_memory_size(text);
            if (!bytes) throw CLI::ValidationError("--max-memory", "expected a size such as 8G or 512M, got " + text);
            mo.options.max_memory = *bytes;
          },
          "refuse (exit 2) a run whose estimated peak memory is over SIZE (8G, 512M; K, M, G, T are powers of "
          "1024); default: 80% of the memory available now")
      ->type_name("SIZE");
  const std::map<std::string, SignRule> sign_rules = {{"winding", SignRule::kWindingNumber},
                                                      {"pseudonormal", SignRule::kPseudonormal}};
  const char* sign_help =
      "inside of a surface: winding (the generalized winding number exceeds 1/2; right on open, folded, "
      "inconsistently oriented and self-intersecting input) or pseudonormal (the nearest triangle's side; "
      "exact only for closed, consistently oriented surfaces)";
  mesh->add_option("--sign", mo.options.input.sign, sign_help)
      ->transform(CLI::CheckedTransformer(sign_rules, CLI::ignore_case))
      ->default_str("winding");
  mesh->add_flag("--no-repair{false}", mo.options.input.repair,
                 "mesh the surface as read: no orientation repair (duplicates, flipped faces, inside-out shells)");
  mesh->add_option("--report", mo.report, "write a JSON report to this file");
  mesh->add_option("--trace", mo.trace,
                   "write the stages and every kernel dispatch, upload and download as a Chrome trace-event JSON "
                   "file (Perfetto, chrome://tracing)");
  bool no_fidelity = false;
  auto* fidelity = mesh->add_flag("--fidelity", mo.options.fidelity,
                                  "measure IoU and Hausdorff ratio against the input (the default)");
  mesh->add_flag("--no-fidelity", no_fidelity, "skip the IoU and Hausdorff measures")->excludes(fidelity);
  // The summary measures fidelity by default: a lattice of 64 keeps it a fraction of the run
  // (README, "Fidelity by default"), the Hausdorff ratio does not depend on it.
  mo.options.lattice = 64;
  mesh->add_option("--lattice", mo.options.lattice, "samples per axis for the IoU")
      ->check(CLI::Range(8, 1024))
      ->capture_default_str();

  // An option with an optional value: `--repel` alone is the default delta. Parsed here so that
  // a bad value is the one-line InputError of every other bad input.
  std::string repel_text;
  auto* repel = mesh->add_option("--repel", repel_text,
                                 fmt::format("repel grid points from the surface before cutting (Awad et al. 2016): "
                                             "every crossing DELTA x its edge from both ends where the rules allow, "
                                             "DELTA in (0, {}] (default {}; docs/repel.md)",
                                             kMaxRepelDelta, kDefaultRepelDelta))
                    ->expected(0, 1)
                    ->type_name("[DELTA]");
  mesh->add_flag("--optimize", mo.options.optimize,
                 "move vertices after meshing to raise the minimum and mean scaled Jacobian: boundary vertices stay "
                 "on the input surface, every hex stays Bernstein-certified (docs/optimize.md)");
  mesh->add_option("--optimize-sweeps", mo.options.optimize_options.max_sweeps, "--optimize: at most this many sweeps")
      ->check(CLI::Range(0, 10000))
      ->capture_default_str();

  mesh->add_option("--optimize-tolerance", mo.options.optimize_options.tolerance,
                   "--optimize: stop when a sweep raises the minimum scaled Jacobian by less than this and the mean "
                   "by less than 10 times it")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();

  OptimizeCommand oo;
  auto* optimize_cmd = app.add_subcommand(
      "optimize", "move the vertices of a hex mesh (and its outside mesh) to raise the scaled Jacobian, keeping "
                  "boundary vertices on the input surface and every hex Bernstein-certified");
  optimize_cmd->add_option("mesh", oo.mesh, "inside hex mesh (.mesh, .vtu or .msh)")->required();
  optimize_cmd->add_option("--outside", oo.outside, "its outside mesh: the interface moves in both");
  optimize_cmd->add_option("--input", oo.input, "the input surface the boundary stays on");
  optimize_cmd->add_option("--shape", oo.shape, "the built-in shape the mesh was made from, as --input");
  optimize_cmd->add_option("-o,--output", oo.output, "optimised inside mesh")->required();
  optimize_cmd->add_option("--outside-output", oo.outside_output,
                           "optimised outside mesh (default: outside.EXT beside the output)");
  optimize_cmd->add_option("--sweeps", oo.options.max_sweeps, "at most this many sweeps")
      ->check(CLI::Range(0, 10000))
      ->capture_default_str();
  optimize_cmd->add_option("--report", oo.report, "write the optimiser's figures as JSON to this file");
  optimize_cmd->add_option("--sign", oo.solid.sign, "--input: the sign rule the mesh was made with, as mesh --sign")
      ->transform(CLI::CheckedTransformer(sign_rules, CLI::ignore_case))
      ->default_str("winding");
  optimize_cmd->add_flag("--no-repair{false}", oo.solid.repair, "--input: as mesh --no-repair");

  CheckCommand co;
  auto* check = app.add_subcommand("check", "validate a hex mesh (and its outside mesh) and measure its quality");
  check->add_option("mesh", co.mesh, "hex mesh (.mesh, .meshb, .vtu, .msh, .exo or .inp)")->required();
  check->add_option("--outside", co.outside, "the outside mesh: check that both conform and fill their box");
  check->add_option("--input", co.input, "the input surface: measure IoU and Hausdorff distance");
  check->add_option("--shape", co.shape, "the built-in shape the mesh was made from, as --input");
  check->add_option("--sign", co.solid.sign, "--input: the sign rule the mesh was made with, as mesh --sign")
      ->transform(CLI::CheckedTransformer(sign_rules, CLI::ignore_case))
      ->default_str("winding");
  check->add_flag("--no-repair{false}", co.solid.repair, "--input: as mesh --no-repair");
  check->add_flag("--json", co.json, "print the results as JSON");
  check->add_option("--lattice", co.lattice, "samples per axis for the IoU")
      ->check(CLI::Range(8, 1024))
      ->capture_default_str();

  CertifyOptions certify_options;
  auto* certify_cmd = app.add_subcommand(
      "certify", "re-check the positivity proof: every cell type x 24 rotations x MC33 subcase, crossings from random "
                 "and extreme corner values; every Bernstein coefficient of det J must be > 0 (exit 3 when not)");
  certify_cmd->add_option("--eps", certify_options.eps, "crossings clamped to [eps, 1 - eps], as mesh --eps")
      ->check(CLI::Range(0.0, 0.5))
      ->capture_default_str();

  std::string convert_in, convert_out;
  MeshWriteOptions convert_write;
  auto* convert = app.add_subcommand(
      "convert", "convert a hex mesh between .mesh, .meshb, .vtu, .msh, .exo and .inp (regions kept)");
  convert->add_option("input", convert_in, "hex mesh to read")->required();
  convert->add_option("output", convert_out, "hex mesh to write; the format follows the extension")->required();
  convert->add_flag("--binary", convert_write.binary, kBinaryHelp);

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
    if (mesh->parsed()) {
      const OutputGroup outputs;
      if (depth->count() == 0 && threshold->count() == 0 && hausdorff->count() == 0)
        mo.options.hausdorff = kDefaultHausdorffRatio;
      mo.options.fidelity = !no_fidelity;
      if (mo.options.optimize && eps->count() == 0) mo.options.eps = kOptimizeEps;
      if (repel->count() > 0) mo.options.repel = parse_repel_delta(repel_text);
      return run_mesh(mo, quiet);
    }
    if (devices->parsed()) return run_devices(devices_json);
    if (optimize_cmd->parsed()) {
      const OutputGroup outputs;
      return run_optimize(oo, quiet);
    }
    if (certify_cmd->parsed()) {
      const CertifyResult r = certify(certify_options);
      if (!quiet) fmt::print("{}", certify_report(r));
      return r.passed() ? 0 : 3;
    }
    if (convert->parsed()) {
      mesh_format(convert_out);
      write_hex_mesh(read_hex_mesh(convert_in), convert_out, convert_write);
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
