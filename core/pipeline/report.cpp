#include "core/pipeline/report.h"

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "core/grid/cell_types.h"
#include "core/grid/templates.h"

namespace mchex {
namespace {

using nlohmann::json;

json box_json(const Box& b) { return {{"lo", {b.lo.x, b.lo.y, b.lo.z}}, {"hi", {b.hi.x, b.hi.y, b.hi.z}}}; }

json uniform_grid_json(const UniformGrid& grid) {
  return {{"kind", "uniform"},
          {"levels", grid.depth()},
          {"cells_per_axis", grid.cells_per_axis()},
          {"cells", grid.cell_count()},
          {"cells_per_type", {{"cube", grid.cell_count()}}},
          {"box", box_json(grid.box())},
          {"cell_size", grid.cell_size()}};
}

// The adaptive complex: levels, cells per cell type and per template.
json adaptive_grid_json(const AdaptiveGrid& g, std::size_t unsampled, const OctreeStats& stats, const MeshOptions& o) {
  json per_type = json::object(), per_level = json::array(), per_template = json::object();
  const auto types = cell_types();
  std::vector<std::size_t> count(types.size());
  for (std::uint8_t t : g.cell_type) ++count[t];
  for (std::size_t t = 0; t < types.size(); ++t) per_type[types[t].name] = count[t];
  for (int k = 0; k < kNumTemplates; ++k) per_template[std::string(template_name(k))] = g.leaves_per_template[k];
  for (const OctreeLevelStats& l : stats.levels)
    per_level.push_back({{"candidates", l.candidates},
                         {"sampled", l.sampled},
                         {"sdf_points", l.sdf_points},
                         {"refined_by_error", l.refined_by_error},
                         {"refined_by_balance", l.refined_by_balance},
                         {"leaves", l.leaves}});
  const Box& cube = g.complex.box;
  return {{"kind", "adaptive"},
          {"threshold", o.threshold},
          {"threshold_relative_to", "finest cell size"},
          {"volume_threshold", o.volume_threshold},
          {"tolerance", adaptive_tolerance(cube, {o.threshold, o.max_depth, o.error_depth})},
          {"error_depth", o.error_depth >= 0 ? o.error_depth : o.max_depth},
          {"points_sampled_in_refinement", g.complex.points.size() - unsampled},
          {"max_depth", o.max_depth},
          {"levels", g.levels},
          {"cells", g.complex.cells.size()},
          {"points", g.complex.points.size()},
          {"cells_per_type", per_type},
          {"leaves_per_template", per_template},
          {"per_level", per_level},
          {"balance_rounds", stats.balance_rounds},
          {"box", box_json(cube)},
          {"finest_cell_size", (cube.hi.x - cube.lo.x) / std::pow(3.0, g.levels - 1)}};
}

json mchex_json(const MchexStats& s, double eps, const std::string& crossings) {
  return {
      {"eps", eps},
      {"crossings",
       {{"rule", crossings},
        {"searched_edges", s.exact_crossings},
        {"batches", s.crossing_batches},
        {"max_residual", s.crossing_residual},
        {"seconds", s.seconds_crossings}}},
      {"refined_cells", s.refined_cells},
      {"refined_cells_two_levels", s.refined_cells_two_levels},
      {"moved_volume_centres", s.moved_centres},
      {"uncertified_polyhedra", s.uncertified_polyhedra},
      {"perturbed_zero_values", s.perturbed_values},
      {"points", s.points},
      {"seconds", {{"topology", s.seconds_topology}, {"cells", s.seconds_cells}, {"assembly", s.seconds_assembly}}}};
}

// What repair_orientation found and did (core/mesh/orientation.h); "self_intersecting_pairs" is
// null when the test was past its bounds.
json repair_json(const OrientationReport& r) {
  return {{"components", r.components},
          {"closed_components", r.closed_components},
          {"nonorientable_components", r.nonorientable_components},
          {"cavities", r.cavities},
          {"nesting_checked", r.nesting_checked},
          {"flipped_triangles", r.flipped_triangles},
          {"reversed_components", r.reversed_components},
          {"reversed_triangles", r.reversed_triangles},
          {"duplicate_faces_removed", r.duplicate_faces_removed},
          {"cancelled_pairs", r.cancelled_pairs},
          {"degenerate_faces_removed", r.degenerate_faces_removed},
          {"zero_area_faces", r.zero_area_faces},
          {"orphaned_vertices_removed", r.orphaned_vertices_removed},
          {"boundary_edges", r.boundary_edges},
          {"boundary_loops", r.boundary_loops},
          {"nonmanifold_edges", r.nonmanifold_edges},
          {"self_intersection_checked", r.self_intersection_checked},
          {"self_intersecting_pairs", r.self_intersection_checked ? json(r.self_intersecting_pairs) : json(nullptr)},
          {"changed", r.changed()},
          {"summary", describe(r)}};
}

}  // namespace

json input_json(const SolidFacts& in) {
  if (in.analytic) return {{"shape", in.name}, {"analytic", true}};
  const SurfaceReport& r = in.surface;
  return {{"file", in.name},
          {"sign", sign_rule_name(in.sign)},
          {"repair", in.repair ? repair_json(*in.repair) : json(nullptr)},
          {"triangles", r.triangles},
          {"vertices", r.vertices},
          {"welded_vertices", in.welded},
          {"closed", r.closed},
          {"consistently_oriented", r.consistently_oriented},
          {"boundary_edges", r.boundary_edges},
          {"nonmanifold_edges", r.nonmanifold_edges},
          {"degenerate_faces", r.degenerate_faces},
          {"inconsistent_edges", r.inconsistent_edges},
          {"components", r.components},
          {"volume", r.volume}};
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

json optimize_json(const OptimizeStats& s) {
  const WorstHex& w = s.worst;
  return {{"sweeps", s.sweeps},
          {"hexes", s.hexes},
          {"vertices",
           {{"total", s.vertices},
            {"free", s.free_vertices},
            {"surface", s.surface_vertices},
            {"box", s.box_vertices},
            {"fixed", s.fixed_vertices},
            {"features", s.feature_vertices},
            {"on_curves", s.curve_vertices},
            {"at_corners", s.corner_vertices},
            {"snapped", s.snapped_vertices}}},
          {"input_features", {{"curves", s.feature_curves}, {"sharp_edges", s.feature_edges}}},
          {"colours", s.colours},
          {"min_scaled_jacobian", {{"before", s.min_sj_before}, {"after", s.min_sj_after}}},
          {"mean_scaled_jacobian", {{"before", s.mean_sj_before}, {"after", s.mean_sj_after}}},
          {"max_edge_ratio", {{"before", s.max_edge_ratio_before}, {"after", s.max_edge_ratio_after}}},
          {"certified", {{"before", s.certified_before}, {"after", s.certified_after}}},
          {"hexes_below_0_3", {{"before", s.below_0_3_before}, {"after", s.below_0_3_after}}},
          {"hexes_below_0_3_touching_fixed", s.below_0_3_touching_fixed},
          {"hexes_above_edge_ratio_cap",
           {{"before", s.above_edge_ratio_cap_before}, {"after", s.above_edge_ratio_cap_after}}},
          {"moves", {{"accepted", s.moves_accepted}, {"rejected", s.moves_rejected}}},
          {"min_per_sweep", s.min_per_sweep},
          {"worst",
           {{"mesh", w.region == kInside ? "inside" : "outside"},
            {"hex", w.hex},
            {"centre", {w.centre.x, w.centre.y, w.centre.z}},
            {"scaled_jacobian", w.scaled_jacobian},
            {"edge_ratio", w.edge_ratio},
            {"fixed_corners", w.fixed_corners},
            {"surface_corners", w.surface_corners},
            {"box_corners", w.box_corners}}},
          {"seconds", s.seconds},
          {"sweep_seconds", s.sweep_seconds},
          {"sweep_cpu_seconds", s.sweep_cpu_seconds},
          {"hexes_per_second_per_sweep", s.hexes_per_second()},
          {"hexes_per_cpu_second_per_sweep", s.hexes_per_cpu_second()},
          {"phases",
           {{"plain",
             {{"sweeps", s.plain_sweeps},
              {"seconds", s.plain_sweep_seconds},
              {"hexes_per_second_per_sweep", s.plain_hexes_per_second()}}},
            {"search",
             {{"sweeps", s.search_sweeps()},
              {"seconds", s.search_sweep_seconds()},
              {"hexes_per_second_per_sweep", s.search_hexes_per_second()}}},
            {"edge_ratio",
             {{"sweeps", s.ratio_sweeps},
              {"seconds", s.ratio_sweep_seconds},
              {"hexes_per_second_per_sweep", s.ratio_hexes_per_second()}}}}}};
}

// Several regions (core/pipeline/regions.h): per region its hexes and volume against the volume
// its shell encloses, the priority that decided overlaps, and what labelling had to correct.
json regions_json(const RegionStats& s) {
  json regions = json::array();
  for (std::size_t i = 0; i < s.regions.size(); ++i) {
    const RegionStats::Region& r = s.regions[i];
    regions.push_back({{"label", i + 1},
                       {"name", r.name},
                       {"hexes", r.hexes},
                       {"volume", r.volume},
                       {"enclosed_volume", r.enclosed_volume}});
  }
  return {{"regions", regions},
          {"outside_label", s.regions.size() + 1},
          {"outside_hexes", s.outside_hexes},
          {"priority", s.priority},
          {"shared_faces", s.shared_faces},
          {"junction_segments", s.junction_segments},
          {"junction_lift_radius",
           s.lift_max_radius > 0 ? json{{"min", s.lift_min_radius}, {"max", s.lift_max_radius}} : json(nullptr)},
          {"flipped_hexes", s.flipped}};
}

// How the grid's settings were chosen: a target Hausdorff ratio, a hex cap and the settings the
// cap's search built (core/pipeline/fit.h).
json fit_json(const MeshRun& run) {
  const MeshOptions& o = run.options;
  json j = {{"hausdorff_target", o.hausdorff > 0 ? json(o.hausdorff) : json(nullptr)},
            {"max_hexes", o.max_hexes > 0 ? json(o.max_hexes) : json(nullptr)}};
  if (run.fit) {
    json trials = json::array();
    for (const FitTrial& t : run.fit->trials)
      trials.push_back({{"threshold", t.options.threshold},
                        {"max_depth", t.options.max_depth},
                        {"cells", t.cells},
                        {"predicted_hexes", t.predicted_hexes}});
    j["predicted_hexes"] = run.fit->predicted_hexes;
    j["trials"] = trials;
  }
  json rounds = json::array();
  for (const FitRound& r : run.fit_rounds)
    rounds.push_back({{"hausdorff_ratio", r.hausdorff_ratio},
                      {"iou", r.iou},
                      {"far_points", r.far_points},
                      {"refined_leaves", r.refined_leaves},
                      {"hexes", r.hexes}});
  j["rounds"] = rounds;
  return j;
}

json report_json(const MeshRun& run, const MeshOutputs* outputs) {
  const DeviceInfo& d = run.device;
  json report = {
      {"input", input_json(run.input)},
      {"method", run.options.method},
      {"backend",
       {{"name", d.backend},
        {"platform", d.platform},
        {"device", d.name},
        {"precision", d.precision},
        {"kernels", d.kernels},
        {"threads", run.threads}}},
      {"grid", run.adaptive ? adaptive_grid_json(*run.adaptive, run.unsampled_points, run.octree, run.options)
                            : uniform_grid_json(*run.uniform)},
      {"elements",
       {{"inside_hexes", run.meshes.inside.hexes.size()},
        {"outside_hexes", run.meshes.outside.hexes.size()},
        {"inside_vertices", run.meshes.inside.points.size()},
        {"outside_vertices", run.meshes.outside.points.size()}}},
      {"check", to_json(run.check)},
  };
  if (run.options.hausdorff > 0 || run.fit) report["fit"] = fit_json(run);
  if (outputs) {
    report["outputs"] = {{"inside", outputs->inside}, {"outside", outputs->outside}};
    if (!outputs->regions.empty()) report["outputs"]["regions"] = outputs->regions;
  }
  if (run.options.method == "mchex") {
    // Cells per MC33 subcase (paper Section 5: 31 subcases), and the tunnel cells meshed with
    // their partner's topology instead of the paper's local refinement (a known gap).
    json cases = json::object();
    for (int i = 0; i < kMchexCaseSlots; ++i) cases[std::string(mchex_case_name(i))] = run.mchex.cases[i];
    report["cases"] = cases;
    report["mchex"] = mchex_json(run.mchex, run.options.eps, run.options.crossings);
    // The certification remedy (docs/templates.md): cut cells whose polyhedron no certificate
    // covered, and the leaves refined for them before the grid was meshed again.
    if (run.adaptive)
      report["remedy"] = {
          {"rounds", run.remedy.rounds}, {"cells", run.remedy.cells}, {"refined_leaves", run.remedy.refined_leaves}};
  }
  // Grid-point repelling (core/cutting/repel.h), of the last meshing.
  if (run.repel)
    report["repel"] = {{"delta", run.repel->delta},       {"moved", run.repel->moved},
                       {"pinned", run.repel->pinned},     {"restored", run.repel->restored},
                       {"relaxed", run.repel->relaxed},   {"rounds", run.repel->rounds},
                       {"off_line", run.repel->off_line}, {"off_line_rounds", run.repel->off_line_rounds}};
  // The boundary snapped onto the surface after the last cut (core/optimize/optimize.h).
  if (run.snap)
    report["snap"] = {{"vertices", run.snap->vertices},
                      {"moved", run.snap->moved},
                      {"partly", run.snap->partly},
                      {"stayed", run.snap->stayed},
                      {"seconds", run.snap->seconds}};
  if (run.optimize) report["optimize"] = optimize_json(*run.optimize);
  if (run.regions) report["regions"] = regions_json(*run.regions);
  if (run.fidelity) report["fidelity"] = fidelity_json(*run.fidelity);
  report["times"] = run.clock.to_json();
  report["peak_memory_bytes"] = run.peak_memory_bytes;
  // What the peak was measured under: the CLI sets glibc's heap tunables (host/cli/huge_pages.h).
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  report["heap_tunables"] = tunables ? nlohmann::json(tunables) : nlohmann::json(nullptr);
  return report;
}

}  // namespace mchex
