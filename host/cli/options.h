// The options of `mchex-gpu mesh` and `check`, defined once for both front ends that parse them: the command
// line (host/cli/main.cpp) and the Python module (host/python/mchex_module.cpp, which turns
// mchex.mesh's and mchex.check's keyword arguments into the same option words). So both accept the same values,
// apply the same defaults and reject a bad value with the same one-line message.
#pragma once

#include <map>
#include <string>

#include <CLI/CLI.hpp>

#include "core/sdf/sdf.h"
#include "host/cli/commands.h"

namespace mchex::cli {

// The sign rules a surface's inside is decided by (mesh, check and optimize --sign).
const std::map<std::string, SignRule>& sign_rules();
inline constexpr const char* kSignHelp =
    "inside of a surface: winding (the generalized winding number exceeds 1/2; right on open, folded, "
    "inconsistently oriented and self-intersecting input) or pseudonormal (the nearest triangle's side; "
    "exact only for closed, consistently oriented surfaces)";

// Gmsh's own command line writes binary files with -bin ("when possible"); so here.
inline constexpr const char* kBinaryHelp =
    "write .msh as Gmsh 4.1 binary, as gmsh -bin does (.vtu, .meshb and .exo are always binary, .mesh and .inp "
    "always ascii)";

// The mesh options on `app` (the mesh subcommand, or an App of its own), bound to `command`.
// Neither copied nor moved: the options write into this object.
class MeshCli {
 public:
  explicit MeshCli(CLI::App& app);
  MeshCli(const MeshCli&) = delete;
  MeshCli& operator=(const MeshCli&) = delete;

  // After a successful parse: the defaults that depend on which options were given (the fitted
  // grid when no grid was asked for, fidelity unless --no-fidelity, --optimize's eps).
  void finish();

  MeshCommand command;

 private:
  CLI::Option *eps_ = nullptr, *depth_ = nullptr, *threshold_ = nullptr, *hausdorff_ = nullptr, *repel_ = nullptr;
  std::string repel_text_;
  bool no_fidelity_ = false;
};

// The check options on `app`, bound to `command`, which must outlive the App.
void add_check_options(CLI::App& app, CheckCommand& command);

}  // namespace mchex::cli
