// The solid a run meshes or a check measures against: a triangle surface (read from a file or
// given in memory) or a built-in analytic shape (core/sdf/shapes.h), with its reference SDF
// (core/sdf/sdf.h) and the facts the report states about it.
//
// A surface is first repaired (core/mesh/orientation.h repair_orientation: duplicates and
// degenerate faces out, each component consistent, closed shells outward and cavities inward),
// then validated, and its SDF takes its sign by the chosen rule: by default the generalized
// winding number (Jacobson et al. 2013), which is right on the open, folded, inconsistently
// oriented and self-intersecting surfaces where the nearest triangle's pseudonormal makes a
// valid mesh of the wrong solid; on a clean closed surface both rules agree.
//
// Guarantee: the SDF is built once per Solid and every stage of a run (refinement, the backend's
// batch as its `reference`, fidelity) reads that one object, so a surface is read and its BVH
// built once. A Solid is neither copied nor moved: its SDF refers to the surface it holds.
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/base/geometry.h"
#include "core/base/stage_clock.h"
#include "core/check/fidelity.h"
#include "core/device/backend.h"
#include "core/mesh/hex_mesh.h"
#include "core/mesh/orientation.h"
#include "core/mesh/surface.h"
#include "core/sdf/sdf.h"
#include "core/sdf/winding_number.h"

namespace mchex {

// Where the solid comes from: a surface file, a surface in memory, or a shape. At most one of
// them; none means the default shape.
struct SolidSource {
  std::string path;                          // STL, OBJ, OFF or PLY (core/io/surface_io.h)
  const TriangleSurface* surface = nullptr;  // the caller's, alive while the Solid is ...
  std::string surface_name;                  // ... and how the report names it
  std::string shape;                         // sphere, torus, rounded-box, two-holed

  static SolidSource file(std::string path) {
    SolidSource s;
    s.path = std::move(path);
    return s;
  }
  static SolidSource in_memory(const TriangleSurface& surface, std::string name) {
    SolidSource s;
    s.surface = &surface;
    s.surface_name = std::move(name);
    return s;
  }
  static SolidSource named_shape(std::string shape) {
    SolidSource s;
    s.shape = std::move(shape);
    return s;
  }
};

inline constexpr const char* kDefaultShape = "torus";

// How a surface becomes a solid (shapes ignore both).
struct SolidOptions {
  bool repair = true;                        // repair_orientation before anything else
  SignRule sign = SignRule::kWindingNumber;  // the SDF's sign rule (core/sdf/sdf.h)
};

// What the report says about the input (core/pipeline/report.h input_json).
struct SolidFacts {
  std::string name;        // the file, the in-memory surface's name, or the shape
  bool analytic = false;   // a built-in shape
  SurfaceReport surface;   // core/mesh/surface.h validate_surface, of the surface as meshed
  std::size_t welded = 0;  // duplicate vertices the reader merged
  SignRule sign = SignRule::kWindingNumber;
  std::optional<OrientationReport> repair;  // what repair found and did, when it ran
};

class Solid {
 public:
  // Reads the surface (stage "read", InputError for an unreadable file), repairs it unless
  // options.repair is false (stage "repair"; an in-memory surface is copied first, the caller's
  // is never changed), validates what is meshed, builds its BVH (stage "bvh"); unless quiet,
  // warns on stderr when the surface is still open or non-manifold after repair, saying which
  // sign rule decides inside. InputError when more than one source is given or the shape is
  // unknown.
  Solid(const SolidSource& source, StageClock& clock, bool quiet, const SolidOptions& options = {});
  Solid(const Solid&) = delete;
  Solid& operator=(const Solid&) = delete;

  const SolidFacts& facts() const { return facts_; }
  const SignedDistance& sdf() const { return *sdf_; }
  const TriangleSurface* surface() const { return surface_; }  // null for a shape (repaired)
  // The winding number that decides inside under SignRule::kWindingNumber; null for a shape or
  // the pseudonormal rule. Grid values from any backend are re-signed with it (apply_winding_sign)
  // so that every backend gives this SDF's field.
  const WindingNumber* winding() const;
  // What a backend's SDF batch evaluates (core/device/backend.h), with this solid's SDF as the
  // cpu backend's reference.
  SdfSource sdf_source() const;

  // The paper's Section 6 measures of an inside mesh against this solid (core/check/fidelity.h):
  // reference samples at 1/400 of the box diagonal, IoU on a lattice^3 lattice over the box.
  // far_tolerance: Fidelity::far_points.
  // The input's side of the measure (its surface samples and the solid on the lattice) is made
  // at the first call for a box and lattice and kept: the fitted grid's rounds measure one mesh
  // after another against it.
  Fidelity fidelity(const HexMesh& inside, const Box& box, std::size_t lattice, double far_tolerance = 0) const;

 private:
  mutable std::optional<FidelityReference> fidelity_reference_;
  SolidFacts facts_;
  std::optional<TriangleSurface> read_;  // a surface read from its file
  const TriangleSurface* surface_ = nullptr;
  std::unique_ptr<SignedDistance> sdf_;
};

}  // namespace mchex
