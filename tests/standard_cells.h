// Cells of the standard (Schneiders) 3-refinement templates that the adaptive grid used before the
// vertex-based set replaced them (docs/templates.md): known hard cases for the volume-centre search
// and local refinement, kept as fixed geometry for the regression tests of those mechanisms. The
// corners are in twelfths of the leaf, VTK order, right-handed: node (the node template's transition
// hex), edge-3 (the edge template's top hex) and face-3 (the face template's trapezoidal prism).
#pragma once

#include <string>

#include "core/mesh/quality.h"

namespace mchex::standard_cells {

inline HexCorners twelfths(const std::array<std::array<double, 3>, 8>& p) {
  HexCorners c;
  for (int i = 0; i < 8; ++i) c[i] = Vec3{p[i][0], p[i][1], p[i][2]} / 12.0;
  return c;
}

inline HexCorners cell(const std::string& name) {
  if (name == "node")
    return twelfths({{{4, 0, 0}, {12, 0, 0}, {12, 12, 0}, {4, 4, 0}, {4, 0, 4}, {12, 0, 12}, {12, 12, 12}, {4, 4, 4}}});
  if (name == "edge-3")
    return twelfths({{{4, 0, 9}, {0, 0, 12}, {12, 0, 12}, {8, 0, 9}, {4, 9, 9}, {0, 12, 12}, {12, 12, 12}, {8, 9, 9}}});
  if (name == "face-3")
    return twelfths({{{4, 4, 6}, {8, 4, 6}, {8, 8, 6}, {4, 8, 6}, {4, 0, 9}, {8, 0, 9}, {8, 12, 9}, {4, 12, 9}}});
  throw std::invalid_argument("no standard cell " + name);
}

}  // namespace mchex::standard_cells
