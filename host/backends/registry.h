// Making a backend by name and listing every device each backend finds.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/device/backend.h"

namespace mchex {

// "cpu", "opencl", "vulkan" or "auto" (the first GPU device with fp64 found by OpenCL or Vulkan,
// else cpu). Throws InputError (exit 1, one line) for an unknown name or a backend asked for by name
// that has no device here or is not built into this binary.
std::unique_ptr<Backend> make_backend(const std::string& name);

// What "auto" stands for here: "opencl" or "vulkan" when that backend finds a GPU device with
// fp64 (OpenCL first), else "cpu". Probing loads the drivers into the calling process (on the
// development machine PoCL and lavapipe: about 70 MiB and 0.2 s that stay for its lifetime);
// the command line asks a child process instead (host/cli/mesh_command.cpp).
std::string auto_backend_choice();

// The names make_backend accepts in this binary: "auto", "cpu", then each device backend it was
// built with, so that the command line offers only what can run.
std::vector<std::string> built_backend_names();

// Every platform and device each backend finds (for `mchex-gpu devices`); a backend this binary
// was configured without (CMake MCHEX_WITH_OPENCL / MCHEX_WITH_VULKAN OFF) is one entry with no
// device whose note says "not built into this binary".
std::vector<DeviceInfo> list_devices();

}  // namespace mchex
