#include "core/pipeline/pipeline.h"

#include "core/check/fidelity.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <span>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "core/base/error.h"
#include "core/base/parallel.h"
#include "core/cutting/repel.h"
#include "core/cutting/ro.h"
#include "core/grid/hex_complex.h"
#include "core/io/mesh_io.h"
#include "core/io/surface_io.h"
#include "core/mesh/quality.h"
#include "core/pipeline/estimate.h"
#include "core/sdf/winding_number.h"

namespace mchex {
namespace {

double wall_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// The solid's SDF with its batches timed, so that the refinement's own time can be told apart
// from the SDF's (refine_octree evaluates one batch per level, never two at once).
class TimedSdf final : public SignedDistance {
 public:
  explicit TimedSdf(const SignedDistance& s) : s_(s) {}
  void evaluate(std::span<const Vec3> p, std::span<double> v) const override {
    const double w = wall_seconds(), c = cpu_seconds();
    s_.evaluate(p, v);
    wall += wall_seconds() - w;
    cpu += cpu_seconds() - c;
  }
  Box bounds() const override { return s_.bounds(); }
  mutable double wall = 0, cpu = 0;

 private:
  const SignedDistance& s_;
};

// What the snap may cost a hex (docs/pipeline.md, "The boundary snapped"). With --repel the user
// asked for quality: alone, no hex may lose any; followed by --optimize, which raises the scaled
// Jacobian again but can only lower an edge ratio it is given room for, the fidelity's floor and
// the optimiser's own edge-ratio cap (a snap that kept quality left the optimiser a boundary it
// could not fit: the bunny's IoU 0.9979 under the plain snapped mesh's 0.9984). Several regions
// keep quality with --optimize too: beside a junction curve the cap then left no room (two
// crossing spheres at cap 8.3 ended at 8.45), for 0.001 of IoU.
SnapLimits snap_limits(const MeshOptions& o, bool regions) {
  if (o.repel > 0 && o.optimize && !regions) return {kSnapFloor, o.optimize_options.max_edge_ratio};
  if (o.repel > 0) return kSnapKeepingQuality;
  return {};
}

// The run's estimated peak memory against its budget (core/pipeline/estimate.h): refused early
// (ResourceError, exit 2) with a coarser setting that fits, rather than dying half-way. A uniform
// grid is estimated before any work; an adaptive one once the octree is refined, from its cells
// (a level less has about 1/9 of the cells near the surface).
void check_memory_budget(const MeshRun& run) {
  const MeshOptions& o = run.options;
  const std::size_t budget = o.max_memory != 0 ? o.max_memory : default_memory_budget();
  const std::string budget_name = o.max_memory != 0 ? "--max-memory" : "80% of the available memory,";
  std::optional<std::pair<std::string, RunEstimate>> fits;
  if (run.uniform) {
    for (int d = o.depth - 1; d >= 0 && !fits; --d)
      if (const RunEstimate e = estimate_uniform(d, o.method); e.bytes <= double(budget))
        fits.emplace(fmt::format("--depth {}", d), e);
    enforce_memory_budget(fmt::format("depth {}", o.depth), estimate_uniform(o.depth, o.method), budget, budget_name,
                          fits);
    return;
  }
  const double cells = double(run.adaptive->complex.cells.size()), n = std::pow(3.0, o.max_depth);
  for (int k = 1; k <= o.max_depth && !fits; ++k)
    if (const RunEstimate e = estimate_cells(cells / std::pow(9.0, k), n / std::pow(3.0, k), o.method);
        e.bytes <= double(budget))
      fits.emplace(fmt::format("--max-depth {}", o.max_depth - k), e);
  enforce_memory_budget(fmt::format("the adaptive grid of {} cells", run.adaptive->complex.cells.size()),
                        estimate_cells(cells, n, o.method), budget, budget_name, fits);
}

// The adaptive 3-refinement grid (core/grid/octree.h) as a HexComplex, each part timed; the
// octree is kept for the remedy (mesh_solid).
AdaptiveGrid build_adaptive_grid(const Solid& solid, MeshRun& run, std::optional<Octree>& kept) {
  const MeshOptions& o = run.options;
  TimedSdf sdf(solid.sdf());
  const double w0 = wall_seconds(), c0 = cpu_seconds();
  AdaptiveOptions a{o.threshold, o.max_depth, o.error_depth, o.volume_threshold};
  std::vector<Vec3> samples;
  if (o.surface_tolerance > 0 && solid.surface() != nullptr) {
    samples = sample_surface(*solid.surface(), (run.cube.hi.x - run.cube.lo.x) / std::pow(3.0, o.max_depth));
    a.surface_tolerance = o.surface_tolerance * solid.sdf().bounds().diagonal();
    a.surface_samples = samples;
  }
  Octree& tree = kept.emplace(refine_octree(sdf, run.cube, a, &run.octree));
  const double w1 = wall_seconds();
  balance_octree(tree, &run.octree);
  const double w2 = wall_seconds();
  AdaptiveGrid grid = build_adaptive_complex(tree);
  OctreeTimes& t = run.octree_times;
  t.cpu = cpu_seconds() - c0 - sdf.cpu;
  t.refine = w1 - w0 - sdf.wall;
  t.balance = w2 - w1;
  t.complex = wall_seconds() - w2;
  t.sdf = sdf.wall;
  t.sdf_cpu = sdf.cpu;
  return grid;
}

// The backend's SDF at `points`, with the solid's sign. Device kernels sign by the pseudonormal;
// under the winding-number rule the host re-signs their values (the distances are the same bit
// for bit), so every backend gives the solid's own field. The cpu backend evaluates the solid's
// SDF itself (SdfSource::reference): already signed so. Returns whether the values are still
// those the backend wrote (no sign changed), as ClassifyOptions::values_from_last_sdf needs.
bool backend_sdf(Backend& backend, const Solid& solid, std::span<const Vec3> points, std::span<double> values) {
  backend.signed_distance(solid.sdf_source(), points, values);
  const WindingNumber* w = solid.winding();
  if (!w || backend.device().backend == "cpu") return true;
  // In slices, each compared with its copy: a clean closed surface changes no sign, and the
  // device then keeps classifying from its own copy.
  constexpr std::size_t kSlice = std::size_t{1} << 20;
  bool unchanged = true;
  std::vector<double> before;
  for (std::size_t s = 0; s < points.size(); s += kSlice) {
    const std::size_t n = std::min(kSlice, points.size() - s);
    before.assign(values.begin() + s, values.begin() + s + n);
    apply_winding_sign(*w, points.subspan(s, n), values.subspan(s, n));
    unchanged = unchanged && std::equal(before.begin(), before.end(), values.begin() + s);
  }
  return unchanged;
}

// The SDF at every grid point, in the mesher's order. The adaptive grid already holds the values
// the refinement sampled (bit for bit what a new evaluation gives: same points); only the points
// it never sampled need this batch.
std::vector<double> grid_values(MeshRun& run, Backend& backend, const Solid& solid, bool& device_values) {
  if (run.adaptive) {
    run.unsampled_points = run.adaptive->unsampled.size();
    const std::vector<Vec3> points = unsampled_points(*run.adaptive);
    std::vector<double> v(points.size());
    if (!points.empty()) device_values = backend_sdf(backend, solid, points, v);
    set_unsampled_values(*run.adaptive, v);
    return std::move(run.adaptive->values);
  }
  const std::vector<Vec3> points = run.uniform->vertices();
  std::vector<double> v(points.size());
  device_values = backend_sdf(backend, solid, points, v);
  return v;
}

MeshRun mesh_solid(const MeshRequest& request, const Solid& solid, StageClock clock,
                   const RegionSet* regions = nullptr) {
  MeshRun run;
  run.options = request.options;
  run.clock = std::move(clock);
  const MeshOptions& o = run.options;
  if (o.method != "mchex" && o.method != "ro") throw InputError("method must be mchex or ro, got " + o.method);
  if (o.crossings != "linear" && o.crossings != "exact")
    throw InputError("crossings must be linear or exact, got " + o.crossings);
  if ((request.backend != nullptr) == bool(request.open_backend))
    throw std::invalid_argument("run_pipeline: give a backend or open_backend, exactly one");
  run.input = solid.facts();
  run.threads = hardware_threads();
  run.cube = padded_cube(solid.sdf().bounds(), o.pad);
  if (o.max_hexes > 0 && !o.adaptive())
    throw InputError("a hex cap (max_hexes) needs the adaptive grid: a uniform grid's size is set by its depth");
  if (o.hausdorff > 0) {
    const AdaptiveOptions a = adaptive_for_hausdorff(o.hausdorff, solid.sdf().bounds(), run.cube);
    run.options.threshold = a.threshold;
    run.options.max_depth = a.max_depth;
    run.options.error_depth = a.error_depth;
  }
  if (o.max_hexes > 0) {
    run.fit = run.clock.run("fit", [&] {
      // From the error test's depth: the cap has no measured rounds to use the levels below it.
      return fit_max_hexes(solid.sdf(), run.cube, {o.threshold, o.error_depth >= 0 ? o.error_depth : o.max_depth},
                           o.max_hexes, o.method);
    });
    run.options.error_depth = -1;
    run.options.threshold = run.fit->options.threshold;
    run.options.max_depth = run.fit->options.max_depth;
  }
  std::optional<Octree> tree;
  if (o.adaptive()) {
    run.adaptive = run.clock.run("octree", [&] { return build_adaptive_grid(solid, run, tree); });
  } else {
    run.uniform.emplace(run.cube, o.depth);
  }
  check_memory_budget(run);

  // The SDF batch runs on the chosen backend; every backend gives the cpu reference's values bit
  // for bit, so the mesh does not depend on the choice.
  std::unique_ptr<Backend> opened;
  Backend& backend = request.backend ? *request.backend : *(opened = request.open_backend());
  run.device = backend.device();
  std::vector<Vec3> repelled_points;  // the grid points the last mesh was cut at, where repel moved them
  // Several regions whose shells cross: the parity field is lifted around their junction curves
  // (core/pipeline/regions.h JunctionLift) wherever the mesher reads it, by one cell of the grid
  // where the curve lies (an adaptive grid's leaf at each segment's midpoint, anew for each grid).
  std::optional<JunctionLift> lift;
  const bool lifts = regions && o.method == "mchex" && o.junction_lift > 0 && !regions->junctions().empty();
  const auto field = [&](std::span<const Vec3> p, std::span<double> v) {
    const bool unchanged = backend_sdf(backend, solid, p, v);
    return (!lift || lift->lift(p, v) == 0) && unchanged;
  };
  auto mesh_grid = [&] {
    bool device_values = true;  // values as the backend wrote them: no sign changed on the host
    std::vector<double> values = run.clock.run("sdf", [&] { return grid_values(run, backend, solid, device_values); });
    if (lifts) {
      const std::vector<Segment>& curves = regions->junctions();
      std::vector<double> radii(curves.size(), o.junction_lift * (run.uniform ? run.uniform->cell_size() : 0.0));
      if (tree)
        for (std::size_t s = 0; s < curves.size(); ++s) {
          const int level = leaf_level_at(*tree, 0.5 * (curves[s][0] + curves[s][1]));  // inside the cube
          radii[s] = o.junction_lift * run.cube.size().x / std::pow(3.0, level < 0 ? tree->max_depth() : level);
        }
      lift.emplace(curves, std::move(radii));
      // The adaptive grid's values came from its refinement, the uniform grid's from the backend:
      // the lift applies to all of them here, through the points nearer than a radius to a shell
      // (no other can be lifted), whose positions alone are made.
      std::vector<std::size_t> near;
      for (std::size_t i = 0; i < values.size(); ++i)
        if (std::abs(values[i]) < lift->max_radius()) near.push_back(i);
      std::vector<Vec3> near_points(near.size());
      std::vector<double> near_values(near.size());
      const uint32_t m = run.uniform ? run.uniform->cells_per_axis() + 1 : 0;
      for (std::size_t k = 0; k < near.size(); ++k) {
        const std::size_t i = near[k];
        near_points[k] = run.uniform ? run.uniform->vertex(uint32_t(i % m), uint32_t(i / m % m), uint32_t(i / m / m))
                                     : run.adaptive->complex.points[i];
        near_values[k] = values[i];
      }
      if (lift->lift(near_points, near_values) > 0) {
        device_values = false;
        for (std::size_t k = 0; k < near.size(); ++k) values[near[k]] = near_values[k];
      }
    }
    std::optional<HexComplex> uniform_cx;
    const bool classify_on_device = o.method == "mchex" && run.device.backend != "cpu";
    if (run.uniform && (classify_on_device || o.repel > 0)) uniform_cx.emplace(uniform_complex(*run.uniform));
    const HexComplex* grid_cx = run.adaptive ? &run.adaptive->complex : uniform_cx ? &*uniform_cx : nullptr;

    // Grid-point repelling (core/cutting/repel.h): the mesher cuts a copy of the complex whose
    // points moved, at the SDF values there (the same backend: the same values on any).
    std::optional<Repelled> repelled;
    std::optional<HexComplex> moved_cx;
    if (o.repel > 0) {
      run.clock.run("repel", [&] {
        RepelOptions ro;
        ro.delta = o.repel;
        ro.off_line_rounds = o.repel_off_line_rounds;
        ro.exact_crossings = o.method == "mchex" && o.crossings == "exact";  // what the mesher will cut at
        repelled = repel(*grid_cx, run.cube, values, field, ro);
        moved_cx.emplace(*grid_cx);
        moved_cx->points = repelled->points;
      });
    }
    const std::vector<double>& mesh_values = repelled ? repelled->values : values;

    // Method mchex on a device backend: MC33 classification and the hex-count prefix sum run on
    // the device too (from the values after the mesher's zero rule), and the mesher checks every
    // cell's subcase and every chunk's hex count against it (core/cutting/mchex_mesher.h
    // DeviceClassification). The cpu backend's classification would be core's own: not repeated.
    std::vector<std::uint8_t> device_subcases;
    std::vector<std::uint64_t> device_offsets;
    auto classify = [&] {
      if (!classify_on_device) return;
      const HexComplex& cx = *grid_cx;  // the device classifies from values and corner ids only
      run.clock.run("classify", [&] {
        // The device applies the zero rule itself, reads the values the SDF left on it, and
        // computes a uniform grid's corner ids (core/device/backend.h ClassifyOptions).
        ClassifyOptions co;
        co.zero_tolerance = zero_tolerance_of(cx);
        co.uniform_cells_per_axis = run.adaptive ? 0 : run.uniform->cells_per_axis();
        // Repelled values were not the device's last batch (the moved points were).
        co.values_from_last_sdf = device_values && !repelled;
        device_subcases.resize(cx.cells.size());
        device_offsets.resize(cx.cells.size() + 1);
        backend.classify_cells(cx, mesh_values, {device_subcases, device_offsets}, co);
      });
    };
    auto run_method = [&](const auto& where) {
      // The meshes of an earlier grid (a fit round, the remedy) are not needed any more: freed
      // before the new ones are made rather than after, which would hold both at the peak.
      run.meshes = MeshPair{};
      if (o.method != "mchex") return run.clock.run("ro", [&] { return mesh_remove_outside(where, mesh_values); });
      return run.clock.run("mchex", [&] {
        run.mchex = {};
        MchexCrossings crossings;
        if (o.crossings == "exact") crossings.field = field;
        if constexpr (std::is_same_v<std::decay_t<decltype(where)>, HexComplex>)
          return mesh_mchex(where, mesh_values, o.eps, &run.mchex, {device_subcases, device_offsets}, crossings);
        else if (crossings.field)
          return mesh_mchex(uniform_complex(where), mesh_values, o.eps, &run.mchex, {}, crossings);
        else return mesh_mchex(where, mesh_values, o.eps, &run.mchex);
      });
    };
    classify();
    if (!repelled) {
      run.meshes = run.adaptive ? run_method(run.adaptive->complex)
                   : uniform_cx ? run_method(*uniform_cx)
                                : run_method(*run.uniform);
      run.repel.reset();
      repelled_points.clear();
      return;
    }
    // A moved cell whose hexes are not all certified has its corners' moves halved, then given
    // back (relax_cells), and the grid is meshed again: each round halves or restores at least
    // one moved point, so it ends, at worst with the unmoved grid. RO's hexes are the cells
    // themselves, checked here the same way.
    for (;;) {
      run.meshes = run_method(*moved_cx);
      std::vector<std::uint32_t> bad;
      if (o.method == "mchex") {
        bad = run.mchex.uncertified_cells;
      } else {
        std::vector<std::uint8_t> ok(moved_cx->cells.size());
        parallel_for(ok.size(), [&](std::size_t c) {
          HexCorners corners;
          for (int k = 0; k < 8; ++k) corners[k] = moved_cx->points[moved_cx->cells[c][k]];
          ok[c] = bernstein_certified(corners);
        });
        for (std::uint32_t c = 0; c < ok.size(); ++c)
          if (!ok[c]) bad.push_back(c);
      }
      if (bad.empty() ||
          run.clock.run("repel", [&] { return relax_cells(*grid_cx, values, bad, field, *repelled); }) == 0)
        break;
      moved_cx->points = repelled->points;
      classify();
    }
    run.repel = repelled->stats;
    repelled_points = std::move(repelled->points);
  };
  // The remedy for a cut cell that no certificate covers (docs/templates.md, "Certification"):
  // its leaf is refined and the grid meshed again. Leaves at max_depth are cubes, proven for every
  // subcase, so the loop ends; max_depth rounds reach them from any level. Every grid gets it,
  // the fit rounds' too: a round's new leaves can hold such a cell as well.
  const auto mesh_and_remedy = [&] {
    mesh_grid();
    for (int round = 0; tree && !run.mchex.uncertified_cells.empty() && round < o.max_depth; ++round) {
      const std::size_t refined = run.clock.run("remedy", [&] {
        const std::size_t n = refine_leaves_of_cells(*tree, *run.adaptive, run.mchex.uncertified_cells);
        run.adaptive = build_adaptive_complex(*tree);
        return n;
      });
      run.remedy.rounds += 1;
      run.remedy.cells += run.mchex.uncertified_cells.size();
      run.remedy.refined_leaves += refined;
      if (refined == 0) break;
      check_memory_budget(run);
      mesh_grid();
    }
    // Several regions: the cut's interface is every shell at once, and the closest point on them
    // is on the shell it approximates, except near a junction curve, where the lifted cut leaves
    // the shells by design and a projection could land on the other shell: those points stay
    // (the fitted rounds' margin, kJunctionFitMargin lift radii).
    if (o.snap && o.method == "mchex") {
      SnapHeld held;
      if (lift) held = [&](std::span<const Vec3> p) { return lift->near(p, kJunctionFitMargin); };
      run.snap = run.clock.run(
          "snap", [&] { return snap_boundary(run.meshes, solid.sdf(), snap_limits(o, regions != nullptr), held); });
    }
  };
  mesh_and_remedy();
  // The fitted grid's measured rounds (core/pipeline/fit.h): where the mesh lies farther from the
  // input than the target, in either direction, the leaves holding those samples are refined and
  // the grid meshed again, until the target holds, nothing below max_depth is left to refine, or
  // kFitRounds rounds. The last measure is the run's fidelity. A hex cap has the last word: no
  // rounds under max_hexes.
  const bool rounds = tree && o.fidelity && o.hausdorff > 0 && o.max_hexes == 0;
  const double far = o.hausdorff * solid.sdf().bounds().diagonal();
  std::vector<Vec3> last_far;  // the last round's far samples, sorted
  for (int round = 0; rounds; ++round) {
    run.fidelity =
        run.clock.run("fidelity", [&] { return solid.fidelity(run.meshes.inside, run.cube, o.lattice, far); });
    if (lift) {
      // Near a junction curve the mesh leaves the shells by design (the lift): refining there
      // would only put transition cells, cut by the shells, beside the curve (docs/regions.md).
      for (std::vector<Vec3>* points : {&run.fidelity->far_points, &run.fidelity->misclassified_points}) {
        const std::vector<std::uint8_t> skip = lift->near(*points, kJunctionFitMargin);
        std::size_t kept = 0;
        for (std::size_t i = 0; i < points->size(); ++i)
          if (!skip[i]) (*points)[kept++] = (*points)[i];
        points->resize(kept);
      }
    }
    const Fidelity& fid = *run.fidelity;
    // A round that lowered neither the HR nor the IoU's shortfall would repeat itself, unless its
    // far samples are all new ones: where the surface is the same along a run of leaves (a
    // gearwheel's tooth roots), refining the far leaves makes their neighbours transition cells,
    // which can be as far, so the same HR turns up one leaf on until the run is refined
    // (docs/pipeline.md, "Why the gearwheel's HR stopped at 0.614 %"); such rounds go on.
    std::sort(run.fidelity->far_points.begin(), run.fidelity->far_points.end(), lexicographic_less);
    const bool moved =
        !last_far.empty() && std::none_of(fid.far_points.begin(), fid.far_points.end(), [&](const Vec3& p) {
          return std::binary_search(last_far.begin(), last_far.end(), p, lexicographic_less);
        });
    const bool same = !run.fit_rounds.empty() && !(fid.hausdorff_ratio < run.fit_rounds.back().hausdorff_ratio) &&
                      !(fid.iou > run.fit_rounds.back().iou);
    const bool stalled = same && !moved;
    // The chase's signature: the same HR (to rounding: the same distance one leaf on) from samples
    // that all moved.
    const bool chase =
        moved && !run.fit_rounds.empty() && !(fid.hausdorff_ratio < run.fit_rounds.back().hausdorff_ratio * (1 - 1e-9));
    const double iou_target = fit_iou(o.hausdorff);
    if ((fid.far_points.empty() && !(fid.iou < iou_target)) || stalled || round == kFitRounds) break;
    const std::vector<Vec3> previous_far = std::exchange(last_far, fid.far_points);
    FitRound& r = run.fit_rounds.emplace_back();
    r.hausdorff_ratio = run.fidelity->hausdorff_ratio;
    r.iou = run.fidelity->iou;
    r.far_points = run.fidelity->far_points.size();
    r.hexes = run.meshes.inside.hexes.size() + run.meshes.outside.hexes.size();
    r.refined_leaves = run.clock.run("fit-rounds", [&] {
      // In a chase along a run of same-level leaves (a gearwheel's tooth roots: refining a far
      // leaf makes its neighbour along the run the next far one) the run is refined a few leaves
      // ahead of the far samples too (chase_ahead, core/pipeline/fit.h), all in one refinement.
      std::vector<Vec3> at = run.fidelity->far_points;
      if (chase) {
        const std::vector<Vec3> ahead = chase_ahead(*tree, solid.sdf(), fid.far_points, previous_far);
        at.insert(at.end(), ahead.begin(), ahead.end());
      }
      std::size_t n = refine_leaves_at_points(*tree, at);
      if (fid.iou < iou_target)
        n += refine_leaves_at_points(*tree, run.fidelity->misclassified_points, kFitMisclassifiedPerLeaf);
      if (n) run.adaptive = build_adaptive_complex(*tree);
      return n;
    });
    if (r.refined_leaves == 0) break;
    run.fidelity.reset();
    check_memory_budget(run);
    mesh_and_remedy();
  }
  if (run.fidelity) run.fidelity->far_points = run.fidelity->misclassified_points = {};
  if (o.optimize) {
    run.optimize = run.clock.run(
        "optimize", [&] { return mchex::optimize(run.meshes, &solid.sdf(), o.optimize_options, solid.surface()); });
    run.fidelity.reset();  // the rounds measured the mesh before the optimiser moved it
  }
  if (regions) {
    // The fidelity measures the two meshes of the parity field against the shells; labelling
    // then regroups their hexes by region.
    if (o.fidelity && !run.fidelity)
      run.fidelity = run.clock.run("fidelity", [&] { return solid.fidelity(run.meshes.inside, run.cube, o.lattice); });
    RegionStats& stats = run.regions.emplace();
    run.meshes = run.clock.run("regions", [&] {
      // The points the cells were cut at: hexes find their grid corner among them.
      if (!repelled_points.empty()) return label_regions(run.meshes, repelled_points, *regions, &stats);
      const std::vector<Vec3> uniform_points = run.uniform ? run.uniform->vertices() : std::vector<Vec3>{};
      return label_regions(run.meshes, run.uniform ? uniform_points : run.adaptive->complex.points, *regions, &stats);
    });
    if (lift) stats.lift_min_radius = lift->min_radius(), stats.lift_max_radius = lift->max_radius();
  }
  CheckOptions check_options;
  check_options.keep_scaled_jacobians = o.keep_scaled_jacobians;
  run.check = run.clock.run(
      "check", [&] { return check_mesh(run.meshes.inside, &run.meshes.outside, &run.cube, check_options); });
  if (o.fidelity && !run.fidelity)
    run.fidelity = run.clock.run("fidelity", [&] { return solid.fidelity(run.meshes.inside, run.cube, o.lattice); });
  run.peak_memory_bytes = peak_memory_bytes();
  return run;
}

}  // namespace

MeshRun run_pipeline(const MeshRequest& request) {
  StageClock clock(request.options.quiet);
  std::vector<TriangleSurface> shells;  // --shells-as-regions: alive while the regions use them
  std::vector<SolidSource> sources = request.regions;
  if (request.shells_as_regions) {
    const SolidSource& one = request.solid;
    if ((one.path.empty() && !one.surface) || !sources.empty())
      throw InputError("--shells-as-regions splits one INPUT file into its shells");
    const std::string file = one.surface ? one.surface_name : std::filesystem::path(one.path).filename().string();
    shells = clock.run("read", [&] { return split_shells(one.surface ? *one.surface : read_surface(one.path)); });
    if (shells.size() < 2)
      throw InputError((one.surface ? one.surface_name : one.path) +
                       ": one shell, so one region; --shells-as-regions needs two or more");
    for (std::size_t i = 0; i < shells.size(); ++i)
      sources.push_back(SolidSource::in_memory(shells[i], fmt::format("{} shell {}", file, i + 1)));
  }
  if (!sources.empty()) {
    const bool quiet = request.options.quiet;
    const RegionSet regions(sources, clock, quiet, request.options.input, request.region_order);
    // The parity field of every shell at once (core/pipeline/regions.h); the regions' own
    // repair already ran, and the combined surface is non-manifold where regions touch.
    const Solid solid(SolidSource::in_memory(regions.combined(), regions.name()), clock, true,
                      {false, SignRule::kWindingParity});
    return mesh_solid(request, solid, std::move(clock), &regions);
  }
  const Solid solid(request.solid, clock, request.options.quiet, request.options.input);
  return mesh_solid(request, solid, std::move(clock));
}

MeshRun run_pipeline(const MeshRequest& request, const Solid& solid) {
  return mesh_solid(request, solid, StageClock(request.options.quiet));
}

void write_meshes(MeshRun& run, const std::filesystem::path& inside, const std::filesystem::path& outside,
                  const MeshWriteOptions& write) {
  if (!run.check.ok) throw std::logic_error("write_meshes: the mesh fails its own check");
  run.clock.run("write", [&] {
    // The check's scaled Jacobians are those of these very meshes (nothing moves them after it).
    MeshWriteOptions in = write, out = write;
    in.scaled_jacobians = run.check.inside.scaled_jacobians;
    if (run.check.outside) out.scaled_jacobians = run.check.outside->scaled_jacobians;
    write_hex_mesh(run.meshes.inside, inside, in);
    write_hex_mesh(run.meshes.outside, outside, out);
  });
  run.check.inside.scaled_jacobians = {};
  if (run.check.outside) run.check.outside->scaled_jacobians = {};
  run.peak_memory_bytes = peak_memory_bytes();
}

}  // namespace mchex
