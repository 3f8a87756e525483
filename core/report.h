// Per-stage wall times and the progress lines of long stages, plus the process facts the JSON
// report carries (DESIGN.md "Report JSON").
#pragma once

#include <chrono>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace mchex {

class StageClock {
 public:
  explicit StageClock(bool quiet) : quiet_(quiet) {}
  // Runs f as the named stage; a stage that takes more than a second leaves one progress line
  // on stderr (unless quiet).
  template <class F>
  decltype(auto) run(const std::string& name, F&& f) {
    const auto t0 = std::chrono::steady_clock::now();
    struct Done {
      StageClock* self;
      const std::string& name;
      std::chrono::steady_clock::time_point t0;
      ~Done() { self->finish(name, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()); }
    } done{this, name, t0};
    return f();
  }
  nlohmann::json to_json() const;
  double total() const;

 private:
  void finish(const std::string& name, double seconds);
  bool quiet_;
  std::vector<std::pair<std::string, double>> stages_;
};

// Peak resident memory of this process in bytes.
std::size_t peak_memory_bytes();

}  // namespace mchex
