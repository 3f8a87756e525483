// The triangle surface flattened for device kernels (kernels/*.cl, shaders/*.comp): every array
// is a flat buffer of 4- or 8-byte scalars, so one upload serves OpenCL (packed C structs) and
// Vulkan (std430 storage buffers: a float/uint array has stride 4, a double array stride 8, and
// BvhNode's two float[3] + uint pairs are 32 bytes in both).
//
// What a device needs to reproduce core/sdf/sdf.h's SurfaceSdf bit for bit:
//   - the BVH of core/sdf/bvh.h (depth-first nodes, float bounds rounded outward from the double
//     triangles, so pruning against them is conservative);
//   - each leaf slot's triangle: its id (ties between equal squared distances go to the lowest
//     id, as in SurfaceSdf::Impl::closest) and its corners in the triangle's own order, in double,
//     because closest_point_on_triangle's rounding depends on which corner is `a`;
//   - the angle-weighted pseudonormals (Baerentzen & Aanaes 2005) of every face, edge and vertex,
//     and each slot's vertex and edge ids to find them: the sign of the closest feature.
// Pseudonormals is the single implementation of those normals: SurfaceSdf and brute_force_sdf
// (core/sdf/sdf.cpp) use it too.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/base/geometry.h"
#include "core/mesh/surface.h"
#include "core/sdf/bvh.h"
#include "core/sdf/pseudonormals.h"

namespace mchex {

struct DeviceScene {
  std::vector<BvhNode> nodes;           // core/sdf/bvh.h layout
  std::vector<uint32_t> slot_triangle;  // leaf slot -> triangle id
  std::vector<double> slot_corners;     // 9 per slot: a.xyz b.xyz c.xyz
  std::vector<uint32_t> slot_features;  // 6 per slot: vertex ids of a, b, c; edge ids of ab, bc, ca
  std::vector<double> face_normals;     // 3 per slot (the slot's triangle's face pseudonormal)
  std::vector<double> edge_normals;     // 3 per edge
  std::vector<double> vertex_normals;   // 3 per vertex
  double scale = 0;                     // largest coordinate magnitude of the surface

  // The search tree of the fp64 kernels (kernels/sdf.h): the shape of core/sdf/sdf.cpp's reference
  // search, so that a device prunes as much as the reference does. The binary BVH above
  // (`nodes`, kept for kernels/sdf_fp32.h) collapsed to four children per node, each child's
  // triangles bounded by a box in a frame of its own (the group's mean normal where the group is
  // nearly flat: a thin slab, not an axis-aligned box as thick as the piece is wide), and below
  // each leaf a bound per triangle (its plane interval and its three edge lines). Every bound is
  // float, computed in double from the float vectors the kernel uses and rounded outward, so
  // pruning with it is conservative; the answer is still decided in double. Layouts (float4
  // groups, one child or one triangle per lane, so a step measures four at once):
  //   wide_boxes  kWideNodeFloats per node: axis[a][i] in group 3a + i, lo[a] in 9 + a,
  //               hi[a] in 12 + a; an absent child has an empty box (lo = +inf, hi = -inf);
  //   wide_links  kWideNodeLinks per node: child[4] then count[4]; count 0: child is a wide
  //               node, else child is a leaf holding `count` triangles;
  //   leaf_bounds kLeafBoundFloats per leaf: unit normal[i] in group i, plane_lo 3, plane_hi 4,
  //               edge line e's unit in-plane normal[i] in 5 + 3e + i, its bound edge_hi[e] in
  //               14 + e (|p - x|^2 >= plane^2 + edge^2 for x on the triangle);
  //   leaf_slot   the first slot of each leaf (its triangles are slots leaf_slot .. + count).
  std::vector<float> wide_boxes;
  std::vector<uint32_t> wide_links;
  std::vector<float> leaf_bounds;
  std::vector<uint32_t> leaf_slot;
  uint32_t wide_stack = 0;  // stack entries a nearest-first walk of this tree can need

  // kFp64: everything above. kFp32: what kernels/sdf_fp32.h and DeviceScene32 read (nodes,
  // slot_triangle, slot_corners, scale); the fp32 path's host half has its own pseudonormals
  // (host/backends/fp32_path.h), so neither they nor the wide tree are built for it.
  enum class Search { kFp64, kFp32 };
  static DeviceScene build(const TriangleSurface& surface, Search search = Search::kFp64);
  std::size_t slots() const { return slot_triangle.size(); }
  std::size_t bytes() const;
};

inline constexpr int kWideNodeFloats = 60, kWideNodeLinks = 8, kLeafBoundFloats = 68;
// The walk's stack in kernels/sdf.h (entries). A walk pops one node and pushes at most four, so
// it holds at most 3 per level below the root plus one: the binary BVH is at most 64 deep
// (core/sdf/bvh.cpp) and every wide level goes at least one binary level down, so 3 * 64 + 4 always
// suffices; DeviceScene::build checks its tree's own need (wide_stack) against it.
inline constexpr int kSdfWideStack = 196;

// What kernels/sdf_fp32.h needs besides DeviceScene's nodes, for a device without fp64: the
// corners rounded to float, and per slot / per node the slack that bounds how far core's double
// closest_point_on_triangle can be from the true distance (kernels/sdf_fp32.h derives it):
// slot_slack = 12 2^-41 |ab|^2 |ac|^2 / (min(|ab|, |ac|) |ab x ac|^2), rounded up to float (a
// degenerate triangle gets 1e30); node_slack the largest slot_slack below the node.
// Candidate slots per point that kernels/sdf_fp32.h returns (more: the host evaluates the point
// whole); a point's record is kFp32Candidates + 1 words (count, slots).
inline constexpr int kFp32Candidates = 8;

struct DeviceScene32 {
  std::vector<float> slot_corners;  // 9 per slot, the double corners rounded to nearest
  std::vector<float> slot_slack;
  std::vector<float> node_slack;
  static DeviceScene32 build(const DeviceScene& scene);
};

}  // namespace mchex
