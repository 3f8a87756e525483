#include "core/check/fidelity.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/base/parallel.h"
#include "core/check/mesh_check.h"
#include "core/mesh/quality.h"

namespace mchex {
namespace {

// Newton's tolerances for a hex whose corners span `box`, on points within it: the step below
// which it stops, in parametric units, and the margin of the unit cube that still counts as inside.
// The step's floor is rounding's: the residual p - x(t) is a difference of coordinates of size
// |x|, known to an ulp or so of that, which is a parametric error of about eps |x| / L in a hex of
// extent L. On a hex much smaller than its distance from the origin (the clamped slivers at the
// surface: edges of 1e-3 of a cell) a fixed 1e-13 was below that floor, Newton never got there,
// and the sample counted as unresolved: which samples did depended on the last bits of the
// corners, moving the IoU by up to 0.001 on the bumpy torus.
struct InverseTolerance {
  double step = 0, inside = 0;
};
InverseTolerance inverse_tolerance(const Box& box) {
  const Vec3 size = box.size();
  const double extent = std::max({size.x, size.y, size.z});
  double magnitude = 0;
  for (const Vec3& c : {box.lo, box.hi}) magnitude = std::max({magnitude, std::abs(c.x), std::abs(c.y), std::abs(c.z)});
  const double floor = 64 * std::numeric_limits<double>::epsilon() * magnitude / extent;
  return {std::max(1e-13, floor), std::max(1e-10, 4 * floor)};
}

// Newton on the trilinear map (paper Eq. 7) from the centre. Returns false when it does not
// converge; *inside tells whether the preimage lies in the closed unit cube.
bool invert_trilinear(const std::array<Vec3, 8>& x, Vec3 p, const InverseTolerance& tol, bool* inside) {
  Vec3 t{0.5, 0.5, 0.5};
  for (int it = 0; it < 30; ++it) {
    const auto [du, dv, dw] = jacobian(x, t.x, t.y, t.z);
    const double det = triple(du, dv, dw);
    if (!(std::abs(det) > 0)) return false;
    const Vec3 r = p - trilinear_map(x, t);
    // Cramer's rule for J * delta = r.
    const Vec3 delta{triple(r, dv, dw) / det, triple(du, r, dw) / det, triple(du, dv, r) / det};
    t += delta;
    if (std::max({std::abs(delta.x), std::abs(delta.y), std::abs(delta.z)}) < tol.step) {
      const double m = tol.inside;
      *inside = t.x >= -m && t.x <= 1 + m && t.y >= -m && t.y <= 1 + m && t.z >= -m && t.z <= 1 + m;
      return true;
    }
    // Far outside the cube the map is not meaningful; the point is not in this hex.
    if (std::abs(t.x - 0.5) > 4 || std::abs(t.y - 0.5) > 4 || std::abs(t.z - 0.5) > 4) {
      *inside = false;
      return true;
    }
  }
  return false;
}

// The solid's SDF on the lattice, or at least its sign where |f| bounds the distance to any sign
// change: a block of kBlock^3 samples is decided by one of its 8 corner samples when |f| there
// exceeds the block's diagonal (the ball of radius |f| around the corner holds the whole block and
// no sign change), and only the undecided blocks, those near the surface, are evaluated whole.
// The signs (all the IoU reads) are those of evaluating every sample.
void solid_on_lattice(const SignedDistance& solid, std::span<const Vec3> points, std::size_t lattice, Vec3 step,
                      std::span<double> f) {
  constexpr std::size_t kBlock = 4;
  const std::size_t blocks = (lattice + kBlock - 1) / kBlock, corners = blocks + 1;
  auto corner_index = [&](std::size_t c) { return std::min(c * kBlock, lattice - 1); };
  auto at = [&](std::size_t i, std::size_t j, std::size_t k) { return i + lattice * (j + lattice * k); };
  std::vector<Vec3> cp(corners * corners * corners);
  parallel_for(cp.size(), [&](std::size_t c) {
    cp[c] = points[at(corner_index(c % corners), corner_index((c / corners) % corners),
                      corner_index(c / (corners * corners)))];
  });
  std::vector<double> cf(cp.size());
  solid.evaluate(cp, cf);
  const double diagonal = norm(double(kBlock) * step);
  // Per block: the deciding corner value, or NaN where the block needs every sample.
  std::vector<double> decided(blocks * blocks * blocks, std::numeric_limits<double>::quiet_NaN());
  parallel_for(decided.size(), [&](std::size_t b) {
    const std::size_t bi = b % blocks, bj = (b / blocks) % blocks, bk = b / (blocks * blocks);
    for (int c = 0; c < 8; ++c) {
      const double v = cf[(bi + (c & 1)) + corners * ((bj + ((c >> 1) & 1)) + corners * (bk + (c >> 2)))];
      if (std::abs(v) > diagonal) {
        decided[b] = v;
        return;
      }
    }
  });
  std::vector<std::size_t> todo;
  for (std::size_t s = 0; s < f.size(); ++s) {
    const std::size_t i = s % lattice, j = (s / lattice) % lattice, k = s / (lattice * lattice);
    const double v = decided[i / kBlock + blocks * (j / kBlock + blocks * (k / kBlock))];
    if (std::isnan(v)) todo.push_back(s);
    else f[s] = v;
  }
  std::vector<Vec3> tp(todo.size());
  parallel_for(todo.size(), [&](std::size_t t) { tp[t] = points[todo[t]]; });
  std::vector<double> tf(todo.size());
  solid.evaluate(tp, tf);
  for (std::size_t t = 0; t < todo.size(); ++t) f[todo[t]] = tf[t];
}

}  // namespace

std::vector<Vec3> sample_surface(const TriangleSurface& surface, double spacing) {
  // Rows parallel to the longest edge, a spacing apart across the triangle, each sampled at the
  // spacing: about area / spacing^2 points however thin the triangle (a grid over two edges
  // would give (longest edge / spacing)^2 on a sliver).
  std::vector<Vec3> out;
  for (const auto& t : surface.triangles) {
    Vec3 a = surface.vertices[t[0]], b = surface.vertices[t[1]], c = surface.vertices[t[2]];
    if (norm(c - b) > norm(b - a) && norm(c - b) >= norm(a - c)) std::swap(a, c);
    else if (norm(a - c) > norm(b - a)) std::swap(b, c);  // now a-b is a longest edge
    const Vec3 ab = b - a;
    const double len = norm(ab);
    const double height = len > 0 ? norm(cross(ab, c - a)) / len : norm(c - a);
    const int rows = std::max(1, int(std::ceil(height / spacing)));
    for (int r = 0; r <= rows; ++r) {
      const double v = double(r) / rows;
      const Vec3 p = a + v * (c - a), q = b + v * (c - b);
      const int k = std::max(r == rows ? 0 : 1, int(std::ceil(norm(q - p) / spacing)));
      for (int i = 0; i <= k; ++i) out.push_back(k ? p + (double(i) / k) * (q - p) : p);
    }
  }
  return out;
}

std::vector<Vec3> sample_surface(const SignedDistance& solid, const Box& box, double spacing) {
  // Lattice points within a spacing of the surface, pulled onto it along the SDF gradient
  // (p - f grad f is the closest point for an exact SDF; three rounds absorb the rest).
  const Vec3 size = box.size();
  const std::size_t n[3] = {std::size_t(std::ceil(size.x / spacing)) + 1, std::size_t(std::ceil(size.y / spacing)) + 1,
                            std::size_t(std::ceil(size.z / spacing)) + 1};
  auto at = [&](std::size_t i, std::size_t j, std::size_t k) {
    return box.lo + Vec3{i * spacing, j * spacing, k * spacing};
  };
  // The lattice has (400 / sqrt 3)^3 = 12 M points at the usual spacing (370 MB of points and
  // values, measured): it is visited in blocks of kBlock^3 points, and a block is skipped when a
  // corner's |f| exceeds the block's diagonal plus the spacing, since every point of the block
  // then has |f| above the spacing (|f| is 1-Lipschitz). The points kept are those of the whole
  // lattice, in its order.
  constexpr std::size_t kBlock = 8;
  std::size_t blocks[3], corners[3];
  for (int a = 0; a < 3; ++a) blocks[a] = (n[a] + kBlock - 1) / kBlock, corners[a] = blocks[a] + 1;
  auto corner_index = [&](std::size_t c, int a) { return std::min(c * kBlock, n[a] - 1); };
  std::vector<Vec3> cp(corners[0] * corners[1] * corners[2]);
  parallel_for(cp.size(), [&](std::size_t c) {
    cp[c] = at(corner_index(c % corners[0], 0), corner_index((c / corners[0]) % corners[1], 1),
               corner_index(c / (corners[0] * corners[1]), 2));
  });
  std::vector<double> cf(cp.size());
  solid.evaluate(cp, cf);
  const double reach = std::sqrt(3.0) * double(kBlock) * spacing + spacing;
  std::vector<uint8_t> near(blocks[0] * blocks[1] * blocks[2], 1);
  parallel_for(near.size(), [&](std::size_t b) {
    const std::size_t bi = b % blocks[0], bj = (b / blocks[0]) % blocks[1], bk = b / (blocks[0] * blocks[1]);
    for (int c = 0; c < 8; ++c) {
      const std::size_t i = bi + (c & 1), j = bj + ((c >> 1) & 1), k = bk + (c >> 2);
      if (std::abs(cf[i + corners[0] * (j + corners[1] * k)]) > reach) near[b] = 0;
    }
  });
  std::vector<Vec3> candidates;
  for (std::size_t k = 0; k < n[2]; ++k)
    for (std::size_t j = 0; j < n[1]; ++j)
      for (std::size_t i = 0; i < n[0]; ++i)
        if (near[i / kBlock + blocks[0] * (j / kBlock + blocks[1] * (k / kBlock))]) candidates.push_back(at(i, j, k));
  std::vector<double> f(candidates.size());
  solid.evaluate(candidates, f);
  std::vector<Vec3> pts;
  for (std::size_t i = 0; i < candidates.size(); ++i)
    if (std::abs(f[i]) < spacing) pts.push_back(candidates[i]);
  const double h = 1e-6 * box.diagonal();
  std::vector<Vec3> probes(7 * pts.size());
  std::vector<double> values(probes.size());
  for (int round = 0; round < 3; ++round) {
    for (std::size_t i = 0; i < pts.size(); ++i) {
      probes[7 * i] = pts[i];
      for (int a = 0; a < 3; ++a) {
        Vec3 e{};
        e[a] = h;
        probes[7 * i + 1 + 2 * a] = pts[i] + e;
        probes[7 * i + 2 + 2 * a] = pts[i] - e;
      }
    }
    solid.evaluate(probes, values);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const double* v = &values[7 * i];
      const Vec3 g = normalized(Vec3{v[1] - v[2], v[3] - v[4], v[5] - v[6]});
      pts[i] = pts[i] - v[0] * g;  // f > 0 inside and grad points inward: step against it
    }
  }
  return pts;
}

namespace {

// The lattice's geometry: its step and its cell-centred samples.
struct Lattice {
  Vec3 lo, step;
  std::size_t n;
  Lattice(const Box& box, std::size_t lattice)
      : lo(box.lo), step{box.size().x / lattice, box.size().y / lattice, box.size().z / lattice}, n(lattice) {}
  Vec3 sample(std::size_t i, std::size_t j, std::size_t k) const {
    return Vec3{lo.x + (i + 0.5) * step.x, lo.y + (j + 0.5) * step.y, lo.z + (k + 0.5) * step.z};
  }
  Vec3 sample(std::size_t s) const { return sample(s % n, (s / n) % n, s / (n * n)); }
};

// distance_to_boundary over the boundary's quads, chunk by chunk: one chunk's search tree at a
// time. The whole boundary's tree was the run's largest allocation but for the meshes (on the npm
// gearwheel's 169k boundary quads about 100 MiB of its 429 MiB peak). First each point is measured
// against its home chunk, the one whose box is nearest it; then against the quads of every other
// chunk that can be nearer than that answer. A box holds its quads' triangles, so nothing skipped
// is nearer, and a triangle's distance is computed the same way in any chunk: the answers are the
// whole tree's, bit for bit (tests: Fidelity.BoundaryDistanceIsTheSameInChunksOfAnySize).
std::vector<double> distance_to_quads(const HexMesh& mesh, std::span<const std::array<uint32_t, 4>> quads,
                                      std::span<const Vec3> points, std::size_t chunk_quads) {
  if (chunk_quads == 0) throw std::invalid_argument("distance_to_boundary: chunks of no quads");
  // The chunks: halves of the quads' centres at the median along the longest side, until each
  // holds at most chunk_quads. Their boxes overlap only by a quad's reach, so a point is near few
  // of them (Morton ranges of the same size overlapped so much that the second pass measured
  // each point twice more).
  // A quad's bilinear centre, the apex of its four triangles.
  auto quad_centre = [&](const std::array<uint32_t, 4>& q) {
    return 0.25 * (mesh.points[q[0]] + mesh.points[q[1]] + mesh.points[q[2]] + mesh.points[q[3]]);
  };
  std::vector<uint32_t> order(quads.size());
  std::vector<std::pair<std::size_t, std::size_t>> ranges;
  {
    std::vector<Vec3> centres(quads.size());
    parallel_for(quads.size(), [&](std::size_t q) { centres[q] = quad_centre(quads[q]); });
    for (std::size_t q = 0; q < order.size(); ++q) order[q] = uint32_t(q);
    std::vector<std::pair<std::size_t, std::size_t>> stack{{0, quads.size()}};
    while (!stack.empty()) {
      const auto [first, last] = stack.back();
      stack.pop_back();
      if (last - first <= chunk_quads) {
        ranges.emplace_back(first, last);
        continue;
      }
      Box box;
      for (std::size_t k = first; k < last; ++k) box.extend(centres[order[k]]);
      const Vec3 size = box.size();
      const int axis = size.x >= size.y && size.x >= size.z ? 0 : size.y >= size.z ? 1 : 2;
      const std::size_t middle = first + (last - first) / 2;
      std::nth_element(order.begin() + first, order.begin() + middle, order.begin() + last,
                       [&](uint32_t a, uint32_t b) {
                         const double ca = centres[a][axis], cb = centres[b][axis];
                         return ca < cb || (ca == cb && a < b);
                       });
      stack.emplace_back(middle, last);
      stack.emplace_back(first, middle);
    }
  }
  const std::size_t chunks = ranges.size();
  std::vector<Box> boxes(chunks);
  parallel_for(chunks, [&](std::size_t c) {
    for (std::size_t k = ranges[c].first; k < ranges[c].second; ++k)
      for (uint32_t v : quads[order[k]]) boxes[c].extend(mesh.points[v]);
  });
  // Whether a triangle in box b can measure nearer to p than `best`: the box's distance, less what
  // rounding can take off a triangle's computed distance (a few ulps of the largest coordinate),
  // so that skipping a box never changes an answer, not even a tie in the last bits.
  double magnitude = 0;
  for (const Box& b : boxes)
    for (const Vec3& c : {b.lo, b.hi}) magnitude = std::max({magnitude, std::abs(c.x), std::abs(c.y), std::abs(c.z)});
  for (const Vec3& p : points) magnitude = std::max({magnitude, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  const double slack = 64 * std::numeric_limits<double>::epsilon() * magnitude;
  auto may_be_nearer = [slack](const Box& b, Vec3 p, double best) {
    return std::sqrt(squared_distance_to_box(p, b)) < best + slack;
  };
  std::vector<double> best(points.size(), std::numeric_limits<double>::infinity());
  // Quads as a surface of their own (a quad's corners repeated in each quad: the distances do not
  // depend on shared vertices).
  auto quad_surface = [&](std::span<const uint32_t> ids) {
    TriangleSurface s;
    s.vertices.resize(5 * ids.size());
    s.triangles.resize(4 * ids.size());
    parallel_for(ids.size(), [&](std::size_t i) {
      const auto& q = quads[ids[i]];
      const uint32_t base = uint32_t(5 * i);
      for (int e = 0; e < 4; ++e) s.vertices[base + e] = mesh.points[q[e]];
      s.vertices[base + 4] = quad_centre(q);
      for (uint32_t e = 0; e < 4; ++e) s.triangles[4 * i + e] = {base + e, base + (e + 1) % 4, base + 4};
    });
    return s;
  };
  auto quad_box = [&](uint32_t q) {
    Box b;
    for (uint32_t v : quads[q]) b.extend(mesh.points[v]);
    return b;
  };
  // The quads of chunk c that can be nearer to a point of `batch` than its answer so far: a
  // point's candidates are found through a grid of cells at least as wide as every answer and
  // every quad, so a quad's box grown by the widest answer meets at most 4 cells a side.
  auto needed_quads = [&](std::size_t c, const std::vector<uint32_t>& batch) {
    const std::span<const uint32_t> all(order.data() + ranges[c].first, ranges[c].second - ranges[c].first);
    double reach = 0, widest = 0;
    for (uint32_t i : batch) reach = std::max(reach, best[i] + slack);
    for (uint32_t q : all) {
      const Vec3 size = quad_box(q).size();
      widest = std::max({widest, size.x, size.y, size.z});
    }
    const double cell = std::max(reach, widest);
    if (!(cell > 0 && cell < std::numeric_limits<double>::infinity()))
      return std::vector<uint32_t>(all.begin(), all.end());
    auto at = [cell](double x) { return int64_t(std::floor(x / cell)); };
    auto key = [](int64_t i, int64_t j, int64_t k) {
      return uint64_t(i & 0x1FFFFF) << 42 | uint64_t(j & 0x1FFFFF) << 21 | uint64_t(k & 0x1FFFFF);
    };
    std::unordered_map<uint64_t, std::vector<uint32_t>> cells;
    for (uint32_t i : batch) cells[key(at(points[i].x), at(points[i].y), at(points[i].z))].push_back(i);
    std::vector<uint8_t> keep(all.size(), 0);
    parallel_for(all.size(), [&](std::size_t k) {
      const Box b = quad_box(all[k]);
      for (int64_t i = at(b.lo.x - reach); i <= at(b.hi.x + reach) && !keep[k]; ++i)
        for (int64_t j = at(b.lo.y - reach); j <= at(b.hi.y + reach) && !keep[k]; ++j)
          for (int64_t l = at(b.lo.z - reach); l <= at(b.hi.z + reach) && !keep[k]; ++l) {
            const auto found = cells.find(key(i, j, l));
            if (found == cells.end()) continue;
            for (uint32_t p : found->second)
              if (may_be_nearer(b, points[p], best[p])) {
                keep[k] = 1;
                break;
              }
          }
    });
    std::vector<uint32_t> kept;
    for (std::size_t k = 0; k < all.size(); ++k)
      if (keep[k]) kept.push_back(all[k]);
    return kept;
  };
  std::vector<uint32_t> home(points.size());
  parallel_for(points.size(), [&](std::size_t i) {
    double nearest = std::numeric_limits<double>::infinity();
    for (std::size_t c = 0; c < chunks; ++c)
      if (const double d = squared_distance_to_box(points[i], boxes[c]); d < nearest)
        nearest = d, home[i] = uint32_t(c);
  });
  // Each chunk's batch, by a counting sort on the chunk: one pass over the points, not one a chunk.
  std::vector<std::vector<uint32_t>> batches(chunks);
  auto fill_batches = [&](auto&& in_chunk) {
    for (auto& b : batches) b.clear();
    for (std::size_t i = 0; i < points.size(); ++i)
      in_chunk(uint32_t(i), [&](std::size_t c) { batches[c].push_back(uint32_t(i)); });
  };
  // A chunk's batch measured against the chunk's quads: all of them the first time, then only
  // those that can still be nearer (most of a chunk is far from the few points near its side).
  auto measure = [&](std::size_t c, bool all) {
    const std::vector<uint32_t>& batch = batches[c];
    if (batch.empty()) return;
    const std::vector<uint32_t> ids = all ? std::vector<uint32_t>(order.begin() + std::ptrdiff_t(ranges[c].first),
                                                                  order.begin() + std::ptrdiff_t(ranges[c].second))
                                          : needed_quads(c, batch);
    if (ids.empty()) return;
    std::vector<Vec3> batch_points(batch.size());
    std::vector<double> batch_values(batch.size(), 0);
    for (std::size_t k = 0; k < batch.size(); ++k) batch_points[k] = points[batch[k]];
    const SurfaceSdf chunk(quad_surface(ids), SignRule::kPseudonormal, SearchUse::kOneBatchInFours);
    chunk.distance(batch_points, batch_values);
    for (std::size_t k = 0; k < batch.size(); ++k) best[batch[k]] = std::min(best[batch[k]], batch_values[k]);
  };
  fill_batches([&](uint32_t i, auto&& add) { add(home[i]); });
  for (std::size_t c = 0; c < chunks; ++c) measure(c, true);
  // Which points another chunk may hold a nearer triangle for: flagged in parallel (most are
  // not), then listed.
  std::vector<uint8_t> beyond(points.size());
  parallel_for(points.size(), [&](std::size_t i) {
    for (std::size_t c = 0; c < chunks && !beyond[i]; ++c)
      beyond[i] = c != home[i] && may_be_nearer(boxes[c], points[i], best[i]);
  });
  fill_batches([&](uint32_t i, auto&& add) {
    if (beyond[i])
      for (std::size_t c = 0; c < chunks; ++c)
        if (c != home[i] && may_be_nearer(boxes[c], points[i], best[i])) add(c);
  });
  for (std::size_t c = 0; c < chunks; ++c) measure(c, false);
  return best;
}

}  // namespace

std::vector<double> distance_to_boundary(const HexMesh& inside, std::span<const Vec3> points, std::size_t chunk_quads) {
  const auto quads = boundary_quads(inside);
  if (quads.empty()) return std::vector<double>(points.size(), std::numeric_limits<double>::infinity());
  return distance_to_quads(inside, quads, points, chunk_quads);
}

FidelityReference fidelity_reference(const SignedDistance& solid, std::vector<Vec3> surface_samples,
                                     const Box& lattice_box, std::size_t lattice, double spacing,
                                     bool distance_bounds_sign) {
  FidelityReference ref;
  ref.surface_samples = std::move(surface_samples);
  ref.lattice_box = lattice_box;
  ref.lattice = lattice;
  ref.spacing = spacing;
  const Lattice grid(lattice_box, lattice);
  const std::size_t count = lattice * lattice * lattice;
  std::vector<Vec3> points(count);
  parallel_for(count, [&](std::size_t s) { points[s] = grid.sample(s); });
  ref.lattice_values.resize(count);
  if (distance_bounds_sign) solid_on_lattice(solid, points, lattice, grid.step, ref.lattice_values);
  else solid.evaluate(points, ref.lattice_values);
  return ref;
}

Fidelity measure_fidelity(const HexMesh& inside, const SignedDistance& solid, std::span<const Vec3> surface_samples,
                          const Box& lattice_box, std::size_t lattice, double spacing, const SurfaceDistance& distance,
                          bool distance_bounds_sign, double far_tolerance) {
  const FidelityReference ref =
      fidelity_reference(solid, std::vector<Vec3>(surface_samples.begin(), surface_samples.end()), lattice_box, lattice,
                         spacing, distance_bounds_sign);
  return measure_fidelity(inside, solid, ref, distance, far_tolerance);
}

Fidelity measure_fidelity(const HexMesh& inside, const SignedDistance& solid, const FidelityReference& reference,
                          const SurfaceDistance& distance, double far_tolerance) {
  Fidelity fid;
  const std::size_t lattice = reference.lattice;
  fid.lattice = lattice;
  const Lattice grid(reference.lattice_box, lattice);
  const Vec3 lo = grid.lo, step = grid.step;
  const std::size_t count = lattice * lattice * lattice;
  const std::span<const double> f = reference.lattice_values;
  const std::span<const Vec3> surface_samples = reference.surface_samples;
  const double spacing = reference.spacing;

  // The mesh on the lattice: each hex marks the samples it contains (bit 0), and the samples in its
  // box where inverting its map failed (bit 1). A sample counts as unresolved when no hex contains
  // it and one failed there: a hex skips samples already covered, so counting failures as they
  // happen would depend on the threads' order, and this does not.
  constexpr std::uint8_t kCovered = 1, kFailed = 2;
  std::unique_ptr<std::atomic<uint8_t>[]> covered(new std::atomic<uint8_t>[count]);
  for (std::size_t s = 0; s < count; ++s) covered[s].store(0, std::memory_order_relaxed);
  auto index_range = [&](double a, double b, double o, double d) {
    const double ia = std::ceil((a - o) / d - 0.5), ib = std::floor((b - o) / d - 0.5);
    return std::pair<std::size_t, std::size_t>(std::size_t(std::max(0.0, ia)),
                                               std::size_t(std::min(double(lattice) - 1, ib)));
  };
  parallel_for(inside.hexes.size(), [&](std::size_t h) {
    const auto x = inside.corners(h);
    Box b;
    for (const Vec3& p : x) b.extend(p);
    const auto [i0, i1] = index_range(b.lo.x, b.hi.x, lo.x, step.x);
    const auto [j0, j1] = index_range(b.lo.y, b.hi.y, lo.y, step.y);
    const auto [k0, k1] = index_range(b.lo.z, b.hi.z, lo.z, step.z);
    if (b.hi.x < lo.x + 0.5 * step.x || b.hi.y < lo.y + 0.5 * step.y || b.hi.z < lo.z + 0.5 * step.z) return;
    const InverseTolerance tol = inverse_tolerance(b);  // the samples tried lie in b
    for (std::size_t k = k0; k <= k1 && k < lattice; ++k)
      for (std::size_t j = j0; j <= j1 && j < lattice; ++j)
        for (std::size_t i = i0; i <= i1 && i < lattice; ++i) {
          const std::size_t s = i + lattice * (j + lattice * k);
          if (covered[s].load(std::memory_order_relaxed) & kCovered) continue;
          bool in = false;
          if (!invert_trilinear(x, grid.sample(i, j, k), tol, &in)) {
            covered[s].fetch_or(kFailed, std::memory_order_relaxed);
            continue;
          }
          if (in) covered[s].fetch_or(kCovered, std::memory_order_relaxed);
        }
  });
  std::size_t both = 0, either = 0, mesh_n = 0, solid_n = 0;
  for (std::size_t s = 0; s < count; ++s) {
    const std::uint8_t c = covered[s].load(std::memory_order_relaxed);
    const bool m = (c & kCovered) != 0, v = f[s] > 0;
    fid.unresolved += c == kFailed;
    both += m && v;
    either += m || v;
    mesh_n += m;
    solid_n += v;
  }
  if (far_tolerance > 0)
    for (std::size_t s = 0; s < count; ++s)
      if (((covered[s].load(std::memory_order_relaxed) & kCovered) != 0) != (f[s] > 0))
        fid.misclassified_points.push_back(grid.sample(s));
  const double cell_volume = step.x * step.y * step.z;
  fid.iou = either ? double(both) / double(either) : 1.0;
  fid.mesh_volume = mesh_n * cell_volume;
  fid.solid_volume = solid_n * cell_volume;

  // Hausdorff, mesh side: bilinear samples on every boundary quad, measured by the distance to
  // the surface. A quad's corners are boundary vertices that several quads share: each is
  // measured once, the quads add only their edge and interior samples (none on a quad shorter
  // than the spacing, the common case on a fine grid), so the maximum is over the same points.
  // The samples are measured kMeshSampleBlock at a time, in the same order, and only their
  // maximum and the far ones kept: a coarse mesh's large flat quads take many samples each (1.3 M
  // on the npm cube at its default grid, 30 MB held at once before).
  const auto quads = boundary_quads(inside);
  {
    std::vector<Vec3> block;
    block.reserve(kMeshSampleBlock);
    std::vector<double> d(kMeshSampleBlock);
    auto measure = [&] {
      const std::span<double> out(d.data(), block.size());
      if (distance) {
        distance(block, out);
      } else {
        solid.evaluate(block, out);
      }
      for (std::size_t i = 0; i < block.size(); ++i) {
        fid.mesh_to_surface = std::max(fid.mesh_to_surface, std::abs(out[i]));
        if (far_tolerance > 0 && !(std::abs(out[i]) <= far_tolerance)) fid.far_points.push_back(block[i]);
      }
      block.clear();
    };
    auto add = [&](Vec3 p) {
      block.push_back(p);
      if (block.size() == kMeshSampleBlock) measure();
    };
    std::vector<uint8_t> on_boundary(inside.points.size(), 0);
    for (const auto& q : quads)
      for (uint32_t v : q) on_boundary[v] = 1;
    for (const auto& q : quads) {
      const Vec3 c[4] = {inside.points[q[0]], inside.points[q[1]], inside.points[q[2]], inside.points[q[3]]};
      const double longest = std::max({norm(c[1] - c[0]), norm(c[2] - c[1]), norm(c[3] - c[2]), norm(c[0] - c[3])});
      const int k = std::max(1, int(std::ceil(longest / spacing)));
      for (int a = 0; a <= k; ++a)
        for (int b = 0; b <= k; ++b) {
          if ((a == 0 || a == k) && (b == 0 || b == k)) continue;  // a corner
          const double u = double(a) / k, v = double(b) / k;
          add((1 - u) * (1 - v) * c[0] + u * (1 - v) * c[1] + u * v * c[2] + (1 - u) * v * c[3]);
        }
    }
    for (std::size_t p = 0; p < on_boundary.size(); ++p)
      if (on_boundary[p]) add(inside.points[p]);
    if (!block.empty()) measure();
  }

  if (quads.empty()) {
    // No mesh surface at all: nothing of the input is matched.
    fid.surface_to_mesh = surface_samples.empty() ? 0 : std::numeric_limits<double>::infinity();
  } else if (!surface_samples.empty()) {
    const std::vector<double> d = distance_to_quads(inside, quads, surface_samples, kBoundaryChunkQuads);
    for (double v : d) fid.surface_to_mesh = std::max(fid.surface_to_mesh, v);
    if (far_tolerance > 0)
      for (std::size_t i = 0; i < d.size(); ++i)
        if (!(d[i] <= far_tolerance)) fid.far_points.push_back(surface_samples[i]);
  }
  fid.hausdorff = std::max(fid.mesh_to_surface, fid.surface_to_mesh);
  const double diag = solid.bounds().diagonal();
  fid.hausdorff_ratio = diag > 0 ? fid.hausdorff / diag : 0;
  return fid;
}

}  // namespace mchex
