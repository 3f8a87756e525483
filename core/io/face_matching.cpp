// face_matching.h: boundary and interface faces by hashing each slice's open faces.
#include "core/io/face_matching.h"

#include <algorithm>
#include <array>
#include <cstddef>
#include <limits>
#include <memory>
#include <mutex>
#include <tuple>
#include <utility>

#include "core/base/parallel.h"
#include "core/mesh/hex_faces.h"

namespace mchex::io_detail {
namespace {

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

// Fixed, so that the pairing of faces that three hexes share does not depend on the threads; 16
// keeps 2 to 8 threads busy, and each cut between slices adds one layer of faces to the final,
// serial, match.
constexpr std::size_t kSlices = 16;

using FaceKey = std::array<std::uint32_t, 4>;

// The corners of face k of a hex, sorted by a network of five compare-exchanges (no branches).
FaceKey face_key(const Hex& hex, std::uint32_t k) {
  const auto& corners = kHexFaces[k];
  std::uint32_t a = hex[corners[0]], b = hex[corners[1]], c = hex[corners[2]], d = hex[corners[3]];
  auto order = [](std::uint32_t& x, std::uint32_t& y) {
    const std::uint32_t lo = std::min(x, y);
    y = std::max(x, y);
    x = lo;
  };
  order(a, b);
  order(c, d);
  order(a, c);
  order(b, d);
  order(b, c);
  return {a, b, c, d};
}

FaceKey face_key(const HexMesh& mesh, std::uint32_t f) { return face_key(mesh.hexes[f / 6], f % 6); }

bool same(const FaceKey& a, const FaceKey& b) {
  // Branch-free: std::array's == became a memcmp call, 12 % of the .exo write.
  return ((a[0] ^ b[0]) | (a[1] ^ b[1]) | (a[2] ^ b[2]) | (a[3] ^ b[3])) == 0;
}

// The faces waiting for their partner, by their corners. Linear probing from a home slot that
// hashes the smallest corner only, so that the faces around one point share a cluster; a slot
// holds the whole key, so a probe never reads the mesh. A matched face is taken out by shifting
// the rest of its cluster back (no tombstones), so a table whose faces come and go stays as large
// as its front, not as its slice. On the bench_formats block the whole matching took 12 ns per
// face against 27 with 32-bit hashes checked against the hexes' corners and a full hash of the
// key (CPU time, 1 thread).
//
// Every slice starts from the same capacity and grows the same way, so which faces it leaves and
// in which order depend on its hexes alone; the memory (two buffers, for growing) is reused from
// slice to slice.
class OpenFaces {
 public:
  // `multiplier` (odd) picks the hash: the merge of the slices' leftovers uses another one than
  // the slices, because a slice leaves its faces in slot order, which is home order under its own
  // hash; inserted into a smaller table under the same hash they would pile up (1110 probes a face
  // on the bench block's first slice, with one multiplier for all tables).
  void reset(std::uint64_t multiplier) {
    multiplier_ = multiplier;
    capacity_ = std::size_t{1} << kInitialBits;
    bits_ = kInitialBits;
    clear(slots_, capacity_);
    size_ = 0;
  }

  void prefetch(const FaceKey& key) const { __builtin_prefetch(&slots_[home(key, bits_)]); }

  // The open face with these corners, taken out of the table; kNone (and f put in) if there is
  // none.
  std::uint32_t match(std::uint32_t f, const FaceKey& key) {
    const std::size_t mask = capacity_ - 1;
    std::size_t i = home(key, bits_);
    for (;; i = (i + 1) & mask) {
      const Slot& s = slots_[i];
      if (s.face == kNone) break;
      if (same(s.key, key)) {
        const std::uint32_t g = s.face;
        take_out(i);
        return g;
      }
    }
    slots_[i] = {key, f};
    if (2 * ++size_ > capacity_) grow();
    return kNone;
  }

  // Takes out the open faces whose key fails `keep`, appending them to `out`.
  template <class Keep>
  void retire(const Keep& keep, std::vector<std::uint32_t>& out) {
    std::vector<Slot> kept;
    for (std::size_t i = 0; i < capacity_; ++i) {
      if (slots_[i].face == kNone) continue;
      if (keep(slots_[i].key)) {
        kept.push_back(slots_[i]);
      } else {
        out.push_back(slots_[i].face);
      }
    }
    if (kept.size() == size_) return;
    clear(slots_, capacity_);
    size_ = 0;
    for (const Slot& k : kept) match(k.face, k.key);
  }

  // Every open face, in slot order; the table is left empty.
  std::vector<std::uint32_t> drain() {
    std::vector<std::uint32_t> faces;
    faces.reserve(size_);
    for (std::size_t i = 0; i < capacity_; ++i)
      if (slots_[i].face != kNone) faces.push_back(slots_[i].face);
    reset(multiplier_);
    return faces;
  }

 private:
  struct Slot {
    FaceKey key;
    std::uint32_t face;
  };
  static constexpr int kInitialBits = 14;

  // The top bits of a multiplicative hash of the smallest corner. Hashing the whole key makes
  // fewer probes (1.6 against 2.2 a face) but twice the time: the faces around a point no longer
  // share cache lines.
  std::size_t home(const FaceKey& key, int bits) const {
    return static_cast<std::size_t>((key[0] * multiplier_) >> (64 - bits));
  }

  static void clear(std::vector<Slot>& slots, std::size_t capacity) {
    if (slots.size() < capacity) slots.resize(capacity);
    for (std::size_t i = 0; i < capacity; ++i) slots[i].face = kNone;
  }

  void take_out(std::size_t i) {
    const std::size_t mask = capacity_ - 1;
    for (std::size_t j = i;;) {
      j = (j + 1) & mask;
      const Slot& s = slots_[j];
      if (s.face == kNone) break;
      // s may fill the hole at i when i lies between its home and j (cyclically).
      const std::size_t h = home(s.key, bits_);
      if (((j - h) & mask) >= ((j - i) & mask)) {
        slots_[i] = s;
        i = j;
      }
    }
    slots_[i].face = kNone;
    --size_;
  }

  void grow() {
    clear(spare_, 2 * capacity_);
    const std::size_t mask = 2 * capacity_ - 1;
    for (std::size_t k = 0; k < capacity_; ++k) {
      const Slot& s = slots_[k];
      if (s.face == kNone) continue;
      std::size_t i = home(s.key, bits_ + 1);
      while (spare_[i].face != kNone) i = (i + 1) & mask;
      spare_[i] = s;
    }
    slots_.swap(spare_);
    capacity_ *= 2;
    ++bits_;
  }

  std::vector<Slot> slots_, spare_;
  std::uint64_t multiplier_ = 0;
  std::size_t capacity_ = 0;
  int bits_ = 0;  // log2(capacity_)
  std::size_t size_ = 0;
};

constexpr std::uint64_t kSliceHash = 0x9E3779B97F4A7C15ull, kMergeHash = 0xC2B2AE3D27D4EB4Full;

// The tables of the slices in flight, one per thread at most, reused from slice to slice (their
// memory is already paged in).
class TablePool {
 public:
  std::unique_ptr<OpenFaces> take(std::uint64_t multiplier) {
    const std::lock_guard<std::mutex> lock(mutex_);
    std::unique_ptr<OpenFaces> t;
    if (free_.empty()) {
      t = std::make_unique<OpenFaces>();
    } else {
      t = std::move(free_.back());
      free_.pop_back();
    }
    t->reset(multiplier);
    return t;
  }
  void give(std::unique_ptr<OpenFaces> t) {
    const std::lock_guard<std::mutex> lock(mutex_);
    free_.push_back(std::move(t));
  }

 private:
  std::mutex mutex_;
  std::vector<std::unique_ptr<OpenFaces>> free_;
};

using InterfaceFace = std::tuple<int32_t, int32_t, std::uint32_t>;  // lower, upper, face

// Faces f and g matched, their hexes' regions differ: the face of the lower region's hex.
void note_interface(const HexMesh& mesh, std::uint32_t f, std::uint32_t g, std::vector<InterfaceFace>& interfaces) {
  const int32_t a = mesh.region[f / 6], b = mesh.region[g / 6];
  if (a < b) {
    interfaces.emplace_back(a, b, f);
  } else {
    interfaces.emplace_back(b, a, g);
  }
}

}  // namespace

MatchedFaces match_faces(const HexMesh& mesh) {
  const std::size_t m = mesh.hexes.size();
  struct Slice {
    std::vector<std::uint32_t> open;  // faces left unmatched
    std::vector<InterfaceFace> interfaces;
    // The range of its hexes' corner indices, and of the slices after it.
    std::uint32_t lowest = kNone, highest = 0;
    std::uint32_t later_lowest = kNone, later_highest = 0;
  };
  std::vector<Slice> slices(kSlices);
  TablePool tables;
  parallel_chunks(kSlices, 1, [&](std::size_t begin, std::size_t end) {
    for (std::size_t s = begin; s < end; ++s) {
      std::unique_ptr<OpenFaces> table = tables.take(kSliceHash);
      // The keys of a hex's faces are made kAhead hexes early and their home slots prefetched:
      // the table outgrows the core's cache, and the probes are independent until they reach it.
      constexpr std::size_t kAhead = 8;
      std::array<std::array<FaceKey, 6>, kAhead> ahead;
      auto prepare = [&](std::size_t h) {
        for (std::uint32_t k = 0; k < 6; ++k) {
          const FaceKey& key = ahead[h % kAhead][k] = face_key(mesh.hexes[h], k);
          table->prefetch(key);
          slices[s].lowest = std::min(slices[s].lowest, key[0]);
          slices[s].highest = std::max(slices[s].highest, key[3]);
        }
      };
      const std::size_t first = m * s / kSlices, last = m * (s + 1) / kSlices;
      for (std::size_t h = first; h < std::min(last, first + kAhead); ++h) prepare(h);
      for (std::size_t h = first; h < last; ++h) {
        const std::array<FaceKey, 6> keys = ahead[h % kAhead];
        if (h + kAhead < last) prepare(h + kAhead);
        for (std::uint32_t k = 0; k < 6; ++k) {
          const auto f = static_cast<std::uint32_t>(6 * h + k);
          const std::uint32_t g = table->match(f, keys[k]);
          if (g != kNone && mesh.region[h] != mesh.region[g / 6]) note_interface(mesh, f, g, slices[s].interfaces);
        }
      }
      slices[s].open = table->drain();
      tables.give(std::move(table));
    }
  });

  // The faces the slices left open, matched across slices in slice order. A face whose corners
  // lie outside every later slice's range of corners can meet no partner any more: it is
  // boundary, and leaves the table, which so holds the faces between slices and not the whole
  // boundary (in spatial order, one layer instead of the mesh's surface).
  for (std::size_t s = kSlices - 1; s > 0; --s) {
    slices[s - 1].later_lowest = std::min(slices[s].lowest, slices[s].later_lowest);
    slices[s - 1].later_highest = std::max(slices[s].highest, slices[s].later_highest);
  }
  std::unique_ptr<OpenFaces> table = tables.take(kMergeHash);
  std::vector<InterfaceFace> interfaces;
  MatchedFaces result;
  for (Slice& slice : slices) {
    for (const std::uint32_t f : slice.open) {
      const std::uint32_t g = table->match(f, face_key(mesh, f));
      if (g != kNone && mesh.region[f / 6] != mesh.region[g / 6]) note_interface(mesh, f, g, interfaces);
    }
    table->retire([&](const FaceKey& key) { return key[0] >= slice.later_lowest && key[3] <= slice.later_highest; },
                  result.boundary);
    interfaces.insert(interfaces.end(), slice.interfaces.begin(), slice.interfaces.end());
    slice.open = {};
    slice.interfaces = {};
  }
  const std::vector<std::uint32_t> rest = table->drain();
  result.boundary.insert(result.boundary.end(), rest.begin(), rest.end());
  std::sort(interfaces.begin(), interfaces.end());
  for (const auto& [lower, upper, face] : interfaces) {
    if (result.interfaces.empty() || result.interfaces.back().lower != lower || result.interfaces.back().upper != upper)
      result.interfaces.push_back({lower, upper, {}});
    result.interfaces.back().faces.push_back(face);
  }
  return result;
}

}  // namespace mchex::io_detail
