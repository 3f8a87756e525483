// The uniform 3-refinement grid: a cube around the input split 3^depth times per axis (depth d
// is d levels of 27-child refinement of the root cell), with vertices shared between cells.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/base/geometry.h"

namespace mchex {

// The cube the mesh fills: the input's bounds grown by pad_fraction of their largest extent on
// every side, then made cubic about their centre so that every cell is a cube (the paper's
// 3-refinement and its cell types assume cubic root cells).
Box padded_cube(const Box& bounds, double pad_fraction);

class UniformGrid {
 public:
  UniformGrid(const Box& cube, int depth);

  int depth() const { return depth_; }
  uint32_t cells_per_axis() const { return n_; }
  std::size_t cell_count() const { return std::size_t(n_) * n_ * n_; }
  std::size_t vertex_count() const { return std::size_t(n_ + 1) * (n_ + 1) * (n_ + 1); }
  const Box& box() const { return box_; }
  double cell_size() const { return h_; }

  uint32_t vertex_index(uint32_t i, uint32_t j, uint32_t k) const { return i + (n_ + 1) * (j + (n_ + 1) * k); }
  // Grid vertex positions are computed from integer coordinates (never accumulated), so the same
  // vertex has bit-identical coordinates wherever it is computed.
  Vec3 vertex(uint32_t i, uint32_t j, uint32_t k) const;
  std::vector<Vec3> vertices() const;  // in vertex_index order (x fastest)
  // Corners of cell (i, j, k) in VTK hexahedron order.
  std::array<uint32_t, 8> cell_corners(uint32_t i, uint32_t j, uint32_t k) const;

 private:
  Box box_;
  int depth_;
  uint32_t n_;
  double h_;
};

// Deepest grid this build will make: 3^7 = 2187 cells per axis already means 10^10 cells.
inline constexpr int kMaxUniformDepth = 6;

}  // namespace mchex
