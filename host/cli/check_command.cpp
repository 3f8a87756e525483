// mchex-gpu check: the validator (core/check/mesh_check.h) on meshes read from files, and their
// fidelity to a surface or shape when one is given. Exit 1 when the check fails.
#include <cstdio>
#include <optional>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/base/error.h"
#include "core/io/mesh_io.h"
#include "core/pipeline/report.h"
#include "core/pipeline/solid.h"
#include "host/cli/commands.h"
#include "host/cli/summary.h"

namespace mchex::cli {

CheckOutcome check_meshes(const HexMesh& inside, const HexMesh* outside, const CheckCommand& o, bool quiet) {
  if (!o.input.empty() && !o.shape.empty()) throw InputError("give either --input or --shape, not both");
  StageClock clock(true);
  CheckOutcome r;
  r.check = check_mesh(inside, outside, nullptr);
  r.json = {{"mesh", o.mesh}, {"check", to_json(r.check)}};
  if (outside) r.json["outside"] = o.outside;
  if (!o.input.empty() || !o.shape.empty()) {
    SolidSource source;
    source.path = o.input;
    source.shape = o.shape;
    const Solid solid(source, clock, quiet, o.solid);
    // The lattice spans both meshes and the solid.
    Box box;
    for (const Vec3& p : inside.points) box.extend(p);
    if (outside)
      for (const Vec3& p : outside->points) box.extend(p);
    box.extend(solid.sdf().bounds().lo);
    box.extend(solid.sdf().bounds().hi);
    r.fidelity = solid.fidelity(inside, box, o.lattice);
    r.json["input"] = input_json(solid.facts());
    r.json["fidelity"] = fidelity_json(*r.fidelity);
  }
  return r;
}

int run_check(const CheckCommand& o, bool quiet) {
  if (!o.input.empty() && !o.shape.empty()) throw InputError("give either --input or --shape, not both");
  const HexMesh inside = read_hex_mesh(o.mesh);
  std::optional<HexMesh> outside;
  if (!o.outside.empty()) outside = read_hex_mesh(o.outside);
  const CheckOutcome outcome = check_meshes(inside, outside ? &*outside : nullptr, o, quiet || o.json);
  const MeshCheck& check = outcome.check;
  const std::optional<Fidelity>& fid = outcome.fidelity;
  const nlohmann::json& j = outcome.json;
  if (o.json) {
    fmt::print("{}\n", j.dump(2));
  } else if (!quiet) {
    fmt::print("mchex-gpu check: {}{}\n", o.mesh, outside ? " + " + o.outside : "");
    fmt::print("{}", summary(check, /*detailed=*/true));
    if (fid) fmt::print("{}", fidelity_line(*fid));
  }
  if (!check.ok) {
    std::fprintf(stderr, "mchex-gpu: %s: check failed: %s\n", o.mesh.c_str(), first_error(check).c_str());
    return 1;
  }
  return 0;
}

}  // namespace mchex::cli
