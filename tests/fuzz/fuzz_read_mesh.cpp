// libFuzzer target for the hex mesh readers (MEDIT .mesh and .meshb, VTK XML .vtu, Gmsh 4.1 .msh
// ascii and binary, Abaqus .inp, Exodus II .exo): any bytes under any of those extensions must give
// a mesh whose every index
// is in range and whose labels match its hexes, or an InputError of one line of printable UTF-8; never a crash, a hang
// or an allocation out of proportion to the input. Built with -DMCHEX_FUZZ=ON and clang (.ci/sanitize.sh). An .exo in
// the netCDF-4 (HDF5) layout is skipped: libexodusii and HDF5 read it, not code of ours.
#include <unistd.h>

#include <cstdint>
#include <fstream>
#include <string>
#include <string_view>

#include "core/base/error.h"
#include "core/io/mesh_io.h"
#include "core/io/surface_text.h"
#include "core/mesh/hex_mesh.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  // The first byte picks the format, the rest is the file.
  static const char* const kExtensions[] = {".mesh", ".vtu", ".msh", ".meshb", ".inp", ".exo"};
  constexpr unsigned kFormats = sizeof kExtensions / sizeof kExtensions[0];
  if (std::string_view(kExtensions[data[0] % kFormats]) == ".exo" && size >= 5 && data[1] == 0x89 && data[2] == 'H')
    return 0;
  const std::string path = "/dev/shm/mchex_fuzz_mesh_" + std::to_string(getpid()) + kExtensions[data[0] % kFormats];
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(data + 1), std::streamsize(size - 1));
  try {
    const mchex::HexMesh m = mchex::read_hex_mesh(path);
    if (m.region.size() != m.hexes.size()) __builtin_trap();
    for (const mchex::Hex& h : m.hexes)
      for (const uint32_t v : h)
        if (v >= m.points.size()) __builtin_trap();
  } catch (const mchex::InputError& e) {
    // One line of printable, valid UTF-8: what one_line leaves as it is.
    if (mchex::io_detail::one_line(e.what()) != e.what()) __builtin_trap();
  }
  unlink(path.c_str());
  return 0;
}
