// The one way the project writes a file: into a hidden temporary beside the target, renamed onto
// the target only by commit(). A run that fails or is interrupted before commit() leaves the
// target as it was (the destructor removes the temporary), so no reader ever sees a partial file.
//
// Signals: a process killed by SIGINT or SIGTERM runs no destructors, so every live temporary is
// also kept in a fixed registry of path slots that install_signal_cleanup()'s handler reads with
// async-signal-safe calls only (atomics and unlink(2)), then re-raises the signal with its default
// action: the exit status stays the signal's. While an OutputGroup lives, targets committed in it
// are registered too and removed by a signal: a command's outputs appear all together or not at
// all. A commit's rename and its registry update are one step the handler waits for (the
// committing thread blocks the signals meanwhile), so the handler never sees a file between
// names.
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
  int slot_ = -1;  // the temporary's registry slot; -1 for a path too long to register
};

// SIGINT and SIGTERM handlers that remove the registered files, then die of the signal.
void install_signal_cleanup();

// While one lives, a signal removes the targets committed since it was made (one at a time).
class OutputGroup {
 public:
  OutputGroup();
  OutputGroup(const OutputGroup&) = delete;
  OutputGroup& operator=(const OutputGroup&) = delete;
  ~OutputGroup();  // the committed targets are the caller's for good
};

}  // namespace mchex
