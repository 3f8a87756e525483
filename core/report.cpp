#include "core/report.h"

#include <sys/resource.h>

#include <cstdio>

namespace mchex {

void StageClock::finish(const std::string& name, double seconds) {
  stages_.emplace_back(name, seconds);
  if (!quiet_ && seconds > 1.0) std::fprintf(stderr, "mchex-gpu: %s took %.1f s\n", name.c_str(), seconds);
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

std::size_t peak_memory_bytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return std::size_t(usage.ru_maxrss) * 1024;  // Linux reports kilobytes
}

}  // namespace mchex
