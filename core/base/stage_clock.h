// Per-stage wall times and the progress lines of long stages, plus the process facts the JSON
// report carries (docs/pipeline.md, "The report").
#pragma once

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace mchex {

class StageClock {
 public:
  explicit StageClock(bool quiet) : quiet_(quiet) {}
  // Runs f as the named stage. A stage still running after a second says so on stderr, and
  // when it ends how long it took (unless quiet); short stages print nothing.
  template <class F>
  decltype(auto) run(const std::string& name, F&& f) {
    struct Done {
      StageClock* self;
      const std::string& name;
      std::chrono::steady_clock::time_point t0;
      ProgressWatch watch;
      ~Done() {
        const bool announced = watch.stop();
        self->finish(name, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), announced);
      }
    } done{this, name, std::chrono::steady_clock::now(), ProgressWatch(quiet_ ? "" : name)};
    return f();
  }
  nlohmann::json to_json() const;
  double total() const;
  // Seconds the named stage took (the sum, if it ran more than once; 0 if it never ran).
  double seconds(const std::string& name) const;

 private:
  // Prints "mchex-gpu: NAME ..." from a helper thread once NAME has run for a second.
  class ProgressWatch {
   public:
    explicit ProgressWatch(std::string name);
    ~ProgressWatch();
    ProgressWatch(ProgressWatch&&) = delete;
    bool stop();  // true when the line was printed

   private:
    struct State;
    std::unique_ptr<State> state_;
  };
  void finish(const std::string& name, double seconds, bool announced);
  bool quiet_;
  std::vector<std::pair<std::string, double>> stages_;
};

// Peak resident memory of this process in bytes.
std::size_t peak_memory_bytes();

// CPU seconds of the whole process (all threads). On a shared machine wall time depends on the
// other users' load, CPU time much less: the benchmarks report both.
double cpu_seconds();

}  // namespace mchex
