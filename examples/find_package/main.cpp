// mesh_shape SHAPE DEPTH OUT: meshes a built-in analytic solid through the installed mchex
// package's public API (core/pipeline/pipeline.h on the cpu backend), checks the result and
// writes the inside mesh to OUT (the format follows its extension), then reads it back.
// Prints "hexes INSIDE OUTSIDE" and exits 0 only if both meshes pass the validator, every hex is
// Bernstein-certified, the inside mesh is non-empty, its boundary is a closed manifold with the
// shape's Euler characteristic and the file holds what was meshed; otherwise one line on stderr
// and exit 1 (bad arguments or a failed check alike).
#include <charconv>
#include <cstdio>
#include <exception>
#include <memory>
#include <string>

#include "core/check/mesh_check.h"
#include "core/io/mesh_io.h"
#include "core/mesh/hex_mesh.h"
#include "core/pipeline/pipeline.h"
#include "core/sdf/shapes.h"
#include "host/backends/registry.h"

namespace {

int fail(const std::string& why) {
  std::fprintf(stderr, "mesh_shape: %s\n", why.c_str());
  return 1;
}

bool all_certified(const mchex::MeshStats& m) { return m.quality.certified == m.hexes; }

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) return fail("usage: mesh_shape SHAPE DEPTH OUT.vtu");
  try {
    const mchex::ShapeKind kind = mchex::parse_shape(argv[1]);
    mchex::MeshRequest request;
    request.solid.shape = argv[1];
    const std::string depth = argv[2];
    const auto [end, ec] = std::from_chars(depth.data(), depth.data() + depth.size(), request.options.depth);
    if (ec != std::errc() || end != depth.data() + depth.size()) return fail("DEPTH must be an integer: " + depth);
    request.options.quiet = true;
    const std::unique_ptr<mchex::Backend> backend = mchex::make_backend("cpu");
    request.backend = backend.get();

    mchex::MeshRun run = mchex::run_pipeline(request);
    const mchex::MeshCheck& check = run.check;
    if (!check.ok) return fail("the mesh fails its check: " + (check.errors.empty() ? "" : check.errors.front()));
    const std::size_t inside = run.meshes.inside.hexes.size(), outside = run.meshes.outside.hexes.size();
    if (inside == 0) return fail("the inside mesh has no hexes");
    if (!all_certified(check.inside) || !check.outside || !all_certified(*check.outside))
      return fail("not every hex is Bernstein-certified");
    const mchex::BoundaryStats& b = check.inside.boundary;
    if (!b.closed_manifold() || b.euler_characteristic != mchex::shape_euler_characteristic(kind))
      return fail("the inside boundary is not a closed surface with the shape's Euler characteristic");

    mchex::write_hex_mesh(run.meshes.inside, argv[3]);
    const mchex::HexMesh back = mchex::read_hex_mesh(argv[3]);
    if (back.hexes.size() != inside || back.points.size() != run.meshes.inside.points.size())
      return fail(std::string(argv[3]) + " does not hold the mesh that was written");
    std::printf("hexes %zu %zu\n", inside, outside);
    return 0;
  } catch (const std::exception& e) {
    return fail(e.what());
  }
}
