#include "host/backends/registry.h"

#include "core/base/error.h"
#include "host/backends/cpu.h"
#include "host/backends/opencl.h"
#include "host/backends/vulkan.h"

namespace mchex {

std::unique_ptr<Backend> make_backend(const std::string& name) {
  if (name == "cpu") return make_cpu_backend();
  if (name == "opencl") return std::make_unique<OpenclBackend>();
  if (name == "vulkan") return std::make_unique<VulkanBackend>();
  if (name == "auto") {
    // A GPU with fp64 is worth the transfers; a CPU driver (PoCL, lavapipe) is not faster than
    // the reference on the same cores, so auto keeps the reference there.
    for (const DeviceInfo& d : list_opencl_devices())
      if (d.type == "gpu" && d.fp64) return std::make_unique<OpenclBackend>();
    for (const DeviceInfo& d : list_vulkan_devices())
      if (d.type == "gpu" && d.fp64 && d.note.empty()) return std::make_unique<VulkanBackend>();
    return make_cpu_backend();
  }
  throw InputError("unknown backend '" + name + "' (known: auto, cpu, opencl, vulkan)");
}

std::vector<DeviceInfo> list_devices() {
  std::vector<DeviceInfo> out{make_cpu_backend()->device()};
  for (DeviceInfo& d : list_opencl_devices()) out.push_back(std::move(d));
  for (DeviceInfo& d : list_vulkan_devices()) out.push_back(std::move(d));
  return out;
}

}  // namespace mchex
