#include "host/cli/summary.h"

#include <fmt/format.h>

namespace mchex::cli {
namespace {

std::string describe(const char* label, const MeshStats& m) {
  const QualityStats& q = m.quality;
  const BoundaryStats& b = m.boundary;
  std::string s = fmt::format(
      "  {} quality: min scaled Jacobian {:.4f} (mean {:.4f}), Bernstein-certified {}/{} ({:.2f}%), max edge ratio {:.3g}\n",
      label, q.min_scaled_jacobian, q.mean_scaled_jacobian, q.certified, q.count,
      q.count ? 100.0 * q.certified / q.count : 100.0, q.max_edge_ratio);
  s += fmt::format("  {} boundary: {} quads, {}, Euler characteristic {}, {} component(s)\n", label, b.quads,
                   b.closed_manifold() ? "closed 2-manifold"
                                       : fmt::format("not a closed 2-manifold ({} edges, {} vertices off)", b.bad_edges,
                                                     b.bad_vertices),
                   b.euler_characteristic, b.components);
  return s;
}

}  // namespace

std::string first_error(const MeshCheck& c) {
  return c.errors.empty() ? std::string("unknown error") : c.errors.front();
}

std::string summary(const MeshCheck& c) {
  std::string s = describe("inside ", c.inside);
  if (c.outside) s += describe("outside", *c.outside);
  if (c.combined)
    s += fmt::format("  conformity: {} interface faces, {} gap, {} overlap faces, volume error {:.2e}\n",
                     c.combined->interface_faces, c.combined->gap_faces, c.combined->overlap_faces,
                     c.combined->volume_relative_error);
  s += c.ok ? "  structure: ok\n" : fmt::format("  structure: {} error(s), first: {}\n", c.error_count, first_error(c));
  return s;
}

std::string fidelity_line(const Fidelity& f) {
  return fmt::format("  fidelity: IoU {:.4f}, Hausdorff {:.4g} ({:.3f}% of the input diagonal)\n", f.iou, f.hausdorff,
                     100 * f.hausdorff_ratio);
}

std::string optimize_line(const OptimizeStats& s) {
  return fmt::format(
      "  optimize: min scaled Jacobian {:.4f} -> {:.4f} (mean {:.4f} -> {:.4f}), max edge ratio {:.3g} -> {:.3g}, "
      "certified {} -> {} of {}, {} sweeps, {:.3g} hexes/s per sweep\n",
      s.min_sj_before, s.min_sj_after, s.mean_sj_before, s.mean_sj_after, s.max_edge_ratio_before,
      s.max_edge_ratio_after, s.certified_before, s.certified_after, s.hexes, s.sweeps, s.hexes_per_second());
}

}  // namespace mchex::cli
