#include "core/base/stage_clock.h"

#include "core/base/trace.h"

#include <sys/resource.h>
#include <time.h>

#include <algorithm>
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

void StageClock::finish(const std::string& name, std::chrono::steady_clock::time_point t0,
                        std::chrono::steady_clock::time_point t1, bool announced) {
  const double seconds = std::chrono::duration<double>(t1 - t0).count();
  stages_.emplace_back(name, seconds);
  if (trace::enabled()) {
    if (t0 > end_) trace::record("other", trace::kStage, end_, t0);
    trace::record(name, trace::kStage, t0, t1);
  }
  end_ = std::max(end_, t1);
  if (announced) std::fprintf(stderr, "mchex-gpu: %s done in %.1f s\n", name.c_str(), seconds);
}

nlohmann::json StageClock::to_json() const {
  // A stage that ran more than once (sdf, mchex and fidelity in the remedy and fit rounds) is
  // their sum, so that the stages and "other" add up to "total".
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [name, seconds] : stages_) j[name] = j.value(name, 0.0) + seconds;
  const double wall = total();
  j["other"] = std::max(0.0, wall - stage_seconds());
  j["total"] = wall;
  return j;
}

double StageClock::total() const { return std::chrono::duration<double>(end_ - start_).count(); }

double StageClock::stage_seconds() const {
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
