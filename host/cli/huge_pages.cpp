// Transparent huge pages for the command line's large allocations.
//
// The mesher's arrays (grid values, cells, hexes, points, face keys) are large, written once and
// read a few times, so much of a big run is the kernel faulting their pages in. In a virtual
// machine every 4 KiB fault traps to the hypervisor: measured on this project's 2-core VM, the
// fault path was 20 % of a 4.4 M-hex `mesh --depth 4` and the run took 1.8x as long as with
// 2 MiB pages. Where transparent huge pages are in "madvise" mode (Debian's and Ubuntu's
// default), only ranges advised with MADV_HUGEPAGE get them, so the replaceable global operator
// new (C++ [new.delete.single]) advises the 2 MiB-aligned inside of every block of at least
// kHugeBlock bytes, as glibc's own glibc.malloc.hugetlb=1 tunable would for the whole heap. The
// block still comes from malloc (aligned_alloc for the over-aligned forms, as libstdc++'s own),
// so the default operator delete (free) releases it; smaller blocks are untouched. Advice is a
// hint: where it is refused or huge pages are off, nothing changes. Only this executable replaces
// operator new: the libraries, the Python module and programs that link the installed package
// keep their own allocator.
//
// Blocks under kHugeBlock come from glibc's heap, which operator new cannot advise in time: malloc
// has written the chunk headers around a block (faulting those 4 KiB pages in) before it returns,
// and a 2 MiB range with a 4 KiB page in it is no longer filled by one huge page. Only glibc can
// advise its heap as it grows, and it reads that choice (the glibc.malloc.hugetlb tunable) from
// the environment at start-up alone; so restart_with_heap_tunables() sets it and starts the
// program again (huge_pages.h).
#include "host/cli/huge_pages.h"

#include <bit>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <new>
#include <string>

#include <sys/mman.h>
#include <unistd.h>

namespace {

constexpr std::size_t kHugePage = std::size_t(2) << 20;
// Twice the huge page: such a block always holds at least one whole aligned huge page.
constexpr std::size_t kHugeBlock = 2 * kHugePage;

void advise_huge_pages(void* block, std::size_t size) {
  const std::uintptr_t begin = (std::uintptr_t(block) + kHugePage - 1) & ~(kHugePage - 1);
  const std::uintptr_t end = (std::uintptr_t(block) + size) & ~(kHugePage - 1);
  if (begin < end) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
}

void* allocate(std::size_t size) noexcept {
  void* block = std::malloc(size ? size : 1);
  if (block && size >= kHugeBlock) advise_huge_pages(block, size);
  return block;
}

// Over-aligned types (the SDF search tree's 64-byte nodes and leaves) come through the aligned
// forms: as libstdc++'s own, aligned_alloc with the size rounded up to the alignment, which its
// aligned operator delete frees. Without them the search tree over a mesh boundary faulted its
// leaves in at 4 KiB: 0.1 s of each fidelity round's 0.35 s on the npm bunny.
void* allocate(std::size_t size, std::align_val_t alignment) noexcept {
  const auto align = static_cast<std::size_t>(alignment);
  if (size > std::numeric_limits<std::size_t>::max() - (align - 1)) return nullptr;  // no rounding up
  const std::size_t rounded = ((size ? size : 1) + align - 1) & ~(align - 1);
  void* block = std::aligned_alloc(align, rounded);
  if (block && rounded >= kHugeBlock) advise_huge_pages(block, rounded);
  return block;
}

// As the standard's: on failure the new-handler runs and the allocation is tried again; with
// none, std::bad_alloc.
template <class Allocate>
void* allocate_or_throw(const Allocate& allocate_once) {
  for (;;) {
    if (void* block = allocate_once()) return block;
    const std::new_handler handler = std::get_new_handler();
    if (!handler) throw std::bad_alloc();
    handler();
  }
}

}  // namespace

void* operator new(std::size_t size) {
  return allocate_or_throw([size] { return allocate(size); });
}

void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  try {
    return ::operator new(size);
  } catch (...) {
    return nullptr;
  }
}

void* operator new(std::size_t size, std::align_val_t alignment) {
  // As libstdc++'s: an alignment that is not a power of two is an allocation failure, at once.
  if (!std::has_single_bit(static_cast<std::size_t>(alignment))) throw std::bad_alloc();
  return allocate_or_throw([size, alignment] { return allocate(size, alignment); });
}

void* operator new(std::size_t size, std::align_val_t alignment, const std::nothrow_t&) noexcept {
  try {
    return ::operator new(size, alignment);
  } catch (...) {
    return nullptr;
  }
}

namespace mchex::cli {

namespace {

// Whether the kernel gives huge pages to advised ranges ("[always]" or "[madvise]" selected).
bool transparent_huge_pages_usable() {
  std::ifstream in("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string modes;
  std::getline(in, modes);
  return modes.find("[always]") != std::string::npos || modes.find("[madvise]") != std::string::npos;
}

}  // namespace

void restart_with_heap_tunables(char** argv) {
#ifdef __GLIBC__
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  // Set already: by this restart (the process is the restarted one) or by the user, whose choice
  // stands.
  if (tunables && std::strstr(tunables, "glibc.malloc.hugetlb")) return;
  if (!transparent_huge_pages_usable()) return;
  // hugetlb=1: glibc advises its heap (and aligns its growth) to 2 MiB pages. mmap_threshold:
  // blocks from kHugeBlock up are mapped on their own (advised by operator new above, returned to
  // the system when freed); smaller ones come from the heap, whose freed memory trim_threshold
  // keeps for the next stage instead of returning it to be faulted in again, and which top_pad
  // grows 8 MiB at a time. Measured on the bumpy torus at depth 4 (4.36 M hexes, this project's
  // 2-core VM): page faults 67k -> 13k, system time 1.1-1.5 s -> 0.3-0.5 s, wall 2.9-3.8 s ->
  // 2.3-2.7 s (with a 64 MiB top_pad; 8 MiB: 32-38k faults, the same wall time within the
  // noise, and 5 to 20 MiB less peak memory on the default runs: docs/pipeline.md).
  std::string value = tunables && *tunables ? std::string(tunables) + ":" : std::string();
  value += "glibc.malloc.hugetlb=1:glibc.malloc.mmap_threshold=" + std::to_string(kHugeBlock) +
           ":glibc.malloc.top_pad=" + std::to_string(std::size_t(8) << 20) +
           ":glibc.malloc.trim_threshold=" + std::to_string(std::size_t(1) << 30);
  if (setenv("GLIBC_TUNABLES", value.c_str(), 1) != 0) return;
  execv("/proc/self/exe", argv);
  // Not restarted (no /proc, say): run as we are, and keep the environment as it was for any
  // child.
  if (tunables) {
    setenv("GLIBC_TUNABLES", tunables, 1);
  } else {
    unsetenv("GLIBC_TUNABLES");
  }
#else
  (void)argv;
#endif
}

}  // namespace mchex::cli
