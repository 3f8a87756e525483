// The report JSON of a mesh run (`mchex-gpu mesh --report`), built here and nowhere else, and its
// parts that `mchex-gpu check --json` shares (the input, the fidelity). Keys:
//   input     the solid (core/pipeline/solid.h SolidFacts): a shape, or a surface's validation
//             (after repair), its sign rule ("sign": winding | pseudonormal) and what
//             repair_orientation found and did ("repair", null under --no-repair)
//   method    "mchex" | "ro"
//   backend   where the SDF ran (core/device/backend.h DeviceInfo) and the worker threads
//   grid      uniform: levels and cells; adaptive: cells per level, type and template
//   fit       when the grid was fitted (core/pipeline/fit.h): the target Hausdorff ratio, the hex
//             cap, and the cap's search (every setting built, its cells and predicted hexes)
//   elements  hexes and vertices of both meshes
//   check     core/check/mesh_check.h to_json
//   outputs   the mesh files (when the caller names them)
//   cases, mchex   method mchex: cells per MC33 subcase (paper Section 5: 31 subcases), local
//             refinement and the mesher's own stage times
//   optimize  with --optimize (core/optimize/optimize.h): scaled Jacobian and edge ratio before
//             and after, sweeps, moves, the vertices' constraints, the worst hex left
//   fidelity  when measured: IoU and Hausdorff distance (the paper's Section 6)
//   times     the stages' wall seconds (core/base/stage_clock.h) and their total
//   peak_memory_bytes
//   heap_tunables  GLIBC_TUNABLES as the run saw it (the CLI sets glibc's heap up for huge pages,
//             host/cli/huge_pages.h), or null
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/check/fidelity.h"
#include "core/pipeline/pipeline.h"
#include "core/pipeline/solid.h"

namespace mchex {

// The files a run's meshes went to (or would have, had they passed their check).
struct MeshOutputs {
  std::string inside, outside;
  std::vector<std::string> regions;  // --region-files: region i's own mesh, in label order
};

nlohmann::json report_json(const MeshRun& run, const MeshOutputs* outputs = nullptr);

nlohmann::json input_json(const SolidFacts& input);
nlohmann::json fidelity_json(const Fidelity& f);
nlohmann::json optimize_json(const OptimizeStats& s);

}  // namespace mchex
