// mchex-gpu optimize: reads a hex mesh (and its outside mesh), moves its vertices with the certified
// optimiser (core/optimize/optimize.h) against the input surface or shape, checks the result and
// writes it (both meshes or none). Bad input: one line, exit 1, no file.
#include <filesystem>
#include <optional>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/base/error.h"
#include "core/io/atomic_file.h"
#include "core/io/mesh_io.h"
#include "core/pipeline/report.h"
#include "core/pipeline/solid.h"
#include "host/cli/commands.h"
#include "host/cli/summary.h"

namespace fs = std::filesystem;

namespace mchex::cli {

int run_optimize(const OptimizeCommand& o, bool quiet) {
  if (o.input.empty() == o.shape.empty()) throw InputError("optimize needs the surface: give --input or --shape");
  const fs::path inside_path = o.output;
  std::optional<fs::path> outside_path;
  if (!o.outside.empty())
    outside_path = o.outside_output.empty() ? inside_path.parent_path() / ("outside" + inside_path.extension().string())
                                            : fs::path(o.outside_output);
  else if (!o.outside_output.empty())
    throw InputError("--outside-output needs --outside (the outside mesh to optimise)");
  // Bad output names fail before any work.
  for (const auto& out : {std::optional<fs::path>(inside_path), outside_path}) {
    if (!out) continue;
    mesh_format(*out);
    if (!out->parent_path().empty() && !fs::is_directory(out->parent_path()))
      throw InputError(out->string() + ": the folder " + out->parent_path().string() + " does not exist");
  }
  if (outside_path && fs::weakly_canonical(inside_path) == fs::weakly_canonical(*outside_path))
    throw InputError("the inside and outside meshes need different file names");

  MeshPair meshes;
  meshes.inside = read_hex_mesh(o.mesh);
  if (!o.outside.empty()) meshes.outside = read_hex_mesh(o.outside);
  if (meshes.inside.hexes.empty()) throw InputError(o.mesh + ": the mesh has no hexes");
  // The optimiser needs a valid mesh to start from: the same structural check as `check`.
  CheckOptions check_options;
  check_options.require_regions = false;
  const MeshCheck before = check_mesh(meshes.inside, outside_path ? &meshes.outside : nullptr, nullptr, check_options);
  if (!before.ok) throw InputError(o.mesh + ": not a valid hex mesh (pair): " + first_error(before));

  StageClock clock(true);
  SolidSource source;
  source.path = o.input;
  source.shape = o.shape;
  const Solid solid(source, clock, quiet, o.solid);
  const OptimizeStats stats = optimize(meshes, &solid.sdf(), o.options, solid.surface());
  const MeshCheck after = check_mesh(meshes.inside, outside_path ? &meshes.outside : nullptr, nullptr, check_options);
  if (!after.ok)
    throw std::runtime_error("the optimised mesh fails its check, so nothing was written: " + first_error(after));
  write_hex_mesh(meshes.inside, inside_path);
  if (outside_path) write_hex_mesh(meshes.outside, *outside_path);
  if (!o.report.empty()) {
    AtomicFile out(o.report);
    out.write(nlohmann::json{{"optimize", optimize_json(stats)}, {"check", to_json(after)}}.dump(2) + "\n");
    out.commit();
  }
  if (!quiet) {
    fmt::print("mchex-gpu optimize: {}{} -> {}{}\n", o.mesh, outside_path ? " + " + o.outside : "",
               inside_path.string(), outside_path ? " + " + outside_path->string() : "");
    fmt::print("{}", optimize_line(stats));
    fmt::print("{}", summary(after));
  }
  return 0;
}

}  // namespace mchex::cli
