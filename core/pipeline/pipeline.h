// The mesh pipeline, one function for the command line, the benchmarks and the tests: a solid
// (core/pipeline/solid.h) -> the grid over its padded cube (uniform 3-refinement, or the adaptive
// 3-refinement of core/grid/octree.h) -> the SDF at the grid's points on a backend
// (core/device/backend.h) -> the mesher (MCHex, Tong & Zhang 2025, or the paper's RO baseline) ->
// the validator (core/check/mesh_check.h) -> fidelity (the paper's Section 6 measures) when asked.
// core/pipeline/report.h turns a run into the report JSON.
//
// Guarantees: the meshes do not depend on the backend (every backend gives the cpu reference's
// SDF values bit for bit, tests/test_opencl.cpp; under the winding-number sign the host re-signs
// them with the solid's winding number), nor on how many threads run. Errors are exceptions:
// InputError (bad input: exit 1 in the CLI), ResourceError (a run whose estimated peak memory is
// over its budget, core/pipeline/estimate.h: refused before the mesher's work, exit 2). A mesh that
// fails its own check is no exception here: the run says so in `check`, and the caller decides
// (the CLI writes the report and no mesh, and exits 3).
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "core/base/stage_clock.h"
#include "core/check/fidelity.h"
#include "core/check/mesh_check.h"
#include "core/cutting/mchex_mesher.h"
#include "core/cutting/repel.h"
#include "core/device/backend.h"
#include "core/grid/grid.h"
#include "core/grid/octree.h"
#include "core/io/mesh_io.h"
#include "core/optimize/optimize.h"
#include "core/pipeline/fit.h"
#include "core/pipeline/regions.h"
#include "core/pipeline/solid.h"

namespace mchex {

struct MeshOptions {
  std::string method = "mchex";  // "mchex" | "ro"
  int depth = 3;                 // uniform grid: 3^depth cells per axis (0 .. kMaxUniformDepth)
  // > 0: the adaptive grid instead, refined while the paper's refinement error exceeds
  // threshold x the finest cell size (core/grid/octree.h AdaptiveOptions), to max_depth.
  double threshold = 0;
  int max_depth = 5;
  int error_depth = -1;         // adaptive: core/grid/octree.h AdaptiveOptions (set by hausdorff)
  double volume_threshold = 0;  // adaptive: core/grid/octree.h AdaptiveOptions
  // adaptive: AdaptiveOptions::surface_tolerance as a fraction of the input's bounding-box
  // diagonal, tested at samples of the input surface a finest cell apart (a surface input only)
  double surface_tolerance = 0;
  // > 0: the adaptive grid with threshold and max_depth chosen for this target Hausdorff ratio
  // (core/pipeline/fit.h adaptive_for_hausdorff); threshold and max_depth are then ignored.
  double hausdorff = 0;
  // > 0 (adaptive grid only): at most this many output hexes, both meshes together; the setting
  // is lowered until its predicted output fits (core/pipeline/fit.h fit_max_hexes).
  std::size_t max_hexes = 0;
  double pad = 0.1;   // padding around the solid, as a fraction of its largest extent
  double eps = 1e-3;  // method mchex: crossings clamped to [eps, 1 - eps]
  // Method mchex: "linear", the zero of the values interpolated along each cut edge (Marching
  // Cubes), or "exact", the field's own zero on the edge (core/cutting/mchex_mesher.h MchexCrossings).
  std::string crossings = "linear";
  // > 0: grid points repelled from the isosurface before cutting (core/cutting/repel.h), every
  // crossing this fraction of its edge from both ends where the rules allow; 0: off.
  double repel = 0;
  // With repel: rounds along the SDF's gradient for the points the grid-line rules leave unmet
  // (core/cutting/repel.h RepelOptions::off_line_rounds); 0 keeps Awad's grid-aligned rule alone.
  int repel_off_line_rounds = RepelOptions{}.off_line_rounds;
  // Several regions, method mchex: the parity field's lift around the junction curves, in cells
  // of the grid where each lies (core/pipeline/regions.h JunctionLift); 0: off.
  double junction_lift = kJunctionLiftRadius;
  bool fidelity = false;
  std::size_t lattice = 128;  // fidelity: IoU samples per axis
  bool quiet = false;         // no progress lines, no warning about an open surface
  // Peak memory allowed, bytes (core/pipeline/estimate.h); 0: 80 % of MemAvailable.
  std::size_t max_memory = 0;
  SolidOptions input;  // repair and sign rule of a surface (core/pipeline/solid.h)
  // Move vertices after meshing, before the check (core/optimize/optimize.h): boundary vertices
  // on the input surface, every hex still Bernstein-certified.
  bool optimize = false;
  OptimizeOptions optimize_options;
  // Method mchex: after each cut the boundary is snapped onto the surface (several regions: onto
  // their shells, away from junction curves) where every hex stays certified (core/optimize/
  // optimize.h snap_boundary; mesh --no-snap turns it off).
  bool snap = true;
  // The check keeps each hex's scaled Jacobian for write_meshes (a .vtu output's cell field,
  // which its writer would otherwise compute again): 8 bytes per hex.
  bool keep_scaled_jacobians = false;
  bool adaptive() const { return threshold > 0 || hausdorff > 0; }
};

struct MeshRequest {
  SolidSource solid;
  // Two or more: the regions of one region-labelled mesh instead of `solid` (core/pipeline/
  // regions.h), with their priority (1-based input positions, highest first; empty: by volume).
  std::vector<SolidSource> regions;
  std::vector<int> region_order;
  // The shells of solid's one file as the regions instead (core/pipeline/regions.h split_shells;
  // mesh --shells-as-regions), named FILE shell I in file order.
  bool shells_as_regions = false;
  MeshOptions options;
  // Where the SDF runs: the caller's backend (host/backends/registry.h make_backend), or one that
  // open_backend makes when the SDF stage starts, so that a bad input or an oversized grid fails
  // before any device is probed. Exactly one of the two.
  Backend* backend = nullptr;
  std::function<std::unique_ptr<Backend>()> open_backend;
};

// Where the adaptive grid's time went (stage "octree" is their sum): the refinement's SDF batches
// apart, wall and CPU seconds (all threads), for the benchmarks' cells-per-second figures.
struct OctreeTimes {
  double refine = 0;  // less its SDF batches
  double balance = 0;
  double complex = 0;  // the templates: build_adaptive_complex
  double sdf = 0, sdf_cpu = 0;
  double cpu = 0;  // refine + balance + complex, CPU seconds, SDF batches taken out
};

// The certification remedy's work (mesh_solid; docs/templates.md, "Certification").
struct RemedyStats {
  int rounds = 0;                  // times the grid was refined and meshed again
  std::size_t cells = 0;           // cut cells with an uncertified polyhedron, over the rounds
  std::size_t refined_leaves = 0;  // octree leaves refined for them
};

// The fitted grid's measured rounds (mesh_solid; core/pipeline/fit.h): each measures the mesh's
// Hausdorff distance to the input, refines the leaves where it exceeds the target and meshes again.
struct FitRound {
  double hausdorff_ratio = 0;  // measured before the round's refinement
  double iou = 0;              // likewise
  std::size_t far_points = 0;  // samples farther than the target
  std::size_t refined_leaves = 0;
  std::size_t hexes = 0;  // inside + outside, as measured
};

struct MeshRun {
  MeshOptions options;           // as asked, with threshold and max_depth as fitted (hausdorff, max_hexes)
  std::optional<FitResult> fit;  // max_hexes: the settings the search built
  SolidFacts input;
  Box cube;                              // the padded cube the grid fills
  std::optional<UniformGrid> uniform;    // the grid: uniform ...
  std::optional<AdaptiveGrid> adaptive;  // ... or adaptive (its values moved to the mesher)
  std::size_t unsampled_points = 0;      // adaptive: points the refinement did not sample (the
                                         // SDF stage's batch; adaptive->unsampled is empty after it)
  OctreeStats octree;
  OctreeTimes octree_times;
  DeviceInfo device;  // the backend's facts
  int threads = 0;    // worker threads the machine offers
  MeshPair meshes;
  MeshCheck check;
  MchexStats mchex;                       // method mchex (of the last meshing)
  RemedyStats remedy;                     // adaptive grid, method mchex
  std::optional<SnapStats> snap;          // the last cut's snap (MeshOptions::snap)
  std::optional<RepelStats> repel;        // when asked for (of the last meshing)
  std::vector<FitRound> fit_rounds;       // hausdorff with fidelity: the measured rounds
  std::optional<Fidelity> fidelity;       // when asked for
  std::optional<OptimizeStats> optimize;  // when asked for
  std::optional<RegionStats> regions;     // several regions: the labelling (fidelity is of the parity field's mesh)
  StageClock clock{
      true};  // read, bvh, octree, sdf, classify, mchex | ro, fit-rounds, optimize, regions, check, fidelity, write
  std::size_t peak_memory_bytes = 0;  // of the process, after the last stage
};

// The whole pipeline from request.solid.
MeshRun run_pipeline(const MeshRequest& request);
// The same on a solid already loaded (several runs on one surface build its BVH once);
// request.solid is not read.
MeshRun run_pipeline(const MeshRequest& request, const Solid& solid);

// Both meshes written (core/io/mesh_io.h, atomically; the format follows each extension) as the
// run's stage "write", the peak memory updated; a .vtu takes the scaled Jacobians the check kept
// (MeshOptions::keep_scaled_jacobians), which are then released. A mesh that fails its check is never written:
// std::logic_error if run.check is not ok.
void write_meshes(MeshRun& run, const std::filesystem::path& inside, const std::filesystem::path& outside,
                  const MeshWriteOptions& write = {});

}  // namespace mchex
