// The mesh and check options (host/cli/options.h): the words, their checks and their help.
#include "host/cli/options.h"

#include <algorithm>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/base/error.h"
#include "core/cutting/repel.h"
#include "core/grid/grid.h"
#include "core/grid/octree.h"
#include "core/optimize/optimize.h"
#include "core/pipeline/estimate.h"
#include "core/pipeline/fit.h"
#include "host/backends/registry.h"

namespace mchex::cli {

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

const std::map<std::string, SignRule>& sign_rules() {
  static const std::map<std::string, SignRule> rules = {{"winding", SignRule::kWindingNumber},
                                                        {"pseudonormal", SignRule::kPseudonormal}};
  return rules;
}

MeshCli::MeshCli(CLI::App& app) {
  app.add_option("input", command.inputs,
                 "input surface file; several: one conforming mesh of their regions, each hex labelled by its "
                 "input's position (docs/regions.md); without any, --shape (default: torus)");
  app.add_option("--region-order", command.region_order,
                 "several regions: which region a point inside several belongs to, as input positions highest "
                 "priority first (for example 2,1); default: the smaller enclosed volume first")
      ->delimiter(',');
  app.add_flag("--shells-as-regions", command.shells_as_regions,
               "one INPUT whose closed shells (connected through their edges) are the regions, in file order");
  app.add_flag("--region-files", command.region_files,
               "several regions: also write each region's own mesh beside the inside one, as STEM.regionI.EXT");
  app.add_option("--junction-lift", command.options.junction_lift,
                 "several regions: where two shells cross, lift the field within this many cells of the crossing "
                 "curve so that Marching Cubes opens its saddle a cell wide (docs/regions.md); 0: off")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  app.add_option("--shape", command.shape, "built-in analytic shape: sphere, torus, rounded-box, two-holed");
  app.add_option("-o,--output", command.inside, "inside mesh (.mesh, .meshb, .vtu, .msh, .exo or .inp)")
      ->capture_default_str();
  app.add_flag("--binary", command.write.binary, kBinaryHelp);
  app.add_option("--outside", command.outside, "outside mesh (default: outside.EXT beside the inside mesh)");
  app.add_option("--method", command.options.method,
                 "mchex: cut every cell by the isosurface (MC33, local refinement where the paper "
                 "needs it) and split the pieces into hexes; ro: keep the cells whose 8 corner "
                 "values sum above 0 (the paper's baseline)")
      ->check(CLI::IsMember({"ro", "mchex"}))
      ->capture_default_str();
  app.add_option("--crossings", command.options.crossings,
                 "--method mchex: where a cut grid edge's crossing lies: linear, the zero of the two values "
                 "interpolated along it (Marching Cubes); exact, the field's own zero on the edge, where it meets the "
                 "input's facets (sharper at sharp edges; docs/pipeline.md)")
      ->check(CLI::IsMember({"linear", "exact"}))
      ->capture_default_str();
  eps_ = app.add_option("--eps", command.options.eps,
                        fmt::format("--method mchex: clamp edge crossings to [eps, 1 - eps], eps in (0, 0.5); "
                                    "with --optimize the default is {}",
                                    kOptimizeEps))
             ->check(CLI::Range(0.0, 0.5))
             ->capture_default_str();
  depth_ = app.add_option("--depth", command.options.depth,
                          "uniform 3-refinement depth: 3^depth cells per axis (instead of the fitted adaptive "
                          "grid of --hausdorff)")
               ->check(CLI::Range(0, kMaxUniformDepth));
  threshold_ =
      app.add_option(
             "--threshold", command.options.threshold,
             "adaptive 3-refinement instead of --depth: a cell the surface may pass through is refined while the "
             "paper's refinement error (how far its trilinear isosurface lies from its 27 children's) exceeds "
             "THRESHOLD times the finest cell size (box edge / 3^max-depth); cells the surface misses are never "
             "refined. --max-depth sets the resolution, THRESHOLD the accuracy asked of coarser cells in units of "
             "it; dimensionless, so it suits a model of any size (the paper's batch run: 0.05)")
          ->check(CLI::PositiveNumber);
  auto* max_depth = app.add_option("--max-depth", command.options.max_depth, "--threshold: deepest refinement level")
                        ->check(CLI::Range(0, kMaxAdaptiveDepth))
                        ->capture_default_str();
  auto* volume_threshold =
      app.add_option("--volume-threshold", command.options.volume_threshold,
                     "--threshold: also refine a cell when its refinement error times its area exceeds V times "
                     "the box volume")
          ->check(CLI::NonNegativeNumber);
  auto* surface_tolerance =
      app.add_option("--surface-tolerance", command.options.surface_tolerance,
                     "--threshold: also refine a cell when a point of the input surface in it lies farther than S "
                     "x the input's diagonal from the cell's trilinear isosurface")
          ->check(CLI::NonNegativeNumber);
  hausdorff_ =
      app.add_option("--hausdorff", command.options.hausdorff,
                     fmt::format("the default grid: the adaptive grid fitted to this target Hausdorff ratio (the "
                                 "two-sided Hausdorff distance between mesh boundary and input over the input's "
                                 "bounding-box diagonal): finest cell about H x diagonal (default {})",
                                 kDefaultHausdorffRatio))
          ->check(CLI::PositiveNumber);
  auto* max_hexes = app.add_option("--max-hexes", command.options.max_hexes,
                                   "at most N output hexes (both meshes): the adaptive grid is coarsened where its "
                                   "error is smallest until its predicted output fits (exit 2 when nothing does)")
                        ->check(CLI::Range(std::size_t{1}, std::size_t{1} << 40))
                        ->type_name("N");
  // One grid setting: a uniform depth, an explicit adaptive one, or the fitted default.
  depth_->excludes(threshold_)->excludes(max_depth)->excludes(hausdorff_)->excludes(max_hexes);
  hausdorff_->excludes(threshold_)->excludes(max_depth);
  max_depth->needs(threshold_);
  volume_threshold->needs(threshold_);
  surface_tolerance->needs(threshold_);
  app.add_option("--pad", command.options.pad, "padding around the input, as a fraction of its largest extent")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  const std::vector<std::string> backends = built_backend_names();
  app.add_option("--backend", command.backend,
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
  app.add_option_function<std::string>(
         "--max-memory",
         [this](const std::string& text) {
           const auto bytes = parse_memory_size(text);
           if (!bytes) throw CLI::ValidationError("--max-memory", "expected a size such as 8G or 512M, got " + text);
           command.options.max_memory = *bytes;
         },
         "refuse (exit 2) a run whose estimated peak memory is over SIZE (8G, 512M; K, M, G, T are powers of "
         "1024); default: 80% of the memory available now")
      ->type_name("SIZE");
  app.add_option("--sign", command.options.input.sign, kSignHelp)
      ->transform(CLI::CheckedTransformer(sign_rules(), CLI::ignore_case))
      ->default_str("winding");
  app.add_flag("--no-repair{false}", command.options.input.repair,
               "mesh the surface as read: no orientation repair (duplicates, flipped faces, inside-out shells)");
  app.add_option("--report", command.report, "write a JSON report to this file");
  app.add_option("--trace", command.trace,
                 "write the stages and every kernel dispatch, upload and download as a Chrome trace-event JSON "
                 "file (Perfetto, chrome://tracing)");
  auto* fidelity = app.add_flag("--fidelity", command.options.fidelity,
                                "measure IoU and Hausdorff ratio against the input (the default)");
  app.add_flag("--no-fidelity", no_fidelity_, "skip the IoU and Hausdorff measures")->excludes(fidelity);
  // The summary measures fidelity by default: a lattice of 64 keeps it a fraction of the run
  // (README, "Fidelity by default"), the Hausdorff ratio does not depend on it.
  command.options.lattice = 64;
  app.add_option("--lattice", command.options.lattice, "samples per axis for the IoU")
      ->check(CLI::Range(8, 1024))
      ->capture_default_str();

  // An option with an optional value: `--repel` alone is the default delta. Parsed in finish() so
  // that a bad value is the one-line InputError of every other bad input.
  repel_ = app.add_option("--repel", repel_text_,
                          fmt::format("repel grid points from the surface before cutting (Awad et al. 2016): every "
                                      "crossing DELTA x its edge from both ends where the rules allow, DELTA in (0, "
                                      "{}] (default {}; docs/repel.md)",
                                      kMaxRepelDelta, kDefaultRepelDelta))
               ->expected(0, 1)
               ->type_name("[DELTA]");
  app.add_option("--repel-off-line-rounds", command.options.repel_off_line_rounds,
                 "--repel: then at most this many rounds moving the points the grid-line rules leave too near "
                 "along the SDF's gradient instead (0: Awad's grid-aligned rule alone; docs/repel.md)")
      ->check(CLI::Range(0, 100))
      ->capture_default_str();
  app.add_flag("--no-snap{false}", command.options.snap,
               "--method mchex: leave the boundary where the cut put it (by default each boundary vertex is moved onto "
               "the input surface, or part of the way, where every hex stays certified; docs/pipeline.md)");
  app.add_flag("--optimize", command.options.optimize,
               "move vertices after meshing to raise the minimum and mean scaled Jacobian: boundary vertices stay "
               "on the input surface, every hex stays Bernstein-certified (docs/optimize.md)");
  app.add_option("--optimize-sweeps", command.options.optimize_options.max_sweeps,
                 "--optimize: at most this many sweeps raising the scaled Jacobian (the plain sweeps and the search)")
      ->check(CLI::Range(0, 10000))
      ->capture_default_str();
  app.add_option("--optimize-ratio-sweeps", command.options.optimize_options.ratio_sweeps,
                 "--optimize: then at most this many sweeps lowering the edge ratios above "
                 "--optimize-max-edge-ratio (docs/optimize.md)")
      ->check(CLI::Range(0, 10000))
      ->capture_default_str();

  app.add_option("--optimize-max-edge-ratio", command.options.optimize_options.max_edge_ratio,
                 "--optimize: no move takes a hex's edge ratio (longest edge over shortest) past this, or past "
                 "the largest among the hexes of the vertex that moves where that is larger (docs/optimize.md)")
      ->check(CLI::Range(1.0, 1e6))
      ->capture_default_str();
  app.add_option("--optimize-tolerance", command.options.optimize_options.tolerance,
                 "--optimize: stop when a sweep raises the minimum scaled Jacobian by less than this and the mean "
                 "by less than 10 times it")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
}

void MeshCli::finish() {
  if (depth_->count() == 0 && threshold_->count() == 0 && hausdorff_->count() == 0)
    command.options.hausdorff = kDefaultHausdorffRatio;
  command.options.fidelity = !no_fidelity_;
  if (command.options.optimize && eps_->count() == 0) command.options.eps = kOptimizeEps;
  if (repel_->count() > 0) command.options.repel = parse_repel_delta(repel_text_);
}

void add_check_options(CLI::App& app, CheckCommand& command) {
  app.add_option("mesh", command.mesh, "hex mesh (.mesh, .meshb, .vtu, .msh, .exo or .inp)")->required();
  app.add_option("--outside", command.outside, "the outside mesh: check that both conform and fill their box");
  app.add_option("--input", command.input, "the input surface: measure IoU and Hausdorff distance");
  app.add_option("--shape", command.shape, "the built-in shape the mesh was made from, as --input");
  app.add_option("--sign", command.solid.sign, "--input: the sign rule the mesh was made with, as mesh --sign")
      ->transform(CLI::CheckedTransformer(sign_rules(), CLI::ignore_case))
      ->default_str("winding");
  app.add_flag("--no-repair{false}", command.solid.repair, "--input: as mesh --no-repair");
  app.add_flag("--json", command.json, "print the results as JSON");
  app.add_option("--lattice", command.lattice, "samples per axis for the IoU")
      ->check(CLI::Range(8, 1024))
      ->capture_default_str();
}

}  // namespace mchex::cli
