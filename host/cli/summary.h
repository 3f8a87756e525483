// The human-readable lines of a mesh check (core/check/mesh_check.h), which `mesh` and `check`
// print alike.
#pragma once

#include <string>

#include "core/check/fidelity.h"
#include "core/check/mesh_check.h"
#include "core/optimize/optimize.h"

namespace mchex::cli {

// The check's first error message ("unknown error" when it kept none).
std::string first_error(const MeshCheck& check);
// Quality and boundary of each mesh, conformity of the pair, structure: a line or two each.
// `detailed` (what `check` prints) adds the histograms and the quality per region.
std::string summary(const MeshCheck& check, bool detailed = false);
// IoU and Hausdorff distance, one line.
std::string fidelity_line(const Fidelity& f);
// The optimiser's effect (core/optimize/optimize.h): scaled Jacobian before -> after, one line.
std::string optimize_line(const OptimizeStats& s);

}  // namespace mchex::cli
