#include "core/base/trace.h"

#include <unistd.h>

#include <mutex>

namespace mchex::trace {

namespace detail {
std::atomic<bool> enabled{false};
}

namespace {

struct Recorder {
  std::mutex mutex;
  Clock::time_point origin = Clock::now();
  std::vector<Event> events;
  std::uint32_t threads = 0;
};

Recorder& recorder() {
  static Recorder r;
  return r;
}

// The thread's id in the file: the first recording thread (the pipeline's) is 1.
std::uint32_t thread_id(Recorder& r) {
  thread_local std::uint32_t id = 0;
  if (id == 0) id = ++r.threads;  // under r.mutex
  return id;
}

}  // namespace

void start() {
  Recorder& r = recorder();
  std::lock_guard lock(r.mutex);
  r.events.clear();
  r.origin = Clock::now();
  detail::enabled.store(true, std::memory_order_relaxed);
}

void stop() { detail::enabled.store(false, std::memory_order_relaxed); }

void record(std::string name, const char* category, Clock::time_point start, Clock::time_point end,
            nlohmann::json args) {
  if (!enabled()) return;
  Recorder& r = recorder();
  std::lock_guard lock(r.mutex);
  if (args.is_null()) args = nlohmann::json::object();
  r.events.push_back({std::move(name), category, start, end - start, thread_id(r), std::move(args)});
}

std::vector<Event> events() {
  Recorder& r = recorder();
  std::lock_guard lock(r.mutex);
  return r.events;
}

nlohmann::json to_json(const nlohmann::json& metadata) {
  Recorder& r = recorder();
  std::lock_guard lock(r.mutex);
  const long pid = long(getpid());
  auto us = [](Clock::duration d) { return std::chrono::duration<double, std::micro>(d).count(); };
  nlohmann::json list = nlohmann::json::array();
  list.push_back({{"name", "process_name"}, {"ph", "M"}, {"pid", pid}, {"tid", 0}, {"args", {{"name", "mchex-gpu"}}}});
  for (const Event& e : r.events)
    list.push_back({{"name", e.name},
                    {"cat", e.category},
                    {"ph", "X"},
                    {"ts", us(e.start - r.origin)},
                    {"dur", us(e.duration)},
                    {"pid", pid},
                    {"tid", e.thread},
                    {"args", e.args}});
  return {{"traceEvents", std::move(list)}, {"displayTimeUnit", "ms"}, {"otherData", metadata}};
}

}  // namespace mchex::trace
