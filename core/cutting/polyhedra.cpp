// Cutting one cell into 3-regular polyhedra; see polyhedra.h for the construction and its scope.
#include "core/cutting/polyhedra.h"

#include <string>

#include "core/cutting/volume_centre_offset.h"
#include "core/mesh/hex_faces.h"

namespace mchex {
namespace {

// The cell edge from corner i of face f to corner i + 1 (kHexFaces order).
constexpr std::array<std::array<int, 4>, 6> make_face_edges() {
  std::array<std::array<int, 4>, 6> out{};
  for (int f = 0; f < 6; ++f)
    for (int i = 0; i < 4; ++i) out[f][i] = detail::cube_edge_index(kHexFaces[f][i], kHexFaces[f][(i + 1) % 4]);
  return out;
}
constexpr std::array<std::array<int, 4>, 6> kFaceEdges = make_face_edges();

// A piece of a cell face, as cell point keys in the face's counter-clockwise order (seen from
// outside the cell, kHexFaces), and the region it belongs to. Fixed storage (this runs for every
// cell the mesher and certify cut): a face's cycle has 4 corners and at most 4 crossings, and a
// piece at most 6 of them (a hexagon; the arc of an odd count, which fails, is never built). Keys
// are filled through a local count: a byte store could alias `size`, which the compiler would
// then reload after each.
struct KeyList {
  std::array<CellPointKey, 8> key;  // [0, size)
  int size = 0;
  const CellPointKey* begin() const { return key.data(); }
  const CellPointKey* end() const { return key.data() + size; }
};

struct FacePiece {
  KeyList keys;
  int region = -1;
};

// Every piece of the 6 faces: at most 3 per face.
struct FacePieces {
  std::array<FacePiece, 18> piece;
  int size = 0;
  void push_back(const KeyList& keys, int region) { piece[size++] = {keys, region}; }
  const FacePiece* begin() const { return piece.data(); }
  const FacePiece* end() const { return piece.data() + size; }
};

bool corner_positive(const CellClass& c, int corner) { return (c.sign_mask >> corner & 1) != 0; }

// The pieces of cell face f. Walking the face boundary gives the cycle corner, [crossing], corner,
// [crossing], ... with 0, 2 or 4 crossings. The crossings split the cycle into arcs, each a run
// of same-sign corners between two consecutive crossings; an arc closed by its chord is a piece.
// With 4 crossings (an ambiguous face: the diagonals have opposite signs) the face test joins
// the two corners of one sign: their two arcs form one hexagon (the face less the two triangles
// that the chords cut off the other two corners).
void face_pieces(const CellClass& c, int f, FacePieces& out) {
  const auto& q = kHexFaces[f];
  KeyList cycle;
  std::array<int, 4> crossing_pos{};
  int k = 0, n = 0;
  for (int i = 0; i < 4; ++i) {
    cycle.key[n++] = corner_key(q[i]);
    const int e = kFaceEdges[f][i];
    if (c.cut_edges >> e & 1) {
      crossing_pos[k++] = n;
      cycle.key[n++] = crossing_key(e);
    }
  }
  cycle.size = n;
  auto region_of = [&](const KeyList& keys) {
    int region = -1;
    for (CellPointKey key : keys) {
      if (!is_corner_key(key)) continue;
      const int r = c.corner_region[key];
      if (region >= 0 && r != region)
        throw std::logic_error("cut_cell: a piece of face " + std::to_string(f) + " has corners in two regions");
      region = r;
    }
    return region;
  };
  if (k == 0) {
    out.push_back(cycle, region_of(cycle));
    return;
  }
  if (k != 2 && k != 4) throw std::logic_error("cut_cell: a face with an odd number of crossings");
  // The arcs, starting at each crossing and ending at the next one (cyclically).
  std::array<KeyList, 4> arcs;
  for (int i = 0; i < k; ++i) {
    KeyList& arc = arcs[i];
    const int begin = crossing_pos[i], end = crossing_pos[i + 1 == k ? 0 : i + 1];
    int m = 0;
    for (int p = begin;; p = p + 1 == n ? 0 : p + 1) {
      arc.key[m++] = cycle.key[p];
      if (p == end && m > 1) break;
    }
    arc.size = m;
  }
  if (k == 2) {
    for (int i = 0; i < 2; ++i) out.push_back(arcs[i], region_of(arcs[i]));
    return;
  }
  // Ambiguous face: arcs alternate in sign; the joined sign's two arcs merge.
  const bool joins_positive = (c.face_joins >> f & 1) != 0;
  auto arc_positive = [&](const KeyList& arc) {
    return corner_positive(c, arc.key[1]);  // arc = crossing, corner, crossing
  };
  const int first_joined = arc_positive(arcs[0]) == joins_positive ? 0 : 1;
  KeyList merged = arcs[first_joined];
  int m = merged.size;
  for (CellPointKey key : arcs[first_joined + 2]) merged.key[m++] = key;
  merged.size = m;
  out.push_back(merged, region_of(merged));
  for (int i : {1 - first_joined, 3 - first_joined}) out.push_back(arcs[i], region_of(arcs[i]));
}

}  // namespace

std::vector<Polyhedron> cut_cell(const std::array<Vec3, 8>& corners, const CellClass& c) {
  std::vector<Polyhedron> out;
  cut_cell(corners, c, out);
  return out;
}

void cut_cell(const std::array<Vec3, 8>& corners, const CellClass& c, std::vector<Polyhedron>& out) {
  if (subcase_has_tunnel(c.subcase))
    throw TunnelSubcaseError("cut_cell: subcase " + std::string(subcase_name(c.subcase)) +
                             " has a tunnel; its cell must be refined first (paper, Figure 7)");
  auto position = [&](CellPointKey k) -> Vec3 {
    if (is_corner_key(k)) return corners[k];
    const int e = key_edge(k);
    const double s = c.crossing[e];
    return (1 - s) * corners[kCubeEdges[e][0]] + s * corners[kCubeEdges[e][1]];
  };

  FacePieces pieces;
  for (int f = 0; f < 6; ++f) face_pieces(c, f, pieces);

  // kEmpty: classify() reports one region holding all 8 corners, so the loop below gives the cube.
  const int num_regions = c.num_regions;
  out.resize(num_regions);
  for (int r = 0; r < num_regions; ++r) {
    // Every field set anew; the vectors (the faces' too) keep their storage from an earlier cut.
    Polyhedron& p = out[r];
    p.points.clear();
    p.keys.clear();
    std::size_t num_faces = 0;
    auto new_face = [&]() -> std::vector<std::uint32_t>& {
      if (num_faces == p.faces.size()) p.faces.emplace_back();
      std::vector<std::uint32_t>& face = p.faces[num_faces++];
      face.clear();
      return face;
    };
    p.region_sign = c.regions[r].sign;
    p.corners = c.regions[r].corners;
    p.volume_centre.reset();
    std::array<int, 20> local{};
    local.fill(-1);
    auto index_of = [&](CellPointKey k) {
      if (local[k] < 0) {
        local[k] = static_cast<int>(p.points.size());
        p.points.push_back(position(k));
        p.keys.push_back(k);
      }
      return static_cast<std::uint32_t>(local[k]);
    };
    // Corners first, in corner order, so that the vertex order does not depend on the faces.
    for (int corner = 0; corner < 8; ++corner)
      if (p.corners >> corner & 1) index_of(corner_key(corner));
    // Cell-face pieces; each chord u -> v that closes a piece (two consecutive crossings in the
    // piece's cycle) is traversed v -> u by the isosurface polygon on the same region, so that
    // the polyhedron's surface is consistently oriented.
    std::array<int, 20> next{};
    next.fill(-1);
    int num_chords = 0;
    for (const FacePiece& piece : pieces) {
      if (piece.region != r) continue;
      std::vector<std::uint32_t>& face = new_face();
      const int m = piece.keys.size;
      for (int i = 0; i < m; ++i) {
        const CellPointKey u = piece.keys.key[i], v = piece.keys.key[i + 1 == m ? 0 : i + 1];
        face.push_back(index_of(u));
        if (!is_corner_key(u) && !is_corner_key(v)) {
          if (next[v] >= 0) throw std::logic_error("cut_cell: two chords leave one crossing");
          next[v] = u;
          ++num_chords;
        }
      }
    }
    p.num_cell_face_pieces = static_cast<std::uint32_t>(num_faces);
    // The loops: every crossing of the region has exactly one chord out (above) and one in.
    std::array<bool, 20> used{};
    for (int start = 8; start < 20; ++start) {
      if (next[start] < 0 || used[start]) continue;
      std::vector<std::uint32_t>& loop = new_face();
      int k = start;
      while (!used[k]) {
        used[k] = true;
        loop.push_back(index_of(static_cast<CellPointKey>(k)));
        k = next[k];
        if (k < 0) throw std::logic_error("cut_cell: an isosurface loop does not close");
        num_chords -= 1;
      }
      if (k != start) throw std::logic_error("cut_cell: an isosurface loop does not close");
    }
    p.faces.resize(num_faces);
    if (num_chords != 0) throw std::logic_error("cut_cell: chords left outside the loops");
    // Paper Section 5, Eq. 14: where the table has an offset, the volume centre is the cell's
    // trilinear map at the parametric vertex mean plus the offset.
    if (const auto v = volume_centre_offset(c, p.corners))
      p.volume_centre = trilinear_point(corners, parametric_volume_centre(p, c) + *v);
  }
}

double polyhedron_volume(const Polyhedron& p) {
  if (p.points.empty()) return 0;
  // Relative to one vertex, so that a cell far from the origin loses no digits.
  const Vec3 o = p.points[0];
  double six_v = 0;
  for (const auto& face : p.faces) {
    Vec3 centre{};
    for (std::uint32_t i : face) centre += p.points[i];
    centre = centre / static_cast<double>(face.size()) - o;
    for (std::size_t i = 0; i < face.size(); ++i) {
      const Vec3 a = p.points[face[i]] - o, b = p.points[face[(i + 1) % face.size()]] - o;
      six_v += triple(centre, a, b);
    }
  }
  return six_v / 6;
}

}  // namespace mchex
