#include "core/check/mesh_check.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <functional>
#include <numeric>
#include <tuple>
#include <utility>

#include "core/base/error.h"
#include "core/base/parallel.h"
#include "core/mesh/hex_faces.h"
#include "core/mesh/point_index.h"
#include "core/mesh/quality.h"
#include "core/mesh/surface.h"

namespace mchex {
namespace {

constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();

// Faces as in core/mesh/hex_faces.h: outward by the right-hand rule, so two hexes on either side of
// a conforming face list it in opposite cyclic directions.
constexpr const auto& kFaces = kHexFaces;

// The first `limit` messages by key (element index or face reference), whatever order the
// parallel leaves produce them in: a bounded max-heap per leaf, merged at joins. The text is
// only formatted for messages that are kept.
class Messages {
 public:
  explicit Messages(std::size_t limit) : limit_(limit) {}

  template <class Make>
  void add(uint64_t key, Make&& make) {
    if (items_.size() < limit_) {
      items_.emplace_back(key, make());
      std::push_heap(items_.begin(), items_.end(), by_key);
    } else if (limit_ > 0 && key < items_.front().first) {
      std::pop_heap(items_.begin(), items_.end(), by_key);
      items_.back() = {key, make()};
      std::push_heap(items_.begin(), items_.end(), by_key);
    }
  }
  void join(Messages&& other) {
    for (auto& item : other.items_) add(item.first, [&] { return std::move(item.second); });
  }
  void append_sorted_to(std::vector<std::string>& out) {
    std::sort_heap(items_.begin(), items_.end(), by_key);
    for (auto& item : items_) out.push_back(std::move(item.second));
  }

 private:
  static bool by_key(const std::pair<uint64_t, std::string>& a, const std::pair<uint64_t, std::string>& b) {
    return a.first < b.first;
  }
  std::size_t limit_;
  std::vector<std::pair<uint64_t, std::string>> items_;
};

std::string point_text(Vec3 p) { return fmt::format("({}, {}, {})", p.x, p.y, p.z); }

std::string points_text(const std::array<Vec3, 4>& q) {
  return fmt::format("{} {} {} {}", point_text(q[0]), point_text(q[1]), point_text(q[2]), point_text(q[3]));
}

// An empty box has lo = +inf and hi = -inf: extending by its corners would give an infinite box.
void extend_by_box(Box& box, const Box& other) {
  if (other.empty()) return;
  box.extend(other.lo);
  box.extend(other.hi);
}

// ---------------------------------------------------------------------------------------------
// Points and hexes of one mesh.

struct PointPass {
  explicit PointPass(std::size_t max_messages) : messages(max_messages) {}
  Messages messages;
  std::size_t nonfinite = 0;
  void join(PointPass&& o) {
    messages.join(std::move(o.messages));
    nonfinite += o.nonfinite;
  }
};

void add_hex(QualityStats& s, const HexQuality& q) {
  ++s.count;
  s.min_scaled_jacobian = std::min(s.min_scaled_jacobian, q.scaled_jacobian);
  s.max_scaled_jacobian = std::max(s.max_scaled_jacobian, q.scaled_jacobian);
  s.mean_scaled_jacobian += q.scaled_jacobian;
  s.certified += q.certified() ? 1 : 0;
  s.min_bernstein_scaled = std::min(s.min_bernstein_scaled, q.min_bernstein_scaled);
  s.min_edge_ratio = std::min(s.min_edge_ratio, q.edge_ratio);
  s.max_edge_ratio = std::max(s.max_edge_ratio, q.edge_ratio);
  s.min_dihedral_angle = std::min(s.min_dihedral_angle, q.min_dihedral_angle);
  s.max_dihedral_angle = std::max(s.max_dihedral_angle, q.max_dihedral_angle);
  s.min_inverse_condition = std::min(s.min_inverse_condition, q.inverse_condition);
  s.max_inverse_condition = std::max(s.max_inverse_condition, q.inverse_condition);
  s.volume += q.volume;
  s.scaled_jacobian_histogram.add(q.scaled_jacobian);
  s.bernstein_scaled_histogram.add(q.min_bernstein_scaled);
}

void join_quality(QualityStats& q, const QualityStats& r) {
  q.count += r.count;
  q.min_scaled_jacobian = std::min(q.min_scaled_jacobian, r.min_scaled_jacobian);
  q.max_scaled_jacobian = std::max(q.max_scaled_jacobian, r.max_scaled_jacobian);
  q.mean_scaled_jacobian += r.mean_scaled_jacobian;
  q.certified += r.certified;
  q.min_bernstein_scaled = std::min(q.min_bernstein_scaled, r.min_bernstein_scaled);
  q.min_edge_ratio = std::min(q.min_edge_ratio, r.min_edge_ratio);
  q.max_edge_ratio = std::max(q.max_edge_ratio, r.max_edge_ratio);
  q.min_dihedral_angle = std::min(q.min_dihedral_angle, r.min_dihedral_angle);
  q.max_dihedral_angle = std::max(q.max_dihedral_angle, r.max_dihedral_angle);
  q.min_inverse_condition = std::min(q.min_inverse_condition, r.min_inverse_condition);
  q.max_inverse_condition = std::max(q.max_inverse_condition, r.max_inverse_condition);
  q.volume += r.volume;
  q.scaled_jacobian_histogram.join(r.scaled_jacobian_histogram);
  q.bernstein_scaled_histogram.join(r.bernstein_scaled_histogram);
}

// The sums held during the pass become means.
void finish(QualityStats& q) {
  if (q.count > 0) q.mean_scaled_jacobian /= static_cast<double>(q.count);
}

// Quality per region label during the pass: a short vector kept sorted by label (a mesh has a
// few labels; the pipeline's one each), given up past MeshStats::kMaxRegions labels.
struct RegionPass {
  std::vector<RegionQuality> regions;
  bool too_many = false;

  QualityStats* find(int32_t label) {
    if (too_many) return nullptr;
    const auto it = std::lower_bound(regions.begin(), regions.end(), label,
                                     [](const RegionQuality& r, int32_t l) { return r.region < l; });
    if (it != regions.end() && it->region == label) return &it->quality;
    if (regions.size() == MeshStats::kMaxRegions) {
      too_many = true;
      regions.clear();
      return nullptr;
    }
    return &regions.insert(it, RegionQuality{label, {}})->quality;
  }
  void join(const RegionPass& o) {
    if (o.too_many) {
      too_many = true;
      regions.clear();
    }
    for (const RegionQuality& r : o.regions)
      if (QualityStats* q = find(r.region)) join_quality(*q, r.quality);
  }
};

struct HexPass {
  explicit HexPass(std::size_t max_messages) : messages(max_messages) {}
  Messages messages;
  std::size_t bad_index = 0;
  std::size_t repeated = 0;
  std::size_t inverted = 0;
  QualityStats quality;  // mean_scaled_jacobian holds the sum until the end
  RegionPass regions;
  Box corners_box;
  void join(HexPass&& o) {
    messages.join(std::move(o.messages));
    bad_index += o.bad_index;
    repeated += o.repeated;
    inverted += o.inverted;
    join_quality(quality, o.quality);
    regions.join(o.regions);
    extend_by_box(corners_box, o.corners_box);
  }
};

// Structural checks and quality of every hex. `valid[h]` is set for hexes with 8 distinct
// in-range indices and finite corners: only those take part in the face checks.
HexPass check_hexes(const HexMesh& mesh, const std::string& name, std::size_t max_messages, std::vector<uint8_t>& valid,
                    std::vector<double>* scaled_jacobians) {
  valid.assign(mesh.hexes.size(), 0);
  if (scaled_jacobians) scaled_jacobians->assign(mesh.hexes.size(), std::numeric_limits<double>::quiet_NaN());
  const std::size_t np = mesh.points.size();
  const bool labelled = mesh.region.size() == mesh.hexes.size();
  const HexPass proto(max_messages);
  return deterministic_reduce(mesh.hexes.size(), 4096, proto, [&](std::size_t b, std::size_t e, HexPass& acc) {
    for (std::size_t h = b; h < e; ++h) {
      const Hex& hex = mesh.hexes[h];
      const auto bad = std::find_if(hex.begin(), hex.end(), [&](uint32_t v) { return v >= np; });
      if (bad != hex.end()) {
        ++acc.bad_index;
        acc.messages.add(h, [&] {
          return fmt::format("{}: hex {} has vertex index {}, but there are {} points", name, h, *bad, np);
        });
        continue;
      }
      bool repeated = false;
      for (int i = 0; i < 8 && !repeated; ++i) {
        for (int j = i + 1; j < 8 && !repeated; ++j) repeated = hex[i] == hex[j];
      }
      if (repeated) {
        ++acc.repeated;
        acc.messages.add(
            h, [&] { return fmt::format("{}: hex {} repeats a vertex: [{}]", name, h, fmt::join(hex, ", ")); });
        continue;
      }
      const HexCorners c = mesh.corners(h);
      // A non-finite corner is reported once, by the point check.
      if (!std::all_of(c.begin(), c.end(), [](Vec3 p) { return is_finite(p); })) continue;
      valid[h] = 1;
      // One cache per thread: its answers are hex_quality's bit for bit, so the thread count
      // changes nothing.
      thread_local QualityCache quality;
      const HexQuality q = quality(c);
      if (scaled_jacobians) (*scaled_jacobians)[h] = q.scaled_jacobian;
      if (!(q.min_corner_jacobian > 0)) {
        ++acc.inverted;
        acc.messages.add(h, [&] {
          return fmt::format("{}: hex {} is inverted or degenerate: det J = {} at a corner", name, h,
                             q.min_corner_jacobian);
        });
      }
      add_hex(acc.quality, q);
      if (labelled)
        if (QualityStats* r = acc.regions.find(mesh.region[h])) add_hex(*r, q);
      for (Vec3 p : c) acc.corners_box.extend(p);
    }
  });
}

// ---------------------------------------------------------------------------------------------
// Quad faces, grouped by vertex set.

// One face as seen from one hex: its vertex ids rotated to start at the smallest (`cycle`, in
// the hex's outward order), and the other three sorted (`key`), which identify the vertex set.
struct FaceRec {
  std::array<uint32_t, 3> key;
  std::array<uint32_t, 4> cycle;
  uint32_t ref;  // hex * 6 + local face

  friend bool operator<(const FaceRec& a, const FaceRec& b) { return std::tie(a.key, a.ref) < std::tie(b.key, b.ref); }
};

enum class Pairing { kOpposite, kSame, kMismatch };

// Both cycles start at the same (smallest) vertex, so for the same vertex set they are the same
// quad iff the opposite corner agrees; then the order of the two neighbours tells the direction.
Pairing pairing(const FaceRec& a, const FaceRec& b) {
  if (a.cycle[2] != b.cycle[2]) return Pairing::kMismatch;
  if (a.cycle[1] == b.cycle[3] && a.cycle[3] == b.cycle[1]) return Pairing::kOpposite;
  if (a.cycle[1] == b.cycle[1] && a.cycle[3] == b.cycle[3]) return Pairing::kSame;
  return Pairing::kMismatch;
}

template <class VertexOf>
std::array<uint32_t, 4> face_ids(const VertexOf& vertex_of, uint32_t ref) {
  const uint32_t h = ref / 6;
  const int f = static_cast<int>(ref % 6);
  return {vertex_of(h, kFaces[f][0]), vertex_of(h, kFaces[f][1]), vertex_of(h, kFaces[f][2]),
          vertex_of(h, kFaces[f][3])};
}

template <class VertexOf>
FaceRec face_rec(const VertexOf& vertex_of, uint32_t ref) {
  const auto ids = face_ids(vertex_of, ref);
  const int m = static_cast<int>(std::min_element(ids.begin(), ids.end()) - ids.begin());
  FaceRec r;
  for (int i = 0; i < 4; ++i) r.cycle[i] = ids[(m + i) % 4];
  r.key = {r.cycle[1], r.cycle[2], r.cycle[3]};
  std::sort(r.key.begin(), r.key.end());
  r.ref = ref;
  return r;
}

// Visits every group of faces with the same vertex set (each group sorted by face reference)
// and reduces the visits into an Acc. Only the faces that faces_of(h) selects take part (bit k:
// the hex's face k).
//
// The face references grouped by smallest vertex id (core/base/parallel.h group_by_key, a counting
// sort), then each bucket, a handful of faces, sorted by the other three ids. Two faces with the same vertex set have
// the same smallest id, so each group lies in one bucket. Memory: 4 bytes per face plus 4 per vertex id; no hash table,
// no 16-byte keys.
//
// Face references (hex * 6 + face) and vertex ids are 32-bit; check_mesh checks the sizes.
//
// The buckets' faces name hexes all over the mesh, so reading their corners often misses the
// cache: prefetch_hex(h) asks for hex h's corners kPrefetchAhead faces before they are read (the
// bucket pass's samples -8 % on the 4.36 M-hex torus check).
template <class Acc, class FacesOf, class VertexOf, class PrefetchHex, class Visit>
Acc reduce_face_groups(std::size_t num_hexes, std::size_t num_ids, const FacesOf& faces_of, const VertexOf& vertex_of,
                       const PrefetchHex& prefetch_hex, const Acc& proto, const Visit& visit) {
  constexpr uint32_t kPrefetchAhead = 24;
  auto min_id = [&](uint32_t ref) {
    const auto ids = face_ids(vertex_of, ref);
    return *std::min_element(ids.begin(), ids.end());
  };
  auto for_each_face = [&](auto&& f) {
    parallel_chunks(num_hexes, 4096, [&](std::size_t begin, std::size_t end) {
      for (std::size_t h = begin; h < end; ++h) {
        const unsigned mask = faces_of(static_cast<uint32_t>(h));
        for (uint32_t k = 0; k < 6; ++k)
          if (mask >> k & 1) f(static_cast<uint32_t>(h * 6 + k));
      }
    });
  };
  const KeyGroups buckets = group_by_key(num_ids, for_each_face, min_id);
  return deterministic_reduce(num_ids, 4096, proto, [&](std::size_t b, std::size_t e, Acc& acc) {
    std::vector<FaceRec> recs;
    const uint32_t last = buckets.start[e];
    for (uint32_t i = buckets.start[b]; i < std::min(last, buckets.start[b] + kPrefetchAhead); ++i)
      prefetch_hex(buckets.items[i] / 6);
    for (std::size_t v = b; v < e; ++v) {
      recs.clear();
      for (uint32_t i = buckets.start[v]; i < buckets.start[v + 1]; ++i) {
        if (i + kPrefetchAhead < last) prefetch_hex(buckets.items[i + kPrefetchAhead] / 6);
        recs.push_back(face_rec(vertex_of, buckets.items[i]));
      }
      std::sort(recs.begin(), recs.end());
      for (std::size_t i = 0; i < recs.size();) {
        std::size_t j = i + 1;
        while (j < recs.size() && recs[j].key[0] == recs[i].key[0] && recs[j].key[1] == recs[i].key[1] &&
               recs[j].key[2] == recs[i].key[2])
          ++j;
        visit(recs.data() + i, recs.data() + j, acc);
        i = j;
      }
    }
  });
}

std::string face_text(const FaceRec& r) {
  return fmt::format("[{}, {}, {}, {}]", r.cycle[0], r.cycle[1], r.cycle[2], r.cycle[3]);
}

std::string hexes_text(const FaceRec* b, const FaceRec* e) {
  std::vector<uint32_t> hexes;
  for (const FaceRec* r = b; r != e; ++r) hexes.push_back(r->ref / 6);
  return fmt::format("{}", fmt::join(hexes, ", "));
}

struct FacePass {
  explicit FacePass(std::size_t max_messages) : messages(max_messages) {}
  Messages messages;
  std::size_t faces = 0, interior = 0, nonmanifold = 0, same_orientation = 0, mismatch = 0;
  // The boundary quads, outward as their hexes list them, and their face references (hex * 6 +
  // face), in the same order; the order does not matter.
  std::vector<std::array<uint32_t, 4>> boundary;
  std::vector<uint32_t> boundary_refs;
  void join(FacePass&& o) {
    messages.join(std::move(o.messages));
    faces += o.faces;
    interior += o.interior;
    nonmanifold += o.nonmanifold;
    same_orientation += o.same_orientation;
    mismatch += o.mismatch;
    boundary.insert(boundary.end(), o.boundary.begin(), o.boundary.end());
    boundary_refs.insert(boundary_refs.end(), o.boundary_refs.begin(), o.boundary_refs.end());
  }
};

FacePass check_faces(const HexMesh& mesh, const std::string& name, const std::vector<uint8_t>& valid,
                     std::size_t max_messages) {
  const auto vertex_of = [&](uint32_t h, int c) { return mesh.hexes[h][c]; };
  const FacePass proto(max_messages);
  FacePass pass = reduce_face_groups(
      mesh.hexes.size(), mesh.points.size(), [&](uint32_t h) { return valid[h] ? 0x3Fu : 0u; }, vertex_of,
      [&](uint32_t h) { __builtin_prefetch(&mesh.hexes[h]); }, proto,
      [&](const FaceRec* b, const FaceRec* e, FacePass& acc) {
        ++acc.faces;
        const std::size_t n = static_cast<std::size_t>(e - b);
        if (n == 1) {
          acc.boundary.push_back(b->cycle);
          acc.boundary_refs.push_back(b->ref);
        } else if (n > 2) {
          ++acc.nonmanifold;
          acc.messages.add(b->ref, [&] {
            return fmt::format("{}: face {} is in {} hexes ({}); at most 2 allowed", name, face_text(*b), n,
                               hexes_text(b, e));
          });
        } else {
          switch (pairing(b[0], b[1])) {
            case Pairing::kOpposite: ++acc.interior; break;
            case Pairing::kSame:
              ++acc.same_orientation;
              acc.messages.add(b->ref, [&] {
                return fmt::format("{}: hexes {} and {} have face {} with the same orientation", name, b[0].ref / 6,
                                   b[1].ref / 6, face_text(*b));
              });
              break;
            case Pairing::kMismatch:
              ++acc.mismatch;
              acc.messages.add(b->ref, [&] {
                return fmt::format("{}: hexes {} and {} share vertices {} and {} in different cyclic "
                                   "orders",
                                   name, b[0].ref / 6, b[1].ref / 6, face_text(b[0]), face_text(b[1]));
              });
              break;
          }
        }
      });
  return pass;
}

// ---------------------------------------------------------------------------------------------
// Boundary surface of one mesh.

// The quads around one vertex form a single cycle when, seen as edges between the vertex's
// neighbours (each quad joins its two neighbours of the vertex), every neighbour has degree 2
// and one walk visits them all. wedges: (previous, next) neighbour of the vertex per quad.
bool single_fan(const std::vector<std::pair<uint32_t, uint32_t>>& wedges) {
  std::vector<uint32_t> ends;
  for (auto [p, n] : wedges) {
    ends.push_back(p);
    ends.push_back(n);
  }
  std::sort(ends.begin(), ends.end());
  for (std::size_t i = 0; i < ends.size(); i += 2) {
    if (ends[i] != ends[i + 1] || (i + 2 < ends.size() && ends[i + 2] == ends[i])) return false;
  }
  std::vector<uint8_t> used(wedges.size(), 0);
  used[0] = 1;
  uint32_t at = wedges[0].second;
  std::size_t visited = 1;
  while (at != wedges[0].first) {
    std::size_t k = 0;
    while (k < wedges.size() && (used[k] || (wedges[k].first != at && wedges[k].second != at))) ++k;
    if (k == wedges.size()) return false;
    used[k] = 1;
    ++visited;
    at = wedges[k].first == at ? wedges[k].second : wedges[k].first;
  }
  return visited == wedges.size();
}

BoundaryStats analyze_boundary(const std::vector<std::array<uint32_t, 4>>& quads, std::size_t num_ids) {
  BoundaryStats s;
  s.quads = quads.size();

  struct Edge {
    uint32_t lo, hi;
    bool forward;
  };
  std::vector<Edge> edges;
  edges.reserve(4 * quads.size());
  struct Wedge {
    uint32_t v, prev, next;
  };
  std::vector<Wedge> wedges;
  wedges.reserve(4 * quads.size());
  for (const auto& q : quads) {
    for (int i = 0; i < 4; ++i) {
      const uint32_t a = q[i], b = q[(i + 1) % 4];
      edges.push_back({std::min(a, b), std::max(a, b), a < b});
      wedges.push_back({q[i], q[(i + 3) % 4], q[(i + 1) % 4]});
    }
  }
  parallel_sort(edges.begin(), edges.end(), [](const Edge& a, const Edge& b) {
    return std::tie(a.lo, a.hi, a.forward) < std::tie(b.lo, b.hi, b.forward);
  });
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i + 1;
    while (j < edges.size() && edges[j].lo == edges[i].lo && edges[j].hi == edges[i].hi) ++j;
    ++s.edges;
    if (j - i != 2) {
      ++s.bad_edges;
    } else if (edges[i].forward == edges[i + 1].forward) {
      ++s.misoriented_edges;
    }
    i = j;
  }

  parallel_sort(wedges.begin(), wedges.end(), [](const Wedge& a, const Wedge& b) {
    return std::tie(a.v, a.prev, a.next) < std::tie(b.v, b.prev, b.next);
  });
  std::vector<std::pair<uint32_t, uint32_t>> fan;
  for (std::size_t i = 0; i < wedges.size();) {
    std::size_t j = i;
    fan.clear();
    for (; j < wedges.size() && wedges[j].v == wedges[i].v; ++j) fan.emplace_back(wedges[j].prev, wedges[j].next);
    ++s.vertices;
    if (!single_fan(fan)) ++s.bad_vertices;
    i = j;
  }

  DisjointSets sets(num_ids);
  for (const auto& q : quads) {
    for (int i = 1; i < 4; ++i) sets.unite(q[0], q[i]);
  }
  for (std::size_t i = 0; i < wedges.size(); ++i) {
    if ((i == 0 || wedges[i].v != wedges[i - 1].v) && sets.find(wedges[i].v) == wedges[i].v) ++s.components;
  }
  s.euler_characteristic =
      static_cast<int64_t>(s.vertices) - static_cast<int64_t>(s.edges) + static_cast<int64_t>(s.quads);
  return s;
}

// ---------------------------------------------------------------------------------------------
// One mesh.

struct MeshResult {
  MeshStats stats;
  std::vector<uint8_t> valid;
  std::vector<uint32_t> boundary_refs;  // FacePass::boundary_refs
  Box corners_box;
  std::size_t errors = 0;
};

MeshResult check_one(const HexMesh& mesh, const std::string& name, const CheckOptions& options,
                     std::vector<std::string>& messages) {
  MeshResult r;
  MeshStats& s = r.stats;
  s.points = mesh.points.size();
  s.hexes = mesh.hexes.size();

  PointPass points = deterministic_reduce(
      mesh.points.size(), 16384, PointPass(options.max_messages), [&](std::size_t b, std::size_t e, PointPass& acc) {
        for (std::size_t i = b; i < e; ++i) {
          if (is_finite(mesh.points[i])) continue;
          ++acc.nonfinite;
          acc.messages.add(
              i, [&] { return fmt::format("{}: point {} is not finite: {}", name, i, point_text(mesh.points[i])); });
        }
      });
  s.nonfinite_points = points.nonfinite;
  points.messages.append_sorted_to(messages);

  HexPass hexes = check_hexes(mesh, name, options.max_messages, r.valid,
                              options.keep_scaled_jacobians ? &s.scaled_jacobians : nullptr);
  s.bad_index_hexes = hexes.bad_index;
  s.repeated_vertex_hexes = hexes.repeated;
  s.inverted_hexes = hexes.inverted;
  s.quality = hexes.quality;
  finish(s.quality);
  s.regions = std::move(hexes.regions.regions);
  s.too_many_regions = hexes.regions.too_many;
  for (RegionQuality& r : s.regions) finish(r.quality);
  r.corners_box = hexes.corners_box;
  hexes.messages.append_sorted_to(messages);

  s.region_size_ok = mesh.region.size() == mesh.hexes.size() || (!options.require_regions && mesh.region.empty());
  if (!s.region_size_ok) {
    messages.push_back(fmt::format("{}: {} region labels for {} hexes", name, mesh.region.size(), mesh.hexes.size()));
  }

  FacePass faces = check_faces(mesh, name, r.valid, options.max_messages);
  s.faces = faces.faces;
  s.interior_faces = faces.interior;
  s.boundary_faces = faces.boundary.size();
  s.nonmanifold_faces = faces.nonmanifold;
  s.orientation_errors = faces.same_orientation;
  s.cyclic_mismatches = faces.mismatch;
  faces.messages.append_sorted_to(messages);

  s.boundary = analyze_boundary(faces.boundary, mesh.points.size());
  r.boundary_refs = std::move(faces.boundary_refs);

  r.errors = s.nonfinite_points + s.bad_index_hexes + s.repeated_vertex_hexes + s.inverted_hexes +
             (s.region_size_ok ? 0 : 1) + s.nonmanifold_faces + s.orientation_errors + s.cyclic_mismatches;
  return r;
}

// ---------------------------------------------------------------------------------------------
// The pair.

bool on_box_side(const std::array<Vec3, 4>& p, const Box& box) {
  for (int d = 0; d < 3; ++d) {
    for (double plane : {box.lo[d], box.hi[d]}) {
      if (std::all_of(p.begin(), p.end(), [&](Vec3 q) { return q[d] == plane; })) return true;
    }
  }
  return false;
}

struct UnionPass {
  explicit UnionPass(std::size_t max_messages) : messages(max_messages) {}
  Messages messages;
  std::size_t interface = 0, overlap = 0, gap = 0, interface_errors = 0;
  void join(UnionPass&& o) {
    messages.join(std::move(o.messages));
    interface += o.interface;
    overlap += o.overlap;
    gap += o.gap;
    interface_errors += o.interface_errors;
  }
};

UnionStats check_union(const HexMesh& in, const HexMesh& out, const MeshResult& rin, const MeshResult& rout,
                       const Box* box, const CheckOptions& options, std::vector<std::string>& messages) {
  UnionStats u;
  u.box_given = box != nullptr;
  if (box) {
    u.box = *box;
  } else {
    u.box = rin.corners_box;
    extend_by_box(u.box, rout.corners_box);
  }

  // Union vertex ids: an inside point keeps its index; an outside point takes the index of the
  // inside point at the same coordinates, or a fresh id after all inside ids. shared[p]: inside
  // point p has an outside point at its coordinates.
  const std::size_t ni = in.points.size();
  std::vector<uint32_t> out_id(out.points.size());
  std::vector<uint8_t> shared(ni, 0);
  {
    const PointIndex index(in.points);
    u.matched_points = parallel_reduce(
        out.points.size(), 16384, std::size_t{0},
        [&](std::size_t begin, std::size_t end, std::size_t matched) {
          for (std::size_t q = begin; q < end; ++q) {
            const uint32_t p = is_finite(out.points[q]) ? index.find(out.points[q]) : kNone;
            out_id[q] = p != kNone ? p : static_cast<uint32_t>(ni + q);
            if (p != kNone) std::atomic_ref<uint8_t>(shared[p]).store(1, std::memory_order_relaxed);
            matched += p != kNone ? 1 : 0;
          }
          return matched;
        },
        std::plus<>());
  }

  const std::size_t hin = in.hexes.size();
  const auto vertex_of = [&](uint32_t h, int c) { return h < hin ? in.hexes[h][c] : out_id[out.hexes[h - hin][c]]; };
  // For messages and the box test: which mesh a union face reference is from, and its corners.
  const auto describe = [&](uint32_t ref) {
    const uint32_t h = ref / 6;
    return h < hin ? fmt::format("inside hex {}", h) : fmt::format("outside hex {}", h - hin);
  };
  const auto face_points = [&](uint32_t ref) {
    const uint32_t h = ref / 6;
    const int f = static_cast<int>(ref % 6);
    const HexMesh& m = h < hin ? in : out;
    const Hex& hex = m.hexes[h < hin ? h : h - hin];
    return std::array<Vec3, 4>{m.points[hex[kFaces[f][0]]], m.points[hex[kFaces[f][1]]], m.points[hex[kFaces[f][2]]],
                               m.points[hex[kFaces[f][3]]]};
  };
  const auto gap = [&](uint32_t ref, UnionPass& acc) {
    if (on_box_side(face_points(ref), u.box)) return;
    ++acc.gap;
    acc.messages.add(ref, [&] {
      return fmt::format("union: face {} of {} is in no other hex and not on the box (a gap)",
                         points_text(face_points(ref)), describe(ref));
    });
  };

  // A face can be in hexes of both meshes only when its 4 vertices are points of both (union ids
  // below ni with shared set): the interface and any overlap. Only those faces are grouped again
  // here (in the pipeline's meshes, little more than the interface faces); every other face was
  // judged by its own mesh's check, and one that is a boundary face there is a boundary face of
  // the union, which must lie on the box.
  // grouped[h]: bit f set when face f of union hex h is one of those (valid hexes only).
  const auto is_shared = [&](uint32_t id) { return id < ni && shared[id]; };
  std::vector<uint8_t> grouped(hin + out.hexes.size(), 0);
  parallel_for(grouped.size(), [&](std::size_t i) {
    const auto h = static_cast<uint32_t>(i);
    if (!(h < hin ? rin.valid[h] : rout.valid[h - hin])) return;
    unsigned corners = 0;
    for (int c = 0; c < 8; ++c) corners |= is_shared(vertex_of(h, c)) ? 1u << c : 0u;
    for (int f = 0; f < 6; ++f) {
      const unsigned face = 1u << kFaces[f][0] | 1u << kFaces[f][1] | 1u << kFaces[f][2] | 1u << kFaces[f][3];
      if ((corners & face) == face) grouped[h] |= static_cast<uint8_t>(1u << f);
    }
  });
  const uint32_t first_outside_ref = static_cast<uint32_t>(6 * hin);
  UnionPass pass = reduce_face_groups(
      hin + out.hexes.size(), ni + out.points.size(), [&](uint32_t h) { return unsigned{grouped[h]}; }, vertex_of,
      [&](uint32_t h) { __builtin_prefetch(h < hin ? &in.hexes[h] : &out.hexes[h - hin]); },
      UnionPass(options.max_messages),
      [&](const FaceRec* b, const FaceRec* e, UnionPass& acc) {
        const std::size_t n = static_cast<std::size_t>(e - b);
        const std::size_t from_inside =
            static_cast<std::size_t>(std::count_if(b, e, [&](const FaceRec& r) { return r.ref < first_outside_ref; }));
        if (n == 1) {
          gap(b->ref, acc);
          return;
        }
        // Groups within one mesh were judged by that mesh's own check.
        if (from_inside == 0 || from_inside == n) return;
        if (n > 2) {
          ++acc.overlap;
          acc.messages.add(b->ref, [&] {
            std::vector<std::string> who;
            for (const FaceRec* r = b; r != e; ++r) who.push_back(describe(r->ref));
            return fmt::format("union: face {} is in {} hexes ({}): the meshes overlap",
                               points_text(face_points(b->ref)), n, fmt::join(who, ", "));
          });
          return;
        }
        ++acc.interface;
        if (pairing(b[0], b[1]) != Pairing::kOpposite) {
          ++acc.interface_errors;
          acc.messages.add(b->ref, [&] {
            return fmt::format("union: interface face {} of {} and {} is not matched with "
                               "opposite orientation",
                               points_text(face_points(b->ref)), describe(b[0].ref), describe(b[1].ref));
          });
        }
      });
  // The boundary faces of either mesh with a vertex of that mesh alone.
  const std::size_t nb_in = rin.boundary_refs.size();
  const auto boundary_ref = [&](std::size_t i) {
    return i < nb_in ? rin.boundary_refs[i] : first_outside_ref + rout.boundary_refs[i - nb_in];
  };
  pass.join(deterministic_reduce(nb_in + rout.boundary_refs.size(), 16384, UnionPass(options.max_messages),
                                 [&](std::size_t b, std::size_t e, UnionPass& acc) {
                                   for (std::size_t i = b; i < e; ++i) {
                                     const uint32_t ref = boundary_ref(i);
                                     if (!(grouped[ref / 6] >> (ref % 6) & 1)) gap(ref, acc);
                                   }
                                 }));
  u.interface_faces = pass.interface;
  u.overlap_faces = pass.overlap;
  u.gap_faces = pass.gap;
  u.interface_errors = pass.interface_errors;
  pass.messages.append_sorted_to(messages);

  u.volume = rin.stats.quality.volume + rout.stats.quality.volume;
  u.box_volume = u.box.empty() ? 0 : u.box.volume();
  u.volume_relative_error =
      u.box_volume > 0 ? std::abs(u.volume - u.box_volume) / u.box_volume : std::numeric_limits<double>::infinity();
  u.volume_ok = u.volume_relative_error <= options.volume_tolerance;
  if (!u.volume_ok) {
    messages.push_back(fmt::format("union: inside + outside volume {} differs from the box volume {} (relative "
                                   "{:.3g} > {:.3g})",
                                   u.volume, u.box_volume, u.volume_relative_error, options.volume_tolerance));
  }
  return u;
}

nlohmann::json number(double x) {
  // JSON has no infinity or NaN; null says "no value" (e.g. a minimum over no element).
  return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr);
}

}  // namespace

void Histogram::add(double v) {
  if (!(v >= kEdges.front())) {
    ++below;
    return;
  }
  if (v > kEdges.back()) {
    ++above;
    return;
  }
  // A first guess from the tenths, settled by comparing with the edges themselves (v * 10 rounds;
  // the edges are the doubles nearest k / 10, and the comparison is what the bins say).
  int i = v < 0 ? 0 : std::min(kBins - 1, 1 + static_cast<int>(v * 10));
  while (i > 0 && v < kEdges[i]) --i;
  while (i < kBins - 1 && v >= kEdges[i + 1]) ++i;
  ++counts[i];
}

void Histogram::join(const Histogram& o) {
  for (int i = 0; i < kBins; ++i) counts[i] += o.counts[i];
  below += o.below;
  above += o.above;
}

std::size_t Histogram::total() const { return std::accumulate(counts.begin(), counts.end(), below + above); }

std::vector<std::array<uint32_t, 4>> boundary_quads(const HexMesh& mesh) {
  const std::vector<uint8_t> valid(mesh.hexes.size(), 1);
  std::vector<std::array<uint32_t, 4>> quads = check_faces(mesh, "", valid, 0).boundary;
  std::sort(quads.begin(), quads.end());  // the parallel pass leaves them in no fixed order
  return quads;
}

MeshCheck check_mesh(const HexMesh& inside, const HexMesh* outside, const Box* box, const CheckOptions& options) {
  // Face references and union vertex ids are 32-bit: 4 bytes per face keeps 5M hexes in about
  // 120 MB. Past that many hexes the mesh would not fit in memory anyway.
  const std::size_t hexes = inside.hexes.size() + (outside ? outside->hexes.size() : 0);
  const std::size_t points = inside.points.size() + (outside ? outside->points.size() : 0);
  constexpr std::size_t kMaxHexes = std::numeric_limits<uint32_t>::max() / 6;
  if (hexes > kMaxHexes || points >= kNone) {
    throw ResourceError(
        fmt::format("mesh check: {} hexes and {} points are over the checker's limits ({} hexes, {} points)", hexes,
                    points, kMaxHexes, kNone - 1));
  }
  MeshCheck check;
  std::vector<std::string> messages;
  const MeshResult rin = check_one(inside, "inside", options, messages);
  check.inside = rin.stats;
  check.error_count = rin.errors;
  if (outside) {
    const MeshResult rout = check_one(*outside, "outside", options, messages);
    check.outside = rout.stats;
    check.error_count += rout.errors;
    const UnionStats u = check_union(inside, *outside, rin, rout, box, options, messages);
    check.combined = u;
    check.error_count += u.overlap_faces + u.gap_faces + u.interface_errors + (u.volume_ok ? 0 : 1);
  }
  if (messages.size() > options.max_messages) messages.resize(options.max_messages);
  check.errors = std::move(messages);
  check.ok = check.error_count == 0;
  return check;
}

nlohmann::json to_json(const Histogram& h) {
  return {{"edges", Histogram::kEdges}, {"counts", h.counts}, {"below", h.below}, {"above", h.above}};
}

nlohmann::json to_json(const QualityStats& q) {
  return {{"count", q.count},
          {"min_scaled_jacobian", number(q.min_scaled_jacobian)},
          {"max_scaled_jacobian", number(q.max_scaled_jacobian)},
          {"mean_scaled_jacobian", number(q.mean_scaled_jacobian)},
          {"certified", q.certified},
          {"min_bernstein_scaled", number(q.min_bernstein_scaled)},
          {"min_edge_ratio", number(q.min_edge_ratio)},
          {"max_edge_ratio", number(q.max_edge_ratio)},
          {"min_dihedral_angle", number(q.min_dihedral_angle)},
          {"max_dihedral_angle", number(q.max_dihedral_angle)},
          {"min_inverse_condition", number(q.min_inverse_condition)},
          {"max_inverse_condition", number(q.max_inverse_condition)},
          {"volume", number(q.volume)},
          {"scaled_jacobian_histogram", to_json(q.scaled_jacobian_histogram)},
          {"bernstein_scaled_histogram", to_json(q.bernstein_scaled_histogram)}};
}

nlohmann::json to_json(const BoundaryStats& b) {
  return {{"quads", b.quads},
          {"edges", b.edges},
          {"vertices", b.vertices},
          {"bad_edges", b.bad_edges},
          {"misoriented_edges", b.misoriented_edges},
          {"bad_vertices", b.bad_vertices},
          {"closed_manifold", b.closed_manifold()},
          {"euler_characteristic", b.euler_characteristic},
          {"components", b.components}};
}

nlohmann::json to_json(const MeshStats& m) {
  // null when there were too many labels to break down; [] when there are none.
  nlohmann::json regions = m.too_many_regions ? nlohmann::json(nullptr) : nlohmann::json::array();
  for (const RegionQuality& r : m.regions) regions.push_back({{"region", r.region}, {"quality", to_json(r.quality)}});
  return {{"points", m.points},
          {"hexes", m.hexes},
          {"nonfinite_points", m.nonfinite_points},
          {"bad_index_hexes", m.bad_index_hexes},
          {"repeated_vertex_hexes", m.repeated_vertex_hexes},
          {"inverted_hexes", m.inverted_hexes},
          {"region_size_ok", m.region_size_ok},
          {"nonmanifold_faces", m.nonmanifold_faces},
          {"orientation_errors", m.orientation_errors},
          {"cyclic_mismatches", m.cyclic_mismatches},
          {"faces", m.faces},
          {"interior_faces", m.interior_faces},
          {"boundary_faces", m.boundary_faces},
          {"quality", to_json(m.quality)},
          {"regions", regions},
          {"boundary", to_json(m.boundary)}};
}

nlohmann::json to_json(const UnionStats& u) {
  const auto point = [](Vec3 p) { return nlohmann::json{number(p.x), number(p.y), number(p.z)}; };
  return {{"box", {{"lo", point(u.box.lo)}, {"hi", point(u.box.hi)}}},
          {"box_given", u.box_given},
          {"matched_points", u.matched_points},
          {"interface_faces", u.interface_faces},
          {"overlap_faces", u.overlap_faces},
          {"gap_faces", u.gap_faces},
          {"interface_errors", u.interface_errors},
          {"volume", number(u.volume)},
          {"box_volume", number(u.box_volume)},
          {"volume_relative_error", number(u.volume_relative_error)},
          {"volume_ok", u.volume_ok}};
}

nlohmann::json to_json(const MeshCheck& c) {
  nlohmann::json j = {
      {"ok", c.ok}, {"error_count", c.error_count}, {"errors", c.errors}, {"inside", to_json(c.inside)}};
  j["outside"] = c.outside ? to_json(*c.outside) : nlohmann::json(nullptr);
  j["union"] = c.combined ? to_json(*c.combined) : nlohmann::json(nullptr);
  return j;
}

}  // namespace mchex
