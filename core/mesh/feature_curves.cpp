#include "core/mesh/feature_curves.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace mchex {
namespace {

constexpr uint32_t kLeafSize = 4;

}  // namespace

FeatureCurves::FeatureCurves(const TriangleSurface& surface, double angle_degrees) {
  const SurfaceEdges edges = surface_edges(surface);
  const auto& v = surface.vertices;
  std::vector<Vec3> normal(surface.triangles.size());
  for (std::size_t t = 0; t < normal.size(); ++t) {
    const auto [a, b, c] = surface.triangles[t];
    normal[t] = normalized(cross(v[b] - v[a], v[c] - v[a]));
  }
  const double cos_angle = std::cos(angle_degrees * M_PI / 180);
  std::vector<uint32_t> sharp;  // edge numbers, increasing
  std::vector<uint32_t> degree(v.size(), 0);
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const EdgeUse* use[2] = {nullptr, nullptr};
    int uses = 0;
    for (const EdgeUse& u : edges.uses_of(e)) {
      if (u.collapsed) continue;
      if (uses < 2) use[uses] = &u;
      ++uses;
    }
    bool is_sharp = uses == 1 || uses > 2;
    if (uses == 2) {
      const Vec3 n0 = normal[use[0]->triangle];
      const Vec3 n1 = use[0]->forward == use[1]->forward ? -normal[use[1]->triangle] : normal[use[1]->triangle];
      is_sharp = n0 != Vec3{} && n1 != Vec3{} && dot(n0, n1) < cos_angle;
    }
    if (!is_sharp) continue;
    sharp.push_back(uint32_t(e));
    ++degree[edges.vertices[e][0]];
    ++degree[edges.vertices[e][1]];
  }
  // Curves: sharp edges joined through the vertices that are not corners.
  DisjointSets sets(sharp.size());
  std::vector<uint32_t> through(v.size(), kAnyCurve);  // the first sharp edge seen at a vertex
  for (uint32_t s = 0; s < sharp.size(); ++s)
    for (uint32_t w : edges.vertices[sharp[s]]) {
      if (degree[w] > 2) continue;
      if (through[w] == kAnyCurve) through[w] = s;
      else sets.unite(through[w], s);
    }
  std::vector<uint32_t> number(sharp.size(), kAnyCurve);
  for (uint32_t s = 0; s < sharp.size(); ++s) {
    const uint32_t root = sets.find(s);
    if (number[root] == kAnyCurve) number[root] = uint32_t(curves_++);
    segments_.push_back({v[edges.vertices[sharp[s]][0]], v[edges.vertices[sharp[s]][1]]});
    curve_.push_back(number[root]);
  }
  for (std::size_t w = 0; w < v.size(); ++w)
    if (degree[w] >= 3) {
      segments_.push_back({v[w], v[w]});
      curve_.push_back(uint32_t(curves_ + corners_++));
    }
  if (segments_.empty()) return;
  order_.resize(segments_.size());
  std::iota(order_.begin(), order_.end(), 0u);
  nodes_.reserve(2 * segments_.size() / kLeafSize + 2);
  build(0, uint32_t(segments_.size()));
}

// Splits at the median of the segment midpoints along the longest side of the node's box (ties
// by segment number, so the tree depends only on the segments).
uint32_t FeatureCurves::build(uint32_t first, uint32_t count) {
  const uint32_t n = uint32_t(nodes_.size());
  nodes_.emplace_back();
  Box box;
  for (uint32_t i = first; i < first + count; ++i) {
    box.extend(segments_[order_[i]][0]);
    box.extend(segments_[order_[i]][1]);
  }
  nodes_[n].box = box;
  if (count <= kLeafSize) {
    nodes_[n].first = first;
    nodes_[n].count = count;
    return n;
  }
  const Vec3 size = box.size();
  const int axis = size.x >= size.y && size.x >= size.z ? 0 : (size.y >= size.z ? 1 : 2);
  auto key = [&](uint32_t s) { return segments_[s][0][axis] + segments_[s][1][axis]; };
  const auto begin = order_.begin() + first, mid = begin + count / 2;
  std::nth_element(begin, mid, begin + count,
                   [&](uint32_t a, uint32_t b) { return key(a) < key(b) || (key(a) == key(b) && a < b); });
  build(first, count / 2);
  const uint32_t second = build(first + count / 2, count - count / 2);
  nodes_[n].second = second;
  return n;
}

FeatureCurves::Nearest FeatureCurves::nearest(Vec3 p, uint32_t curve, double radius) const {
  Nearest best;
  if (nodes_.empty()) return best;
  best.squared_distance = radius * radius;
  uint32_t best_segment = kAnyCurve;
  uint32_t stack[64];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const uint32_t n = stack[--top];
    const Node& node = nodes_[n];
    if (squared_distance_to_box(p, node.box) > best.squared_distance) continue;
    if (node.count == 0) {
      const uint32_t a = n + 1, b = node.second;
      // The nearer child last, so that it is searched first.
      const bool b_first = squared_distance_to_box(p, nodes_[b].box) < squared_distance_to_box(p, nodes_[a].box);
      stack[top++] = b_first ? a : b;
      stack[top++] = b_first ? b : a;
      continue;
    }
    for (uint32_t i = node.first; i < node.first + node.count; ++i) {
      const uint32_t s = order_[i];
      const bool wanted = curve == kAnyCurve ? curve_[s] < curves_
                          : curve == kCorner ? curve_[s] >= curves_
                                             : curve_[s] == curve;
      if (!wanted) continue;
      const Vec3 q = closest_on_segment(p, segments_[s][0], segments_[s][1]);
      const double d = squared_norm(p - q);
      if (d < best.squared_distance || (d == best.squared_distance && s < best_segment)) {
        best.point = q;
        best.squared_distance = d;
        best.curve = curve_[s];
        best.tangent = normalized(segments_[s][1] - segments_[s][0]);
        best_segment = s;
      }
    }
  }
  if (best_segment == kAnyCurve) best.squared_distance = std::numeric_limits<double>::infinity();
  return best;
}

}  // namespace mchex
