#include "core/grid/templates.h"

#include <stdexcept>
#include <vector>

#include <fmt/format.h>

#include "core/grid/template_table.h"
#include "core/mesh/cube.h"

namespace mchex {

namespace {

static_assert(template_table::kNumTemplates == kNumTemplates);

struct Tables {
  std::array<std::vector<TemplateHex>, kNumTemplates> hexes;
  std::array<std::uint16_t, kNumTemplates> canonical_split{};
  std::array<TemplateChoice, 256> choice{};
};

std::uint16_t rotate_edges(std::uint16_t edges, int r) {
  std::uint16_t out = 0;
  for (int e = 0; e < 12; ++e)
    if (edges >> e & 1) out |= static_cast<std::uint16_t>(1u << kCubeSymmetries[r].edge[e]);
  return out;
}

const Tables& tables() {
  static const Tables t = [] {
    Tables t;
    for (int k = 0; k < kNumTemplates; ++k) {
      const template_table::TableTemplate& tt = template_table::kTemplates[k];
      for (int h = 0; h < tt.hexes; ++h) {
        TemplateHex hex;
        for (int c = 0; c < 8; ++c)
          hex.corners[c] = template_table::kPoints[tt.first_point + template_table::kHexes[tt.first_hex + h][c]];
        hex.child = k == kUniformTemplate;
        t.hexes[k].push_back(hex);
      }
      t.canonical_split[k] = split_edges(tt.canonical_marks);
    }
    // Each marking's split edges are some template's canonical ones under a rotation; the lowest
    // (template, rotation) wins, so the choice is a pure function of the table and kCubeSymmetries.
    for (int m = 0; m < 256; ++m) {
      const std::uint16_t want = split_edges(static_cast<std::uint8_t>(m));
      bool found = false;
      for (int k = 0; k < kNumTemplates && !found; ++k)
        for (int r = 0; r < kNumCubeRotations && !found; ++r)
          if (rotate_edges(t.canonical_split[k], r) == want) {
            t.choice[m] = {static_cast<std::uint8_t>(k), static_cast<std::uint8_t>(r)};
            found = true;
          }
      if (!found) throw std::logic_error(fmt::format("no template for the marking {:#04x}", m));
    }
    return t;
  }();
  return t;
}

}  // namespace

std::string_view template_name(int t) {
  static constexpr std::array<std::string_view, kNumTemplates> kNames = {
      "single",       "edge",         "face",         "three-corner",   "concave-edge",
      "composite-6",  "composite-7",  "composite-8",  "two-edges",      "composite-10",
      "composite-11", "composite-12", "composite-13", "concave-corner", "uniform"};
  return kNames.at(static_cast<std::size_t>(t));
}

int template_source_id(int t) { return template_table::kTemplates[t].es_id; }

std::span<const TemplateHex> template_hexes(int t) { return tables().hexes.at(static_cast<std::size_t>(t)); }

std::uint8_t template_canonical_marks(int t) { return template_table::kTemplates[t].canonical_marks; }

std::uint16_t split_edges(std::uint8_t marks) {
  std::uint16_t out = 0;
  for (int e = 0; e < 12; ++e)
    if ((marks >> kCubeEdges[e][0] & 1) && (marks >> kCubeEdges[e][1] & 1)) out |= static_cast<std::uint16_t>(1u << e);
  return out;
}

TemplateChoice template_for_marks(std::uint8_t marks) { return tables().choice[marks]; }

TemplatePoint transform_template_point(TemplatePoint p, int symmetry) {
  const CubeSymmetry& g = kCubeSymmetries.at(static_cast<std::size_t>(symmetry));
  TemplatePoint q;
  for (int i = 0; i < 3; ++i) {
    const int v = p[g.axis[i]];
    q[i] = static_cast<std::int16_t>((g.flip >> i & 1) ? kTemplateUnits - v : v);
  }
  return q;
}

}  // namespace mchex
