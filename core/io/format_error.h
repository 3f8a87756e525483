// The error a format's reader or writer throws: the reason only, without the path. The public
// functions of mesh_io.h catch it and throw InputError("PATH: reason"), so that every message
// names the file once and the per-format code needs no path.
#pragma once

#include <stdexcept>

namespace mchex::io_detail {

struct FormatError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace mchex::io_detail
