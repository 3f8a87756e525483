// mchex-gpu devices: every backend's platforms and devices (host/backends/registry.h), as a table
// or as JSON.
#include <cstdint>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "host/backends/registry.h"
#include "host/cli/commands.h"

namespace mchex::cli {

nlohmann::json devices_json(const std::vector<DeviceInfo>& list) {
  nlohmann::json j = nlohmann::json::array();
  for (const DeviceInfo& d : list)
    j.push_back({{"backend", d.backend},
                 {"platform", d.platform},
                 {"device", d.name},
                 {"type", d.type},
                 {"fp64", d.fp64},
                 {"precision", d.precision},
                 {"max_buffer_bytes", d.max_buffer_bytes},
                 {"global_memory_bytes", d.global_memory_bytes},
                 {"compute_units", d.compute_units ? nlohmann::json(d.compute_units) : nlohmann::json(nullptr)},
                 {"version", d.version},
                 {"usable", d.note.empty()},
                 {"note", d.note}});
  return j;
}

int run_devices(bool as_json) {
  const std::vector<DeviceInfo> list = list_devices();
  if (as_json) {
    fmt::print("{}\n", devices_json(list).dump(2));
    return 0;
  }
  fmt::print("{:<8} {:<30} {:<36} {:<5} {:<4} {:<9} {:>5} {:>12} {:>12}\n", "backend", "platform", "device", "type",
             "fp64", "precision", "units", "max buffer", "memory");
  for (const DeviceInfo& d : list) {
    auto mib = [](std::uint64_t b) { return b ? fmt::format("{} MiB", b >> 20) : std::string("-"); };
    fmt::print("{:<8} {:<30} {:<36} {:<5} {:<4} {:<9} {:>5} {:>12} {:>12}\n", d.backend, d.platform, d.name, d.type,
               d.fp64 ? "yes" : "no", d.precision, d.compute_units ? std::to_string(d.compute_units) : std::string("-"),
               mib(d.max_buffer_bytes), mib(d.global_memory_bytes));
    if (!d.version.empty()) fmt::print("         {}\n", d.version);
    if (!d.note.empty()) fmt::print("         not usable: {}\n", d.note);
  }
  return 0;
}

int run_auto_choice() {
  fmt::print("{}\n", auto_backend_choice());
  return 0;
}

}  // namespace mchex::cli
