#include "core/base/stage_clock.h"

#include <sys/resource.h>
#include <time.h>

#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <thread>

namespace mchex {

struct StageClock::ProgressWatch::State {
  std::string name;
  std::mutex mutex;
  std::condition_variable done;
  bool stopped = false, announced = false;
  std::thread thread;
};

StageClock::ProgressWatch::ProgressWatch(std::string name) : state_(std::make_unique<State>()) {
  if (name.empty()) return;
  state_->name = std::move(name);
  state_->thread = std::thread([s = state_.get()] {
    std::unique_lock lock(s->mutex);
    if (!s->done.wait_for(lock, std::chrono::seconds(1), [s] { return s->stopped; })) {
      std::fprintf(stderr, "mchex-gpu: %s ...\n", s->name.c_str());
      s->announced = true;
    }
  });
}

bool StageClock::ProgressWatch::stop() {
  if (!state_->thread.joinable()) return false;
  {
    std::lock_guard lock(state_->mutex);
    state_->stopped = true;
  }
  state_->done.notify_one();
  state_->thread.join();
  return state_->announced;
}

StageClock::ProgressWatch::~ProgressWatch() { stop(); }

void StageClock::finish(const std::string& name, double seconds, bool announced) {
  stages_.emplace_back(name, seconds);
  if (announced) std::fprintf(stderr, "mchex-gpu: %s done in %.1f s\n", name.c_str(), seconds);
}

nlohmann::json StageClock::to_json() const {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [name, seconds] : stages_) j[name] = seconds;
  j["total"] = total();
  return j;
}

double StageClock::total() const {
  double t = 0;
  for (const auto& s : stages_) t += s.second;
  return t;
}

double StageClock::seconds(const std::string& name) const {
  double t = 0;
  for (const auto& s : stages_)
    if (s.first == name) t += s.second;
  return t;
}

std::size_t peak_memory_bytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return std::size_t(usage.ru_maxrss) * 1024;  // Linux reports kilobytes
}

double cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

}  // namespace mchex
