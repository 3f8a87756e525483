// The six quad faces of a VTK-ordered hex, each listed counter-clockwise seen from outside the
// hex, so a face's normal by the right-hand rule points out of it. Shared by the checker and the
// fidelity measures (boundary extraction).
#pragma once

#include <array>

namespace mchex {

inline constexpr std::array<std::array<int, 4>, 6> kHexFaces = {{
    {0, 4, 7, 3},  // xi = 0
    {1, 2, 6, 5},  // xi = 1
    {0, 1, 5, 4},  // eta = 0
    {3, 7, 6, 2},  // eta = 1
    {0, 3, 2, 1},  // zeta = 0
    {4, 5, 6, 7},  // zeta = 1
}};

}  // namespace mchex
