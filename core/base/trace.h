// The run's timeline for `mesh --trace FILE.json` (docs/trace.md): complete events (Chrome
// trace-event format, phase "X") for every pipeline stage (StageClock records them) and every
// kernel dispatch, upload and download a backend makes, with their sizes in `args`.
//
// Off unless start() was called: then enabled() is one relaxed atomic load and Span does no more,
// so an untraced run pays nothing measurable. Events from any thread are recorded under one
// mutex; their times are microseconds of the steady clock since start(), the clock StageClock
// uses, so stage and backend events line up.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace mchex::trace {

using Clock = std::chrono::steady_clock;

// The categories the timeline uses ("cat" in the file).
inline constexpr const char* kStage = "stage";
inline constexpr const char* kDispatch = "dispatch";
inline constexpr const char* kUpload = "upload";
inline constexpr const char* kDownload = "download";

struct Event {
  std::string name, category;
  Clock::time_point start;
  Clock::duration duration;
  std::uint32_t thread;  // a small id per recording thread, in order of first event
  nlohmann::json args;
};

namespace detail {
extern std::atomic<bool> enabled;
}

inline bool enabled() { return detail::enabled.load(std::memory_order_relaxed); }

// Clears the events and starts recording; the origin of the file's timestamps is now.
void start();
// Stops recording; the events are kept for to_json().
void stop();

void record(std::string name, const char* category, Clock::time_point start, Clock::time_point end,
            nlohmann::json args = nlohmann::json::object());

// Records [construction, destruction) as one event; add args meanwhile with arg().
class Span {
 public:
  Span(const char* name, const char* category) : on_(enabled()) {
    if (on_) {
      name_ = name;
      category_ = category;
      start_ = Clock::now();
    }
  }
  Span(const Span&) = delete;
  Span& operator=(const Span&) = delete;
  ~Span() {
    if (on_) record(name_, category_, start_, Clock::now(), std::move(args_));
  }
  template <class T>
  void arg(const char* key, T&& value) {
    if (on_) args_[key] = std::forward<T>(value);
  }

 private:
  bool on_;
  const char* name_ = nullptr;
  const char* category_ = nullptr;
  Clock::time_point start_;
  nlohmann::json args_ = nullptr;
};

// A copy of the events so far, in the order they ended.
std::vector<Event> events();

// {"traceEvents": [...], "displayTimeUnit": "ms", "otherData": {...}}: Perfetto and
// chrome://tracing read it. `pid` is this process; `metadata` goes into otherData.
nlohmann::json to_json(const nlohmann::json& metadata = nlohmann::json::object());

}  // namespace mchex::trace
