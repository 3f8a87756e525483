#include "core/grid/cell_types.h"

#include <cmath>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>

#include "core/mesh/cube.h"

namespace mchex {

namespace {

// Columns a1 - a0, a3 - a0, a4 - a0: the frame at corner 0 (VTK order: xi, eta, zeta edges).
std::array<Vec3, 3> frame(const HexCorners& c) { return {c[1] - c[0], c[3] - c[0], c[4] - c[0]}; }

// Solves M x = v for the 3 x 3 matrix with columns m by Cramer's rule.
Vec3 solve(const std::array<Vec3, 3>& m, Vec3 v, double det) {
  return {triple(v, m[1], m[2]) / det, triple(m[0], v, m[2]) / det, triple(m[0], m[1], v) / det};
}

struct Table {
  std::vector<CellType> types;
  std::array<std::vector<CellTypeMatch>, kNumTemplates> matches;
};

std::optional<CellTypeMatch> match_in(const std::vector<CellType>& types, const HexCorners& c) {
  for (std::size_t t = 0; t < types.size(); ++t)
    for (int r = 0; r < kNumCubeRotations; ++r)
      if (affinely_equivalent(transform_hex(types[t].corners, r), c)) return CellTypeMatch{static_cast<int>(t), r};
  return std::nullopt;
}

const Table& table() {
  static const Table t = [] {
    Table t;
    for (int k = 0; k < kNumTemplates; ++k) {
      const auto hexes = template_hexes(k);
      int per_template = 0;
      for (std::size_t h = 0; h < hexes.size(); ++h) {
        const HexCorners c = template_hex_corners(hexes[h]);
        auto m = match_in(t.types, c);
        if (!m) {
          CellType type;
          type.corners = c;
          type.source = k;
          type.source_hex = static_cast<int>(h);
          ++per_template;
          type.name = std::string(template_name(k));
          t.types.push_back(type);
          m = CellTypeMatch{static_cast<int>(t.types.size() - 1), 0};
        }
        t.matches[k].push_back(*m);
      }
      // Number the types of a template that has several ("edge-1", "edge-2", ...).
      if (per_template > 1) {
        int n = 0;
        for (CellType& type : t.types)
          if (type.source == k) type.name = fmt::format("{}-{}", type.name, ++n);
      }
    }
    return t;
  }();
  return t;
}

}  // namespace

HexCorners template_hex_corners(const TemplateHex& h) {
  HexCorners c;
  for (int i = 0; i < 8; ++i)
    c[i] = Vec3{double(h.corners[i][0]), double(h.corners[i][1]), double(h.corners[i][2])} / double(kTemplateUnits);
  return c;
}

HexCorners transform_hex(const HexCorners& c, int symmetry) {
  const CubeSymmetry& g = kCubeSymmetries.at(static_cast<std::size_t>(symmetry));
  HexCorners out;
  for (int i = 0; i < 8; ++i) out[g.corner[i]] = c[i];
  return out;
}

bool affinely_equivalent(const HexCorners& a, const HexCorners& b, double tolerance) {
  const auto fa = frame(a), fb = frame(b);
  const double da = triple(fa[0], fa[1], fa[2]), db = triple(fb[0], fb[1], fb[2]);
  // A = Fb Fa^-1 has det db / da: orientation-preserving iff both frames have the same sign.
  if (da == 0 || db == 0 || (da > 0) != (db > 0)) return false;
  double scale = 0;
  for (int i = 0; i < 8; ++i) scale = std::max(scale, norm(b[i] - b[0]));
  for (int i = 0; i < 8; ++i) {
    const Vec3 w = solve(fa, a[i] - a[0], da);  // a_i - a_0 in the frame of a
    const Vec3 image = b[0] + w.x * fb[0] + w.y * fb[1] + w.z * fb[2];
    if (norm(image - b[i]) > tolerance * scale) return false;
  }
  return true;
}

std::span<const CellType> cell_types() { return table().types; }

CellTypeMatch template_hex_type(int t, int hex) {
  return table().matches.at(static_cast<std::size_t>(t)).at(static_cast<std::size_t>(hex));
}

std::optional<CellTypeMatch> find_cell_type(const HexCorners& c) { return match_in(table().types, c); }

}  // namespace mchex
