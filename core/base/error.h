// Errors a user can act on. Core code throws these; the CLI prints what() as one stderr line and
// exits with exit_code(): 1 for bad input or usage, 2 for a resource limit (docs/pipeline.md).
#pragma once

#include <stdexcept>
#include <string>

namespace mchex {

struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct ResourceError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace mchex
