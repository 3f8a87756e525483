#include "core/pipeline/solid.h"

#include <cstdio>
#include <string>

#include "core/base/error.h"
#include "core/grid/grid.h"
#include "core/io/surface_io.h"
#include "core/sdf/shapes.h"

namespace mchex {

Solid::Solid(const SolidSource& source, StageClock& clock, bool quiet, const SolidOptions& options) {
  if (int(!source.path.empty()) + int(source.surface != nullptr) + int(!source.shape.empty()) > 1)
    throw InputError("give either a surface or a shape, not both");
  if (source.path.empty() && !source.surface) {
    facts_.name = source.shape.empty() ? kDefaultShape : source.shape;
    facts_.analytic = true;
    sdf_ = std::make_unique<ShapeSdf>(parse_shape(facts_.name));
    return;
  }
  facts_.sign = options.sign;
  if (source.surface) {
    facts_.name = source.surface_name;
    surface_ = options.repair ? &read_.emplace(*source.surface) : source.surface;
  } else {
    facts_.name = source.path;
    surface_ = &read_.emplace(clock.run("read", [&] { return read_surface(source.path, &facts_.welded); }));
  }
  if (options.repair) {
    facts_.repair = clock.run("repair", [&] { return repair_orientation(*read_); });
    if (read_->triangles.empty())
      throw InputError(facts_.name + ": no face is left after repair (" +
                       std::to_string(facts_.repair->degenerate_faces_removed) + " degenerate, " +
                       std::to_string(facts_.repair->duplicate_faces_removed) +
                       " duplicate or cancelled by an opposite copy); --no-repair meshes it as given");
  }
  facts_.surface = validate_surface(*surface_);
  const SurfaceReport& r = facts_.surface;
  // After repair every closed shell faces the right way; what no repair can fix is a surface
  // that does not enclose anything by itself.
  if (!quiet && !(r.closed && r.consistently_oriented))
    std::fprintf(stderr,
                 "mchex-gpu: warning: %s is not a closed, consistently oriented surface%s (%zu boundary, %zu "
                 "non-manifold, %zu inconsistent edges); inside is %s\n",
                 facts_.name.c_str(), options.repair ? " after repair" : "", r.boundary_edges, r.nonmanifold_edges,
                 r.inconsistent_edges,
                 options.sign == SignRule::kWindingNumber ? "where its winding number exceeds 1/2"
                                                          : "the side of the nearest triangle");
  sdf_ = clock.run("bvh", [&] { return std::make_unique<SurfaceSdf>(*surface_, options.sign); });
}

const WindingNumber* Solid::winding() const {
  return surface_ ? static_cast<const SurfaceSdf&>(*sdf_).winding() : nullptr;
}

SdfSource Solid::sdf_source() const {
  SdfSource s;
  s.reference = sdf_.get();
  if (surface_) s.surface = surface_;
  else s.shape = static_cast<const ShapeSdf&>(*sdf_).kind();
  return s;
}

Fidelity Solid::fidelity(const HexMesh& inside, const Box& box, std::size_t lattice, double far_tolerance) const {
  const FidelityReference* ref = fidelity_reference_ ? &*fidelity_reference_ : nullptr;
  if (!ref || ref->lattice != lattice || ref->lattice_box.lo != box.lo || ref->lattice_box.hi != box.hi) {
    const double spacing = box.diagonal() / 400;
    std::vector<Vec3> samples = surface_ ? sample_surface(*surface_, spacing)
                                         : sample_surface(*sdf_, padded_cube(sdf_->bounds(), 0.05), spacing);
    const bool bounds_sign = !surface_ || (facts_.surface.closed && facts_.surface.consistently_oriented);
    ref =
        &fidelity_reference_.emplace(fidelity_reference(*sdf_, std::move(samples), box, lattice, spacing, bounds_sign));
  }
  SurfaceDistance distance;
  if (surface_)
    distance = [&sdf = static_cast<const SurfaceSdf&>(*sdf_)](std::span<const Vec3> p, std::span<double> d) {
      sdf.distance(p, d);
    };
  return measure_fidelity(inside, *sdf_, *ref, distance, far_tolerance);
}

}  // namespace mchex
