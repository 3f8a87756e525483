// What every benchmark shares: wall time of a callable.
#pragma once

#include <chrono>

namespace mchex::bench {

template <class F>
double seconds_of(F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace mchex::bench
