// mchex-gpu mesh: checks the output names, runs the pipeline (core/pipeline/pipeline.h), writes
// the meshes (only ones that pass their check) and the report, prints the summary.
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <stdexcept>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/base/error.h"
#include "core/base/trace.h"
#include "core/io/atomic_file.h"
#include "core/io/mesh_io.h"
#include "core/pipeline/report.h"
#include "host/backends/registry.h"
#include "host/cli/commands.h"
#include "host/cli/summary.h"

namespace fs = std::filesystem;

namespace mchex::cli {
namespace {

fs::path default_outside(const fs::path& inside) {
  return inside.parent_path() / ("outside" + inside.extension().string());
}

void write_json(const fs::path& path, const nlohmann::json& j) {
  AtomicFile out(path);
  out.write(j.dump(2) + "\n");
  out.commit();
}

void print_summary(const MeshRun& run, const MeshOutputs& outputs) {
  const MeshOptions& o = run.options;
  if (run.adaptive && o.error_depth >= 0 && o.error_depth < o.max_depth)
    fmt::print("mchex-gpu: {} -> adaptive grid of {} cells, {} levels (threshold {} to depth {}, max depth {}), method "
               "{}\n",
               run.input.name, run.adaptive->complex.cells.size(), run.adaptive->levels, o.threshold, o.error_depth,
               o.max_depth, o.method);
  else if (run.adaptive)
    fmt::print("mchex-gpu: {} -> adaptive grid of {} cells, {} levels (threshold {}, max depth {}), method {}\n",
               run.input.name, run.adaptive->complex.cells.size(), run.adaptive->levels, o.threshold, o.max_depth,
               o.method);
  else
    fmt::print("mchex-gpu: {} -> {} grid of {}^3 cells (depth {}), method {}\n", run.input.name, "uniform",
               run.uniform->cells_per_axis(), run.uniform->depth(), o.method);
  if (o.hausdorff > 0 || run.fit)
    fmt::print("  fitted: {}{}{}\n",
               o.hausdorff > 0 ? fmt::format("target Hausdorff ratio {} (--hausdorff)", o.hausdorff) : "",
               o.hausdorff > 0 && run.fit ? ", " : "",
               run.fit ? fmt::format("at most {} hexes (--max-hexes; predicted {}, {} settings tried)", o.max_hexes,
                                     run.fit->predicted_hexes, run.fit->trials.size())
                       : "");
  if (!run.fit_rounds.empty())
    fmt::print("  fit rounds: {} (Hausdorff ratio {:.4f} -> {:.4f}, {} leaves refined where it was over)\n",
               run.fit_rounds.size(), run.fit_rounds.front().hausdorff_ratio,
               run.fidelity ? run.fidelity->hausdorff_ratio : 0.0, [&] {
                 std::size_t n = 0;
                 for (const FitRound& r : run.fit_rounds) n += r.refined_leaves;
                 return n;
               }());
  fmt::print("  inside : {:>10} hexes {:>10} vertices -> {}\n", run.meshes.inside.hexes.size(),
             run.meshes.inside.points.size(), outputs.inside);
  fmt::print("  outside: {:>10} hexes {:>10} vertices -> {}\n", run.meshes.outside.hexes.size(),
             run.meshes.outside.points.size(), outputs.outside);
  if (run.regions) {
    fmt::print("  input: {} regions, cut along every shell by the winding number's parity ({} faces shared), "
               "overlaps to regions {}\n",
               run.regions->regions.size(), run.regions->shared_faces, fmt::join(run.regions->priority, " > "));
    const RegionStats& r = *run.regions;
    if (r.junction_segments > 0 && r.lift_max_radius > 0)
      fmt::print("  junctions: shells cross along {} segments; field lifted within {} of them\n", r.junction_segments,
                 r.lift_min_radius == r.lift_max_radius
                     ? fmt::format("{:.4g}", r.lift_max_radius)
                     : fmt::format("{:.4g} to {:.4g}", r.lift_min_radius, r.lift_max_radius));
    else if (r.junction_segments > 0) fmt::print("  junctions: shells cross along {} segments\n", r.junction_segments);
  } else if (!run.input.analytic)
    fmt::print("  input: inside by {}; repair: {}\n",
               run.input.sign == SignRule::kWindingNumber ? "winding number" : "pseudonormal",
               run.input.repair ? describe(*run.input.repair) : "skipped (--no-repair)");
  if (run.regions)
    for (std::size_t i = 0; i < run.regions->regions.size(); ++i) {
      const RegionStats::Region& r = run.regions->regions[i];
      fmt::print("  region {}: {:>10} hexes, volume {:.6g} (its shell encloses {:.6g}) <- {}\n", i + 1, r.hexes,
                 r.volume, r.enclosed_volume, r.name);
      if (i < outputs.regions.size()) fmt::print("  region {} mesh -> {}\n", i + 1, outputs.regions[i]);
      // Awad et al.'s per-region measures (their Table 1), from check.
      for (const RegionQuality& q : run.check.inside.regions)
        if (q.region == int32_t(i + 1) && q.quality.count > 0)
          fmt::print("  region {} quality: min scaled Jacobian {:.3g}, dihedral angles {:.4g} to {:.4g} degrees, "
                     "edge ratio up to {:.3g}\n",
                     i + 1, q.quality.min_scaled_jacobian, q.quality.min_dihedral_angle, q.quality.max_dihedral_angle,
                     q.quality.max_edge_ratio);
    }
  if (run.repel)
    fmt::print("  repel: delta {}, {} points moved ({} off their grid line), {} pinned, {} moves halved, {} restored, "
               "{} + {} rounds\n",
               run.repel->delta, run.repel->moved, run.repel->off_line, run.repel->pinned, run.repel->relaxed,
               run.repel->restored, run.repel->rounds, run.repel->off_line_rounds);
  if (run.snap)
    fmt::print("  snap: {} of {} boundary vertices on the surface, {} part of the way (hexes kept certified)\n",
               run.snap->moved, run.snap->vertices, run.snap->partly);
  if (run.optimize) fmt::print("{}", optimize_line(*run.optimize));
  fmt::print("{}", summary(run.check));
  if (run.fidelity) fmt::print("{}", fidelity_line(*run.fidelity));
  fmt::print("  time: {:.2f} s, peak memory {:.0f} MiB\n", run.clock.total(), run.peak_memory_bytes / 1048576.0);
}

}  // namespace

namespace {

// --backend auto, decided in a child process (`mchex-gpu devices --auto-choice`) started when the
// command starts and read when the pipeline opens its backend, so that probing for a GPU runs
// beside the reading and the octree and its drivers never load into this process unless they are
// chosen. Probed here, PoCL's and lavapipe's drivers (LLVM with them) stayed for the whole run:
// 58 MiB more peak memory on the npm bunny's default run (366 against 308 MiB) and about 0.2 s.
// The child runs the same auto_backend_choice() with the same environment, so the choice is the
// one an in-process probe would make; if it gives no answer, the probe runs here as before.
class AutoChoice {
 public:
  AutoChoice() {
    int fds[2];
    if (pipe2(fds, O_CLOEXEC) != 0) return;
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);  // the child's copy is not close-on-exec
    // Whatever the drivers say while probing stays out of this run's stderr, where a bad input's
    // one line must be the only one; a chosen backend's driver speaks again when it is opened here.
    posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
    char exe[] = "/proc/self/exe", command[] = "devices", flag[] = "--auto-choice";
    char* argv[] = {exe, command, flag, nullptr};
    pid_t pid = -1;
    const bool spawned = posix_spawn(&pid, exe, &actions, nullptr, argv, environ) == 0;
    posix_spawn_file_actions_destroy(&actions);
    close(fds[1]);
    if (!spawned) {
      close(fds[0]);
      return;
    }
    pid_ = pid;
    fd_ = fds[0];
  }
  AutoChoice(const AutoChoice&) = delete;
  AutoChoice& operator=(const AutoChoice&) = delete;
  ~AutoChoice() {
    // A run that ends before it opens a backend (bad input) does not wait for the probe.
    if (pid_ > 0) kill(pid_, SIGKILL);
    finish();
  }

  // "cpu", "opencl" or "vulkan"; "auto" (probe in this process) when the child gave no answer.
  std::string backend() {
    if (!choice_.empty()) return choice_;
    std::string out;
    char buf[64];
    for (;;) {
      const ssize_t n = fd_ >= 0 ? read(fd_, buf, sizeof buf) : 0;
      if (n > 0) {
        out.append(buf, static_cast<std::size_t>(n));
      } else if (n == 0 || errno != EINTR) {
        break;
      }
    }
    const int status = finish();
    while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
    const bool answered = WIFEXITED(status) && WEXITSTATUS(status) == 0;
    choice_ = answered && (out == "cpu" || out == "opencl" || out == "vulkan") ? out : "auto";
    return choice_;
  }

 private:
  // Closes the pipe and reaps the child; its wait status (-1 when there was none).
  int finish() {
    if (fd_ >= 0) close(fd_);
    fd_ = -1;
    int status = -1;
    if (pid_ > 0)
      while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
      }
    pid_ = -1;
    return status;
  }

  pid_t pid_ = -1;
  int fd_ = -1;
  std::string choice_;
};

}  // namespace

MeshRequest mesh_request(const MeshCommand& o, bool quiet) {
  if (!o.inputs.empty() && !o.shape.empty()) throw InputError("give either INPUT or --shape, not both");
  const bool regions = o.inputs.size() > 1 || o.shells_as_regions;
  if (o.shells_as_regions && o.inputs.size() != 1)
    throw InputError("--shells-as-regions splits one INPUT file into its shells");
  if (!o.region_order.empty() && !regions)
    throw InputError("--region-order orders the regions of several INPUT surfaces (or --shells-as-regions)");
  if (o.region_files && !regions)
    throw InputError("--region-files writes the regions of several INPUT surfaces (or --shells-as-regions)");
  MeshRequest request;
  if (o.inputs.size() == 1) request.solid.path = o.inputs[0];
  request.solid.shape = o.shape;
  if (o.inputs.size() > 1)
    for (const std::string& path : o.inputs) request.regions.push_back(SolidSource::file(path));
  request.region_order = o.region_order;
  request.shells_as_regions = o.shells_as_regions;
  request.options = o.options;
  request.options.quiet = quiet;
  request.open_backend = [&o] { return make_backend(o.backend); };
  return request;
}

int run_mesh(const MeshCommand& o, bool quiet) {
  const fs::path inside_path = o.inside;
  const fs::path outside_path = o.outside.empty() ? default_outside(inside_path) : fs::path(o.outside);
  // Reject bad output names before any work.
  auto check_folder = [](const fs::path& out) {
    if (!out.parent_path().empty() && !fs::is_directory(out.parent_path()))
      throw InputError(out.string() + ": the folder " + out.parent_path().string() + " does not exist");
  };
  for (const fs::path& out : {inside_path, outside_path}) {
    mesh_format(out);
    check_folder(out);
  }
  if (!o.trace.empty()) {
    check_folder(o.trace);
    if (fs::is_directory(o.trace)) throw InputError(o.trace + ": is a folder, not a file name (--trace)");
    trace::start();
  }
  if (fs::weakly_canonical(inside_path) == fs::weakly_canonical(outside_path))
    throw InputError("the inside and outside meshes need different file names");
  MeshRequest request = mesh_request(o, quiet);
  std::optional<AutoChoice> auto_choice;
  if (o.backend == "auto") {
    auto_choice.emplace();
    request.open_backend = [&auto_choice] { return make_backend(auto_choice->backend()); };
  }
  request.options.keep_scaled_jacobians =
      mesh_format(inside_path) == MeshFormat::kVtu || mesh_format(outside_path) == MeshFormat::kVtu;
  // The span every other event of the trace lies in: the run and the meshes' writing.
  std::optional<trace::Span> whole;
  if (!o.trace.empty()) whole.emplace("mesh", "run");
  MeshRun run = run_pipeline(request);
  // A mesh that fails its own check is never written: the report (if asked for) says why.
  MeshOutputs outputs{inside_path.string(), outside_path.string(), {}};
  if (run.check.ok) {
    // --region-files: STEM.regionI.EXT beside the inside mesh (the count is known once the
    // shells are read).
    std::vector<fs::path> region_paths;
    if (o.region_files)
      for (std::size_t i = 1; i <= run.regions->regions.size(); ++i) {
        fs::path p = inside_path;
        p.replace_filename(
            fmt::format("{}.region{}{}", inside_path.stem().string(), i, inside_path.extension().string()));
        if (fs::weakly_canonical(p) == fs::weakly_canonical(outside_path))
          throw InputError(p.string() + ": a region's file would overwrite the outside mesh");
        region_paths.push_back(p);
      }
    write_meshes(run, inside_path, outside_path, o.write);
    // Each region's hexes as a mesh of their own (points renumbered), written within the same
    // all-or-nothing group as the two meshes.
    run.clock.run("write", [&] {
      for (std::size_t i = 0; i < region_paths.size(); ++i) {
        const HexMesh& in = run.meshes.inside;
        std::vector<Hex> hexes;
        for (std::size_t h = 0; h < in.hexes.size(); ++h)
          if (in.region[h] == int32_t(i + 1)) hexes.push_back(in.hexes[h]);
        write_hex_mesh(compact_mesh(in.points, hexes, int32_t(i + 1)), region_paths[i], o.write);
        outputs.regions.push_back(region_paths[i].string());
      }
    });
  }
  whole.reset();
  const nlohmann::json report = report_json(run, &outputs);
  if (!o.trace.empty()) {
    trace::stop();
    write_json(o.trace, trace::to_json({{"backend", report["backend"]}, {"times", report["times"]}}));
  }
  if (!o.report.empty()) write_json(o.report, report);
  if (!quiet) print_summary(run, outputs);
  // A valid mesh of nothing is easy to miss in a summary: the solid had no grid point inside it.
  if (!quiet && run.meshes.inside.hexes.empty()) {
    const double cell = run.uniform ? run.uniform->cell_size()
                                    : (run.cube.hi.x - run.cube.lo.x) / std::pow(3.0, run.adaptive->levels - 1);
    fmt::print(stderr,
               "mchex-gpu: warning: the inside mesh is empty: the solid is thinner than the grid's cells (cell size "
               "{:.3g}) everywhere; a finer {} keeps it\n",
               cell,
               run.uniform                 ? "--depth"
               : run.options.hausdorff > 0 ? "grid (a smaller --hausdorff)"
                                           : "--max-depth");
  }
  if (!run.check.ok)
    throw std::runtime_error("the mesh fails its own check, so nothing was written: " + first_error(run.check));
  return 0;
}

}  // namespace mchex::cli
