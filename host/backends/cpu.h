// The cpu backend: core/'s reference implementations behind core/device/backend.h (Embree + TBB, double
// precision). Every other backend is tested against it.
#pragma once

#include <memory>

#include "core/device/backend.h"

namespace mchex {

std::unique_ptr<Backend> make_cpu_backend();

}  // namespace mchex
