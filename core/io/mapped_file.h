// The bytes of a mesh file, mapped rather than copied: a copy needs as much fresh memory as the
// file, and zeroing that memory was most of the time of reading a large binary mesh.
//
// Only a regular file is accepted: a directory, a device or a pipe has no size to bound the parse
// by, and may never end. Failures throw FormatError("cannot open: reason" and the like).
#pragma once

#include <cstddef>
#include <filesystem>
#include <string_view>

namespace mchex::io_detail {

class MappedFile {
 public:
  explicit MappedFile(const std::filesystem::path& path);
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  ~MappedFile();

  std::string_view text() const {
    return data_ != nullptr ? std::string_view(static_cast<const char*>(data_), size_) : "";
  }

 private:
  void map();

  int fd_;
  void* data_ = nullptr;
  std::size_t size_ = 0;
};

}  // namespace mchex::io_detail
