#include "host/backend.h"

#include "core/device_scene.h"
#include "core/error.h"
#include "host/backend_cpu.h"
#include "host/backend_opencl.h"
#include "host/backend_vulkan.h"

namespace mchex {

CellCode encode_cell(const CellClass& c) {
  CellCode out;
  out.subcase = c.subcase;
  out.sign_mask = c.sign_mask;
  out.face_joins = c.face_joins;
  out.tunnel = c.tunnel;
  out.symmetry = c.symmetry;
  out.inverted = c.inverted ? 1 : 0;
  out.cut_edges = c.cut_edges;
  return out;
}

CellCode decode_cell_words(std::uint32_t w0, std::uint32_t w1) {
  CellCode out;
  out.subcase = static_cast<Subcase>(w0 & 0xFF);
  out.sign_mask = static_cast<std::uint8_t>(w0 >> kCodeSignShift);
  out.face_joins = static_cast<std::uint8_t>(w0 >> kCodeFaceShift & 0x3F);
  out.tunnel = static_cast<std::int8_t>(int(w0 >> kCodeTunnelShift & 3) - 1);
  out.inverted = static_cast<std::uint8_t>(w0 >> kCodeInvertedShift & 1);
  out.symmetry = static_cast<std::uint8_t>(w1 & 0xFF);
  out.cut_edges = static_cast<std::uint16_t>(w1 >> kCodeCutShift);
  return out;
}

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
