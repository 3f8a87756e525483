// Midpoint subdivision (paper Definition 4.3); see subdivide.h.
#include "core/cutting/subdivide.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <stdexcept>
#include <string>

namespace mchex {

namespace {

// keys = k, through 8-byte stores (the struct is three bytes, kind, a, b, in that order).
void store_keys(std::array<SubdivisionPointKey, 8>& keys, const std::array<SubdivisionPointKey, 8>& k) {
  static_assert(sizeof(keys) == 24 && sizeof(SubdivisionPointKey) == 3);
  if constexpr (std::endian::native == std::endian::little) {
    std::uint64_t words[3] = {0, 0, 0};
    for (int i = 0; i < 8; ++i) {
      const std::uint64_t code =
          static_cast<std::uint64_t>(k[i].kind) | std::uint64_t{k[i].a} << 8 | std::uint64_t{k[i].b} << 16;
      const int bit = 24 * i, word = bit / 64, shift = bit % 64;
      words[word] |= code << shift;
      if (shift > 40) words[word + 1] |= code >> (64 - shift);
    }
    std::memcpy(keys.data(), words, sizeof words);
  } else {
    keys = k;
  }
}

}  // namespace

std::vector<SubdivisionHex> midpoint_subdivide(const Polyhedron& p) {
  std::vector<SubdivisionHex> hexes;
  midpoint_subdivide(p, hexes);
  return hexes;
}

void midpoint_subdivide(const Polyhedron& p, std::vector<SubdivisionHex>& hexes) {
  using Kind = SubdivisionPointKey::Kind;
  const std::size_t nv = p.points.size();
  // Per vertex, the faces through it with the vertex before and after it in the face's cycle.
  struct Incidence {
    std::uint32_t face, prev, next;
  };
  // Three incidences per vertex at most (a fourth makes the vertex fail below): one flat array,
  // not a vector per vertex, kept per thread with the others (this runs for every polyhedron the
  // mesher and certify cut; `around` is read only where `degree` says it was written). Grown,
  // never shrunk, and used through plain pointers: a store through one does not make the
  // compiler reload the others (degree is not a char type for that reason).
  thread_local std::vector<std::array<Incidence, 3>> around_storage;
  thread_local std::vector<std::uint32_t> degree_storage;
  thread_local std::vector<Vec3> centroid_storage;
  if (around_storage.size() < nv) around_storage.resize(nv);
  if (degree_storage.size() < nv) degree_storage.resize(nv);
  if (centroid_storage.size() < p.faces.size()) centroid_storage.resize(p.faces.size());
  std::array<Incidence, 3>* const around = around_storage.data();
  std::uint32_t* const degree = degree_storage.data();
  Vec3* const centroid = centroid_storage.data();
  std::fill_n(degree, nv, 0u);
  for (std::uint32_t f = 0; f < p.faces.size(); ++f) {
    const auto& face = p.faces[f];
    const std::size_t m = face.size();
    if (m < 3) throw std::invalid_argument("midpoint_subdivide: a face with fewer than 3 vertices");
    Vec3 sum{};
    for (std::size_t i = 0; i < m; ++i) {
      const std::uint32_t v = face[i];
      if (v >= nv) throw std::invalid_argument("midpoint_subdivide: a face vertex out of range");
      sum += p.points[v];
      if (degree[v] < 3) around[v][degree[v]] = {f, face[i == 0 ? m - 1 : i - 1], face[i + 1 == m ? 0 : i + 1]};
      degree[v] = std::min(degree[v] + 1, 4u);
    }
    centroid[f] = sum / static_cast<double>(m);
  }
  Vec3 centre{};
  for (const Vec3& v : p.points) centre += v;
  centre = centre / static_cast<double>(nv);
  if (p.volume_centre) centre = *p.volume_centre;  // an offset centre (paper Eq. 14)

  auto key_of = [&](std::uint32_t v) { return p.keys.empty() ? std::uint8_t(v) : p.keys[v]; };
  auto edge_key = [&](std::uint32_t u, std::uint32_t v) {
    std::uint8_t a = key_of(u), b = key_of(v);
    if (b < a) std::swap(a, b);
    return SubdivisionPointKey{Kind::kEdge, a, b};
  };
  auto fail = [](std::uint32_t v) {
    throw std::invalid_argument("midpoint_subdivide: vertex " + std::to_string(v) +
                                " is not a consistently oriented degree-3 vertex");
  };

  // Every field of every hex is written below, in place: a hex built aside and copied in is read
  // back 16 bytes at a time from the narrower stores just made, a stall each (perf: 4 % of
  // certify), and one made by emplace_back is zeroed by a slow string store first.
  hexes.resize(nv);
  for (std::uint32_t v = 0; v < nv; ++v) {
    const auto& inc = around[v];
    if (degree[v] != 3) fail(v);
    // Face F = inc[0] runs a -> v -> b. Around v the faces seen from outside alternate their
    // shared edges: the face where a is the NEXT vertex holds edges (v, c) and (v, a), and the
    // face where b is the PREVIOUS vertex holds edges (v, b) and (v, c).
    const std::uint32_t a = inc[0].prev, b = inc[0].next;
    const Incidence* fac = nullptr;
    const Incidence* fbc = nullptr;
    for (int i = 1; i < 3; ++i) {
      if (inc[i].next == a) fac = &inc[i];
      if (inc[i].prev == b) fbc = &inc[i];
    }
    if (!fac || !fbc || fac == fbc || fac->prev != fbc->next || fac->prev == a || fac->prev == b) fail(v);
    const std::uint32_t c = fac->prev;
    const Vec3 x = p.points[v];
    // The keys go in as three 8-byte words: after each byte store the compiler would reload every
    // pointer (a byte may alias anything).
    SubdivisionHex& h = hexes[v];
    h.vertex = v;
    h.corners[0] = x;
    h.corners[1] = 0.5 * (x + p.points[a]);
    h.corners[2] = centroid[inc[0].face];
    h.corners[3] = 0.5 * (x + p.points[b]);
    h.corners[4] = 0.5 * (x + p.points[c]);
    h.corners[5] = centroid[fac->face];
    h.corners[6] = centre;
    h.corners[7] = centroid[fbc->face];
    auto face_key = [](std::uint32_t f) { return SubdivisionPointKey{Kind::kFace, static_cast<std::uint8_t>(f), 0}; };
    store_keys(h.keys,
               {SubdivisionPointKey{Kind::kVertex, key_of(v), 0}, edge_key(v, a), face_key(inc[0].face), edge_key(v, b),
                edge_key(v, c), face_key(fac->face), SubdivisionPointKey{Kind::kCentre, 0, 0}, face_key(fbc->face)});
  }
}

}  // namespace mchex
