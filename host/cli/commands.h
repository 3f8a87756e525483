// The subcommands of mchex-gpu (host/cli/main.cpp parses the command line into these and maps
// the exceptions they throw to exit codes: InputError 1, ResourceError 2, any other 3).
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/check/mesh_check.h"
#include "core/mesh/hex_mesh.h"
#include "core/pipeline/pipeline.h"

namespace mchex::cli {

// mesh: a surface or shape -> inside and outside all-hex meshes (+ JSON report), through
// core/pipeline/pipeline.h run_pipeline.
struct MeshCommand {
  // One surface, or several: the regions of one region-labelled mesh (core/pipeline/regions.h).
  std::vector<std::string> inputs;
  std::vector<int> region_order;   // --region-order: 1-based input positions, highest priority first
  bool region_files = false;       // --region-files: each region's own mesh beside the inside one
  bool shells_as_regions = false;  // --shells-as-regions: one input's shells are the regions
  std::string shape, inside = "inside.mesh", outside, report, backend = "auto";
  std::string trace;  // --trace: the Chrome trace-event timeline (core/base/trace.h)
  MeshOptions options;
  MeshWriteOptions write;  // --binary
};
int run_mesh(const MeshCommand& command, bool quiet);
// The pipeline's request for a mesh command (its input or shape, options and backend); the command
// must outlive the request, whose backend it makes. InputError when both input and shape are given.
MeshRequest mesh_request(const MeshCommand& command, bool quiet);

// check: validate hex meshes (structure, quality, conformity), and their fidelity to a solid.
struct CheckCommand {
  std::string mesh, outside, input, shape;
  bool json = false;
  std::size_t lattice = 128;
  SolidOptions solid;  // how --input becomes a solid, as the mesh run's
};
int run_check(const CheckCommand& command, bool quiet);
// The check of meshes already read (`command.mesh` and `.outside` name them in the JSON), with
// their fidelity to `command`'s input or shape when it names one: what `check --json` prints.
struct CheckOutcome {
  MeshCheck check;
  std::optional<Fidelity> fidelity;
  nlohmann::json json;
};
CheckOutcome check_meshes(const HexMesh& inside, const HexMesh* outside, const CheckCommand& command, bool quiet);

// optimize: move the vertices of a hex mesh (and its outside mesh) to raise the scaled Jacobian,
// boundary vertices on the input surface, every hex still certified (core/optimize/optimize.h).
struct OptimizeCommand {
  std::string mesh, outside, input, shape, output, outside_output, report;
  OptimizeOptions options;
  SolidOptions solid;
};
int run_optimize(const OptimizeCommand& command, bool quiet);

// devices: the compute backends and devices found (host/backends/registry.h list_devices).
int run_devices(bool as_json);
// `devices --auto-choice` (hidden): prints what --backend auto stands for here (cpu, opencl or
// vulkan), for run_mesh's probe in a child process.
int run_auto_choice();
// The list as `devices --json` prints it: one object per device.
nlohmann::json devices_json(const std::vector<DeviceInfo>& list);

}  // namespace mchex::cli
