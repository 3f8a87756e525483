#include "host/backend_cpu.h"

#include <stdexcept>

#include <tbb/info.h>

#include "core/local_refinement.h"
#include "core/parallel.h"
#include "core/sdf.h"
#include "core/shapes.h"

namespace mchex {
namespace {

// Identity of a surface for the BVH cache: its address and its arrays' addresses and sizes.
struct SurfaceKey {
  const TriangleSurface* surface = nullptr;
  const void* vertices = nullptr;
  const void* triangles = nullptr;
  std::size_t nv = 0, nt = 0;
  explicit SurfaceKey(const TriangleSurface* s = nullptr)
      : surface(s),
        vertices(s ? s->vertices.data() : nullptr),
        triangles(s ? s->triangles.data() : nullptr),
        nv(s ? s->vertices.size() : 0),
        nt(s ? s->triangles.size() : 0) {}
  friend bool operator==(const SurfaceKey&, const SurfaceKey&) = default;
};

class CpuBackend final : public Backend {
 public:
  CpuBackend() {
    info_.backend = "cpu";
    info_.platform = "reference";
    info_.name = "Embree + TBB";
    info_.type = "cpu";
    info_.fp64 = true;
    info_.compute_units = uint32_t(tbb::info::default_concurrency());
  }
  const DeviceInfo& device() const override { return info_; }

  void signed_distance(const SdfSource& source, std::span<const Vec3> points, std::span<double> values) override {
    if (points.size() != values.size()) throw std::invalid_argument("signed_distance: batch size mismatch");
    if (source.reference) return source.reference->evaluate(points, values);
    if (!source.surface) return ShapeSdf(source.shape).evaluate(points, values);
    const SurfaceKey key(source.surface);
    if (!(key == key_) || !sdf_) {
      sdf_ = std::make_unique<SurfaceSdf>(*source.surface);
      key_ = key;
    }
    sdf_->evaluate(points, values);
  }

  void refinement_error(std::span<const std::array<double, kChildLatticePoints>> lattice,
                        std::span<const double> sizes, std::span<double> errors) override {
    if (lattice.size() != sizes.size() || lattice.size() != errors.size())
      throw std::invalid_argument("refinement_error: batch size mismatch");
    parallel_for(lattice.size(), [&](std::size_t i) { errors[i] = mchex::refinement_error(lattice[i], sizes[i]); });
  }

  void classify_cells(const HexComplex& complex, std::span<const double> values, std::span<CellCode> codes,
                      std::span<std::uint64_t> offsets) override {
    const std::size_t n = complex.cells.size();
    if (values.size() != complex.points.size() || codes.size() != n || offsets.size() != n + 1)
      throw std::invalid_argument("classify_cells: batch size mismatch");
    parallel_for(n, [&](std::size_t i) {
      std::array<double, 8> f;
      for (int c = 0; c < 8; ++c) f[c] = values[complex.cells[i][c]];
      codes[i] = encode_cell(classify(f));
    });
    std::uint64_t run = 0;
    for (std::size_t i = 0; i < n; ++i) {
      offsets[i] = run;
      run += std::uint64_t(local_refinement_hexes(codes[i].subcase));
    }
    offsets[n] = run;
  }

 private:
  DeviceInfo info_;
  SurfaceKey key_;
  std::unique_ptr<SurfaceSdf> sdf_;
};

}  // namespace

std::unique_ptr<Backend> make_cpu_backend() { return std::make_unique<CpuBackend>(); }

}  // namespace mchex
