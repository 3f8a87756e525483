#include "core/io/mapped_file.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <string>
#include <system_error>

#include "core/io/format_error.h"

namespace mchex::io_detail {
namespace {

std::string errno_message(int e) { return e != 0 ? std::generic_category().message(e) : std::string("I/O error"); }

}  // namespace

MappedFile::MappedFile(const std::filesystem::path& path) : fd_(::open(path.c_str(), O_RDONLY | O_CLOEXEC)) {
  if (fd_ < 0) throw FormatError("cannot open: " + errno_message(errno));
  try {
    map();
  } catch (...) {
    ::close(fd_);
    throw;
  }
}

MappedFile::~MappedFile() {
  if (data_ != nullptr) ::munmap(data_, size_);
  ::close(fd_);
}

void MappedFile::map() {
  struct stat st {};
  if (::fstat(fd_, &st) != 0) throw FormatError("cannot open: " + errno_message(errno));
  // A directory, a device or a pipe has no size to bound the parse by, and may never end.
  if (!S_ISREG(st.st_mode)) throw FormatError("not a regular file");
  size_ = static_cast<std::size_t>(st.st_size);
  if (size_ == 0) return;
#ifdef MAP_POPULATE
  constexpr int kFlags = MAP_PRIVATE | MAP_POPULATE;  // the parse reads every page, in order
#else
  constexpr int kFlags = MAP_PRIVATE;
#endif
  void* p = ::mmap(nullptr, size_, PROT_READ, kFlags, fd_, 0);
  if (p == MAP_FAILED) throw FormatError("cannot read: " + errno_message(errno));
  data_ = p;
}

}  // namespace mchex::io_detail
