// Exact-coordinate lookup of points: which point of a set has exactly these coordinates. The
// inside and outside meshes write their shared interface points bit for bit alike, so this is
// how the check, the optimiser and the snap find an interface point's twin.
#pragma once

#include <algorithm>
#include <atomic>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/base/geometry.h"
#include "core/base/parallel.h"

namespace mchex {

// Open addressing with linear probing over 32-bit point indices, filled in parallel with compare-and-swap. Points with
// equal coordinates keep the smallest index, so the table does not depend on thread timing. -0 and +0 compare equal and
// hash alike; non-finite points are left out.
class PointIndex {
 public:
  static constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();

  // Indexes `points`, which must outlive the index.
  explicit PointIndex(const std::vector<Vec3>& points) : points_(points) {
    const std::size_t capacity = std::bit_ceil(std::max<std::size_t>(2 * points.size(), 16));
    slots_.assign(capacity, kNone);
    mask_ = capacity - 1;
    parallel_chunks(points.size(), 4096, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) {
        if (is_finite(points[i])) insert(static_cast<uint32_t>(i));
      }
    });
    for (const Vec3& p : points)
      if (is_finite(p)) box_.extend(p);
  }

  // The smallest index of a point with p's coordinates, or kNone.
  uint32_t find(Vec3 p) const {
    // Most of an outside mesh lies beyond the inside mesh's box: no hashing, no probe (whose
    // table and points miss the cache) for those. -0 and +0 compare equal here too.
    if (!box_.contains(p)) return kNone;
    for (std::size_t s = hash(p) & mask_;; s = (s + 1) & mask_) {
      const uint32_t i = slots_[s];
      if (i == kNone || points_[i] == p) return i;
    }
  }

 private:
  static uint64_t bits(double x) { return std::bit_cast<uint64_t>(x == 0 ? 0.0 : x); }
  // splitmix64 finalizer over the combined bit patterns.
  static uint64_t mix(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  static std::size_t hash(Vec3 p) { return static_cast<std::size_t>(mix(bits(p.x) + mix(bits(p.y) + mix(bits(p.z))))); }

  void insert(uint32_t i) {
    const Vec3 p = points_[i];
    for (std::size_t s = hash(p) & mask_;; s = (s + 1) & mask_) {
      std::atomic_ref<uint32_t> slot(slots_[s]);
      uint32_t cur = slot.load(std::memory_order_relaxed);
      while (true) {
        if (cur == kNone) {
          if (slot.compare_exchange_weak(cur, i, std::memory_order_relaxed)) return;
          continue;
        }
        if (!(points_[cur] == p)) break;  // another point: probe on
        if (cur <= i || slot.compare_exchange_weak(cur, i, std::memory_order_relaxed)) return;
      }
    }
  }

  const std::vector<Vec3>& points_;
  std::vector<uint32_t> slots_;
  std::size_t mask_ = 0;
  Box box_;  // of the finite points
};

}  // namespace mchex
