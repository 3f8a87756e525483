// The feature-sensitive refinement error of one octree cell (Tong & Zhang 2025, Section 3,
// adapting Zhang et al.'s 2-refinement error to 3-refinement):
//
//   E = max over the 64 corners x_i of the 27 children of |f^{j+1}(x_i) - f^j(x_i)| / |grad f^j(x_i)|
//
// f^{j+1} is the SDF sampled at the children's corners, f^j the parent cell's trilinear
// interpolant of its own 8 corner values. Dividing by the gradient turns a value error into a
// distance: E estimates how far the parent's isosurface lies from the children's, in the units
// of the input. The same function runs in core (this reference), the OpenCL kernel and the
// Vulkan shader; kernels must match it to the last bit where they use fp64.
#pragma once

#include <array>

namespace mchex {

// The 4 x 4 x 4 lattice of a cell's 27 children: point (a, b, c), a, b, c in 0..3, is
// lo + (a, b, c) * size / 3 and has index a + 4 * b + 16 * c. The parent's corners are the
// points with a, b, c in {0, 3}.
inline constexpr int kChildLatticePoints = 64;
constexpr int child_lattice_index(int a, int b, int c) { return a + 4 * b + 16 * c; }

// values: f at the 64 lattice points; size: the (cubic) cell's edge length. Where the parent's
// interpolant has zero gradient, a point with no value change contributes 0 and any change
// gives +infinity (the parent cannot locate a surface there, so the cell must refine).
double refinement_error(const std::array<double, kChildLatticePoints>& values, double size);

}  // namespace mchex
