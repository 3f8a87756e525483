#include "host/backends/registry.h"

#include "core/base/error.h"
#include "host/backends/cpu.h"
#if MCHEX_WITH_OPENCL
#include "host/backends/opencl.h"
#endif
#if MCHEX_WITH_VULKAN
#include "host/backends/vulkan.h"
#endif

namespace mchex {

#if !MCHEX_WITH_OPENCL || !MCHEX_WITH_VULKAN
namespace {

// A backend configured out (CMake MCHEX_WITH_OPENCL / MCHEX_WITH_VULKAN OFF): its name is still
// known, so asking for it says why it cannot run here instead of "unknown backend".
[[noreturn]] void not_built(const std::string& name, const char* option) {
  throw InputError("backend '" + name + "' is not built into this binary (configured with -D" + option + "=OFF)");
}

// The device list's entry for a backend configured out: `devices` says so (tests skip on it).
DeviceInfo not_built_entry(const std::string& name, const char* option) {
  DeviceInfo d;
  d.backend = name;
  d.note = std::string("not built into this binary (-D") + option + "=OFF)";
  return d;
}

}  // namespace
#endif

std::unique_ptr<Backend> make_backend(const std::string& name) {
  if (name == "cpu") return make_cpu_backend();
  if (name == "opencl") {
#if MCHEX_WITH_OPENCL
    return std::make_unique<OpenclBackend>();
#else
    not_built(name, "MCHEX_WITH_OPENCL");
#endif
  }
  if (name == "vulkan") {
#if MCHEX_WITH_VULKAN
    return std::make_unique<VulkanBackend>();
#else
    not_built(name, "MCHEX_WITH_VULKAN");
#endif
  }
  if (name == "auto") return make_backend(auto_backend_choice());
  throw InputError("unknown backend '" + name + "' (known: auto, cpu, opencl, vulkan)");
}

std::string auto_backend_choice() {
  // A GPU with fp64 is worth the transfers; a CPU driver (PoCL, lavapipe) is not faster than
  // the reference on the same cores, so auto keeps the reference there.
#if MCHEX_WITH_OPENCL
  for (const DeviceInfo& d : list_opencl_devices())
    if (d.type == "gpu" && d.fp64) return "opencl";
#endif
#if MCHEX_WITH_VULKAN
  for (const DeviceInfo& d : list_vulkan_devices())
    if (d.type == "gpu" && d.fp64 && d.note.empty()) return "vulkan";
#endif
  return "cpu";
}

std::vector<std::string> built_backend_names() {
  std::vector<std::string> names{"auto", "cpu"};
  if (MCHEX_WITH_OPENCL) names.emplace_back("opencl");
  if (MCHEX_WITH_VULKAN) names.emplace_back("vulkan");
  return names;
}

std::vector<DeviceInfo> list_devices() {
  std::vector<DeviceInfo> out{make_cpu_backend()->device()};
#if MCHEX_WITH_OPENCL
  for (DeviceInfo& d : list_opencl_devices()) out.push_back(std::move(d));
#else
  out.push_back(not_built_entry("opencl", "MCHEX_WITH_OPENCL"));
#endif
#if MCHEX_WITH_VULKAN
  for (DeviceInfo& d : list_vulkan_devices()) out.push_back(std::move(d));
#else
  out.push_back(not_built_entry("vulkan", "MCHEX_WITH_VULKAN"));
#endif
  return out;
}

}  // namespace mchex
