// Making a backend by name and listing every device each backend finds.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/device/backend.h"

namespace mchex {

// "cpu", "opencl", "vulkan" or "auto" (the first GPU device with fp64 found by OpenCL or Vulkan,
// else cpu). Throws InputError (exit 1, one line) for an unknown name or a backend asked for by name
// that has no device here.
std::unique_ptr<Backend> make_backend(const std::string& name);

// Every platform and device each backend finds (for `mchex-gpu devices`).
std::vector<DeviceInfo> list_devices();

}  // namespace mchex
