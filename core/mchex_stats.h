// Statistics and constants of the MCHex mesher (core/mchex_mesher.h), in a header of their own:
// core/mc33.h's struct Region and core/hex_mesh.h's enum Region cannot meet in one translation
// unit, so the cell stage (core/mchex_cells.cpp, MC33 side) and the mesh stage
// (core/mchex_mesher.cpp, HexMesh side) share only this and core/mchex_cells.h.
#pragma once

#include <array>
#include <cstddef>
#include <string_view>

namespace mchex {

// One slot per core/mc33.h Subcase (kEmpty and the 31); static_assert'ed in mchex_cells.cpp.
inline constexpr int kMchexCaseSlots = 32;
// The subcase name of a slot ("empty", "1", ..., "13.5.2", "14").
std::string_view mchex_case_name(int slot);

struct MchexStats {
  std::array<std::size_t, kMchexCaseSlots> cases{};  // cells per subcase (index: mc33 Subcase)
  std::size_t tunnel_cells = 0;     // tunnel subcases meshed with the partner's topology
  std::size_t perturbed_values = 0; // grid values moved off zero by the zero rule
  std::size_t expected_hexes = 0;   // sum over cells of 8 + 2 * cut edges
  std::size_t points = 0;           // distinct global points (both meshes together)
};

// Zero rule: a grid value with |f| < zero_tolerance(h) = 1e-10 * h (h the cell size, the SDF
// being a distance) becomes -zero_tolerance(h): "on the surface counts as outside", as in
// core/mc33.h. It is applied once to the vertex array, so every cell sharing the vertex sees the
// same value, and no crossing lands exactly on a corner (the clamp below then keeps it inside).
double zero_tolerance(double cell_size);

}  // namespace mchex
