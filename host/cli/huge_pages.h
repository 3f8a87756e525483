// The command line's memory set-up (huge_pages.cpp): transparent huge pages for its large blocks
// through a replaced global operator new, and for glibc's heap through its tunables.
#pragma once

namespace mchex::cli {

// Starts this program again (execv of /proc/self/exe, the same arguments) with glibc's malloc
// tunables set for huge pages on its heap, unless GLIBC_TUNABLES already names
// glibc.malloc.hugetlb (the restarted process, or the user's own choice), the kernel gives no
// transparent huge pages, or the C library is not glibc. Returns only when it did not restart.
// Call it first in main: nothing done before it survives the restart.
void restart_with_heap_tunables(char** argv);

}  // namespace mchex::cli
