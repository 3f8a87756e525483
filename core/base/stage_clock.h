// Per-stage wall times and the progress lines of long stages, plus the process facts the JSON
// report carries (docs/pipeline.md, "The report").
//
// The clock's wall time runs from its construction to the end of its last stage. Stages run one
// after another (never nested), so the time between them (opening a backend, the memory budget's
// estimate) is the stage "other": the report's stages sum to the wall time (docs/trace.md). With
// a trace on (core/base/trace.h) each stage and each gap is also an event of the timeline.
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
        self->finish(name, t0, std::chrono::steady_clock::now(), announced);
      }
    } done{this, name, std::chrono::steady_clock::now(), ProgressWatch(quiet_ ? "" : name)};
    return f();
  }
  // {"STAGE": seconds (summed over its runs), ..., "other": the gaps, "total": the wall time}.
  nlohmann::json to_json() const;
  // The wall time: the stages and the gaps between them.
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
  void finish(const std::string& name, std::chrono::steady_clock::time_point t0,
              std::chrono::steady_clock::time_point t1, bool announced);
  double stage_seconds() const;
  bool quiet_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now(), end_ = start_;
  std::vector<std::pair<std::string, double>> stages_;
};

// Peak resident memory of this process in bytes.
std::size_t peak_memory_bytes();

// CPU seconds of the whole process (all threads). On a shared machine wall time depends on the
// other users' load, CPU time much less: the benchmarks report both.
double cpu_seconds();

}  // namespace mchex
