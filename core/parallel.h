// The one thin layer through which the mesher runs data-parallel loops (Manifold's for_each idea):
// every stage calls these over index ranges, so threading policy lives here and nowhere else.
// Results never depend on the thread count: each index writes only its own outputs.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <numeric>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace mchex {

// f(begin, end) over consecutive chunks of [0, n); chunks keep neighbouring indices together,
// which the SDF uses for its coherence bound.
template <class F>
void parallel_chunks(std::size_t n, std::size_t grain, F&& f) {
  if (n == 0) return;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain ? grain : 1),
                    [&](const tbb::blocked_range<std::size_t>& r) { f(r.begin(), r.end()); });
}

template <class F>
void parallel_for(std::size_t n, F&& f) {
  parallel_chunks(n, 1024, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) f(i);
  });
}

// Items grouped by a key with a counting sort: items[start[k] .. start[k + 1]) are the items of
// key k, for keys in [0, num_keys). for_each_item(f) calls f(item) once for each item, on any
// threads, and is called twice (count, then place) with the same items. The order inside a
// group depends on the threads; callers that need one sort each group. Memory: 4 bytes per item
// and per key.
struct KeyGroups {
  std::vector<std::uint32_t> start;  // num_keys + 1 offsets
  std::vector<std::uint32_t> items;
};

template <class ForEachItem, class KeyOf>
KeyGroups group_by_key(std::size_t num_keys, const ForEachItem& for_each_item, const KeyOf& key_of) {
  KeyGroups g;
  g.start.assign(num_keys + 1, 0);
  for_each_item([&](std::uint32_t item) {
    std::atomic_ref<std::uint32_t>(g.start[key_of(item)]).fetch_add(1, std::memory_order_relaxed);
  });
  std::inclusive_scan(g.start.begin(), g.start.end() - 1, g.start.begin());
  g.start[num_keys] = num_keys > 0 ? g.start[num_keys - 1] : 0;
  g.items.resize(g.start[num_keys]);
  // Filling each group from its end leaves start[k] at the group's first item.
  for_each_item([&](std::uint32_t item) {
    const std::uint32_t slot =
        std::atomic_ref<std::uint32_t>(g.start[key_of(item)]).fetch_sub(1, std::memory_order_relaxed);
    g.items[slot - 1] = item;
  });
  return g;
}

}  // namespace mchex
