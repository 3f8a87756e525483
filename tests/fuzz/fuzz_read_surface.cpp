// libFuzzer target for the surface reader: any bytes under any of the four extensions must give
// a surface with triangles and finite coordinates, or an InputError of one line of printable UTF-8; never a crash,
// a hang or an allocation out of proportion to the input. Built with -DMCHEX_FUZZ=ON and clang;
// .ci/sanitize.sh seeds and runs it.
#include <unistd.h>

#include <cstdint>
#include <fstream>
#include <string>

#include "core/base/error.h"
#include "core/io/surface_io.h"
#include "core/io/surface_text.h"
#include "core/mesh/surface.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  // The first byte picks the format, the rest is the file.
  static const char* const kExtensions[] = {".stl", ".obj", ".off", ".ply"};
  const std::string path = "/dev/shm/mchex_fuzz_" + std::to_string(getpid()) + kExtensions[data[0] % 4];
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(data + 1), std::streamsize(size - 1));
  try {
    std::size_t welded = 0;
    const mchex::TriangleSurface s = mchex::read_surface(path, &welded);
    if (mchex::validate_surface(s, welded).triangles == 0) __builtin_trap();
    for (const mchex::Vec3& v : s.vertices)
      if (!mchex::is_finite(v)) __builtin_trap();
  } catch (const mchex::InputError& e) {
    // One line of printable, valid UTF-8: what one_line leaves as it is.
    if (mchex::io_detail::one_line(e.what()) != e.what()) __builtin_trap();
  }
  unlink(path.c_str());
  return 0;
}
