// The one thin layer through which the mesher runs data-parallel loops (Manifold's for_each idea):
// every stage calls these over index ranges, so threading policy lives here and nowhere else.
// Results never depend on the thread count: each index writes only its own outputs.
#pragma once

#include <cstddef>

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

}  // namespace mchex
