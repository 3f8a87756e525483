#include "core/io/atomic_file.h"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <string>
#include <system_error>
#include <utility>

#include "core/base/error.h"

namespace mchex {
namespace {

std::string errno_message(int e) { return e != 0 ? std::generic_category().message(e) : std::string("I/O error"); }

}  // namespace

AtomicFile::AtomicFile(const std::filesystem::path& target) : target_(target) {
  static std::atomic<unsigned> serial{0};
  const std::filesystem::path folder = target.parent_path();
  // Appended piece by piece: GCC 12 warns falsely (-Wrestrict) on the chained operator+ here.
  std::string name = ".";
  name += target.filename().string();
  name += ".tmp.";
  name += std::to_string(::getpid());
  name += '.';
  name += std::to_string(serial++);
  temp_ = folder / name;
  // "x" (exclusive): never truncate a file that is not ours, whatever its name.
  file_ = std::fopen(temp_.c_str(), "wbx");
  if (file_ == nullptr) {
    const int e = errno;
    throw InputError(target_.string() + ": cannot create a file in '" +
                     (folder.empty() ? std::string(".") : folder.string()) + "': " + errno_message(e));
  }
}

AtomicFile::~AtomicFile() {
  if (file_ != nullptr) std::fclose(file_);
  if (!committed_) {
    std::error_code ignored;
    std::filesystem::remove(temp_, ignored);
  }
}

void AtomicFile::write(const void* data, std::size_t size) {
  if (size != 0 && std::fwrite(data, 1, size, file_) != size) fail(errno);
}

void AtomicFile::commit() {
  std::FILE* f = std::exchange(file_, nullptr);
  if (std::fflush(f) != 0) {
    const int e = errno;
    std::fclose(f);
    fail(e);
  }
  if (std::fclose(f) != 0) fail(errno);
  std::error_code ec;
  std::filesystem::rename(temp_, target_, ec);
  if (ec) throw InputError(target_.string() + ": cannot move the finished file into place: " + ec.message());
  committed_ = true;
}

void AtomicFile::fail(int e) const { throw InputError(target_.string() + ": write failed: " + errno_message(e)); }

}  // namespace mchex
