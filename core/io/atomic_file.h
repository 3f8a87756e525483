// The one way the project writes a file: into a hidden temporary beside the target, renamed onto
// the target only by commit(). A run that fails or is interrupted before commit() leaves the
// target as it was (the destructor removes the temporary), so no reader ever sees a partial file.
#pragma once

#include <cstddef>
#include <cstdio>
#include <filesystem>
#include <string_view>

namespace mchex {

class AtomicFile {
 public:
  // Throws InputError("TARGET: cannot create a file in 'FOLDER': reason").
  explicit AtomicFile(const std::filesystem::path& target);
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  ~AtomicFile();

  // Throw InputError("TARGET: write failed: reason").
  void write(const void* data, std::size_t size);
  void write(std::string_view s) { write(s.data(), s.size()); }
  // Flushes, closes and renames; errors of buffered or delayed writes (full disk, quota) surface
  // here.
  void commit();

  const std::filesystem::path& temporary() const { return temp_; }

 private:
  [[noreturn]] void fail(int e) const;

  std::filesystem::path target_;
  std::filesystem::path temp_;
  std::FILE* file_ = nullptr;
  bool committed_ = false;
};

}  // namespace mchex
