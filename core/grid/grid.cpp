#include "core/grid/grid.h"

#include <stdexcept>
#include <string>

#include "core/base/error.h"

namespace mchex {

Box padded_cube(const Box& bounds, double pad_fraction) {
  if (bounds.empty()) throw InputError("the input has no extent");
  const Vec3 size = bounds.size();
  const double extent = std::max({size.x, size.y, size.z});
  if (!(extent > 0)) throw InputError("the input is a single point");
  const double half = 0.5 * extent * (1 + 2 * pad_fraction);
  const Vec3 c = bounds.center();
  return {{c.x - half, c.y - half, c.z - half}, {c.x + half, c.y + half, c.z + half}};
}

UniformGrid::UniformGrid(const Box& cube, int depth) : box_(cube), depth_(depth) {
  if (depth < 0 || depth > kMaxUniformDepth)
    throw InputError("depth must be between 0 and " + std::to_string(kMaxUniformDepth) + ", got " +
                     std::to_string(depth));
  n_ = 1;
  for (int d = 0; d < depth; ++d) n_ *= 3;
  h_ = (box_.hi.x - box_.lo.x) / n_;
}

Vec3 UniformGrid::vertex(uint32_t i, uint32_t j, uint32_t k) const {
  // Interpolate from both ends so that the last vertex is exactly box.hi.
  auto at = [this](double lo, double hi, uint32_t t) { return t == n_ ? hi : lo + (hi - lo) * (double(t) / n_); };
  return {at(box_.lo.x, box_.hi.x, i), at(box_.lo.y, box_.hi.y, j), at(box_.lo.z, box_.hi.z, k)};
}

std::vector<Vec3> UniformGrid::vertices() const {
  std::vector<Vec3> v(vertex_count());
  for (uint32_t k = 0; k <= n_; ++k)
    for (uint32_t j = 0; j <= n_; ++j)
      for (uint32_t i = 0; i <= n_; ++i) v[vertex_index(i, j, k)] = vertex(i, j, k);
  return v;
}

std::array<uint32_t, 8> UniformGrid::cell_corners(uint32_t i, uint32_t j, uint32_t k) const {
  // clang-format off
  return {vertex_index(i, j, k),         vertex_index(i + 1, j, k),
          vertex_index(i + 1, j + 1, k), vertex_index(i, j + 1, k),
          vertex_index(i, j, k + 1),     vertex_index(i + 1, j, k + 1),
          vertex_index(i + 1, j + 1, k + 1), vertex_index(i, j + 1, k + 1)};
  // clang-format on
}

}  // namespace mchex
