// The one thin layer through which the mesher runs data-parallel loops (Manifold's for_each idea):
// every stage calls these over index ranges, so threading policy lives here and nowhere else.
// Results never depend on the thread count: each index writes only its own outputs.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <mutex>
#include <numeric>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>
#include <tbb/task_arena.h>

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

// Sorts [begin, end) on all threads (not stable: callers sort by a key that makes the order unique).
template <class It>
void parallel_sort(It begin, It end) {
  tbb::parallel_sort(begin, end);
}
template <class It, class Less>
void parallel_sort(It begin, It end, const Less& less) {
  tbb::parallel_sort(begin, end, less);
}

// Sum-like reduction over [0, n): f(begin, end, partial) returns the partial result extended by a
// chunk, join combines two partials. Only for exact (integer) results: the split depends on the
// threads.
template <class T, class F, class Join>
T parallel_reduce(std::size_t n, std::size_t grain, T identity, const F& f, const Join& join) {
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, grain ? grain : 1), identity,
      [&](const tbb::blocked_range<std::size_t>& r, T partial) { return f(r.begin(), r.end(), std::move(partial)); },
      join);
}

// Deterministic reduction over [0, n): leaves of `grain` indices each fill an Acc (copied from
// `proto`) through f(begin, end, acc), joined left to right with Acc::join. The split is fixed by
// n and grain alone, so floating-point sums do not depend on the thread count.
template <class Acc, class F>
Acc deterministic_reduce(std::size_t n, std::size_t grain, const Acc& proto, const F& f) {
  struct Body {
    const F* f;
    const Acc* proto;
    Acc acc;
    Body(const F& fn, const Acc& p) : f(&fn), proto(&p), acc(p) {}
    Body(Body& other, tbb::split) : f(other.f), proto(other.proto), acc(*other.proto) {}
    void operator()(const tbb::blocked_range<std::size_t>& r) { (*f)(r.begin(), r.end(), acc); }
    void join(Body& rhs) { acc.join(std::move(rhs.acc)); }
  } body(f, proto);
  if (n > 0) tbb::parallel_deterministic_reduce(tbb::blocked_range<std::size_t>(0, n, grain ? grain : 1), body);
  return std::move(body.acc);
}

// Items [0, count) made on all threads and consumed in order on one: make(i) returns item i,
// consume(item) takes them 0, 1, 2, ... At most a few items per thread are alive at once, so a
// writer formats a large table in bounded memory. An exception from make or consume is rethrown
// here after the pipeline has drained: one thrown inside TBB's pipeline cancels it and abandons
// the items between its filters undestroyed (a leak AddressSanitizer found on a failed write), so
// the filters never throw; after the first failure the input stops and items in flight are
// dropped.
template <class Make, class Consume>
void ordered_pipeline(std::size_t count, const Make& make, const Consume& consume) {
  using Item = decltype(make(std::size_t{0}));
  if (count == 0) return;
  std::mutex failure_mutex;
  std::exception_ptr failure;
  std::atomic<bool> failed{false};
  auto record = [&] {
    const std::lock_guard<std::mutex> lock(failure_mutex);
    if (!failure) failure = std::current_exception();
    failed.store(true);
  };
  std::size_t next = 0;
  const auto live = static_cast<std::size_t>(2 * std::max(1, tbb::this_task_arena::max_concurrency()));
  tbb::parallel_pipeline(
      live,
      tbb::make_filter<void, std::size_t>(tbb::filter_mode::serial_in_order, [&](tbb::flow_control& fc) -> std::size_t {
        if (next == count || failed.load()) {
          fc.stop();
          return 0;
        }
        return next++;
      }) & tbb::make_filter<std::size_t, Item>(tbb::filter_mode::parallel, [&](std::size_t i) -> Item {
        if (failed.load()) return Item{};
        try {
          return make(i);
        } catch (...) {
          record();
          return Item{};
        }
      }) & tbb::make_filter<Item, void>(tbb::filter_mode::serial_in_order, [&](const Item& item) {
        if (failed.load()) return;
        try {
          consume(item);
        } catch (...) {
          record();
        }
      }));
  if (failure) std::rethrow_exception(failure);
}

// Threads: what the machine offers, and a scope that runs at most n (n >= 1) while it lives.
inline int hardware_threads() { return tbb::info::default_concurrency(); }
class ThreadLimit {
 public:
  explicit ThreadLimit(int n) : control_(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(n)) {}

 private:
  tbb::global_control control_;
};

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
