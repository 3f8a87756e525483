#include "host/backends/cpu.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/base/parallel.h"
#include "core/cutting/local_refinement.h"
#include "core/sdf/sdf.h"
#include "core/sdf/shapes.h"

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
    info_.precision = "fp64";
    info_.kernels = "core/ in double, Embree BVH search, TBB threads";
    info_.compute_units = uint32_t(hardware_threads());
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

  void refinement_error(std::span<const std::array<double, kChildLatticePoints>> lattice, std::span<const double> sizes,
                        std::span<double> errors) override {
    if (lattice.size() != sizes.size() || lattice.size() != errors.size())
      throw std::invalid_argument("refinement_error: batch size mismatch");
    parallel_for(lattice.size(), [&](std::size_t i) { errors[i] = mchex::refinement_error(lattice[i], sizes[i]); });
  }

  void classify_cells(const HexComplex& complex, std::span<const double> values, const CellClassification& out,
                      const ClassifyOptions& options = {}) override {
    check_classify_sizes(complex, values, out, options);
    const std::size_t n = complex.cells.size();
    const double tiny = options.zero_tolerance;
    parallel_for(n, [&](std::size_t i) {
      std::array<double, 8> f;
      for (int c = 0; c < 8; ++c) {
        const double v = values[complex.cells[i][c]];
        f[c] = std::abs(v) < tiny ? -tiny : v;  // core/cutting/mchex_mesher.h apply_zero_rule (NaN passes)
      }
      const CellClass cls = classify(f);
      out.subcases[i] = static_cast<std::uint8_t>(cls.subcase);
      if (!out.words.empty()) {
        const auto w = encode_cell_words(encode_cell(cls));
        out.words[2 * i] = w[0];
        out.words[2 * i + 1] = w[1];
      }
      if (!out.crossings.empty()) std::copy(cls.crossing.begin(), cls.crossing.end(), out.crossings.begin() + 12 * i);
    });
    std::uint64_t run = 0;
    for (std::size_t i = 0; i < n; ++i) {
      out.offsets[i] = run;
      run += std::uint64_t(local_refinement_hexes(static_cast<Subcase>(out.subcases[i])));
    }
    out.offsets[n] = run;
  }

 private:
  DeviceInfo info_;
  SurfaceKey key_;
  std::unique_ptr<SurfaceSdf> sdf_;
};

}  // namespace

std::unique_ptr<Backend> make_cpu_backend() { return std::make_unique<CpuBackend>(); }

}  // namespace mchex
