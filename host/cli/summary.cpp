#include "host/cli/summary.h"

#include <fmt/format.h>

namespace mchex::cli {
namespace {

// One row of counts, the first bin ([-1, 0): inverted somewhere) set apart.
std::string histogram_line(const char* name, const Histogram& h) {
  std::string s =
      fmt::format("    {:<16} {} | {}", name, h.counts[0], fmt::join(h.counts.begin() + 1, h.counts.end(), " "));
  if (h.below || h.above) s += fmt::format("  (below -1: {}, above 1: {})", h.below, h.above);
  return s + "\n";
}

std::string region_line(const char* label, const RegionQuality& r) {
  const QualityStats& q = r.quality;
  return fmt::format(
      "  {} region {}: {} hexes, scaled Jacobian {:.3g} to {:.3g}, dihedral angles {:.4g} to {:.4g} degrees, edge "
      "ratio {:.3g} to {:.3g}\n",
      label, r.region, q.count, q.min_scaled_jacobian, q.max_scaled_jacobian, q.min_dihedral_angle,
      q.max_dihedral_angle, q.min_edge_ratio, q.max_edge_ratio);
}

std::string describe(const char* label, const MeshStats& m, bool detailed) {
  const QualityStats& q = m.quality;
  const BoundaryStats& b = m.boundary;
  // Three significant digits: a minimum scaled Jacobian of 2e-5 must not print as 0.0000.
  std::string s = fmt::format(
      "  {} quality: min scaled Jacobian {:.3g} (mean {:.3g}), Bernstein-certified {}/{} ({:.2f}%), max edge ratio "
      "{:.3g}\n",
      label, q.min_scaled_jacobian, q.mean_scaled_jacobian, q.certified, q.count,
      q.count ? 100.0 * q.certified / q.count : 100.0, q.max_edge_ratio);
  s += fmt::format(
      "  {} shape: dihedral angles {:.4g} to {:.4g} degrees, min inverse condition number {:.3g}, min Bernstein "
      "bound {:.3g}\n",
      label, q.min_dihedral_angle, q.max_dihedral_angle, q.min_inverse_condition, q.min_bernstein_scaled);
  if (detailed) {
    s += fmt::format("  {} histograms, bins from {}:\n", label, fmt::join(Histogram::kEdges, " | "));
    s += histogram_line("scaled Jacobian", q.scaled_jacobian_histogram);
    s += histogram_line("Bernstein bound", q.bernstein_scaled_histogram);
    for (const RegionQuality& r : m.regions) s += region_line(label, r);
    if (m.too_many_regions)
      s += fmt::format("  {} regions: more than {} labels, not broken down\n", label, MeshStats::kMaxRegions);
  }
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

std::string summary(const MeshCheck& c, bool detailed) {
  std::string s = describe("inside ", c.inside, detailed);
  if (c.outside) s += describe("outside", *c.outside, detailed);
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
      "certified {} -> {} of {}, {} sweeps, {:.3g} hexes/s per sweep ({} plain at {:.3g}, {} search at {:.3g}, {} edge-ratio at {:.3g})\n",
      s.min_sj_before, s.min_sj_after, s.mean_sj_before, s.mean_sj_after, s.max_edge_ratio_before,
      s.max_edge_ratio_after, s.certified_before, s.certified_after, s.hexes, s.sweeps, s.hexes_per_second(),
      s.plain_sweeps, s.plain_hexes_per_second(), s.search_sweeps(), s.search_hexes_per_second(), s.ratio_sweeps,
      s.ratio_hexes_per_second());
}

}  // namespace mchex::cli
