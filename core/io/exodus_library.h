// libexodusii's error report and database handle, shared by the .exo reader (exodus.cpp) and
// writer (exodus_writer.cpp): a failed call becomes a FormatError with the library's own message
// on one line, and the database is closed however the caller leaves.
#pragma once

#include <exodusII.h>

#include <string>
#include <string_view>

#include "core/io/format_error.h"

namespace mchex::io_detail::exodus_library {

inline std::string message(std::string_view what, int status) {
  const char* msg = nullptr;
  const char* func = nullptr;
  int code = 0;
  ex_get_err(&msg, &func, &code);
  std::string reason = std::string(what) + ": ";
  reason += msg != nullptr && *msg != '\0' ? std::string(msg) : "Exodus error " + std::to_string(status);
  if (code != 0) reason += " (error " + std::to_string(code) + ")";
  for (char& c : reason)
    if (c == '\n' || c == '\r') c = ' ';
  return reason;
}

inline void check(int status, std::string_view what) {
  if (status < 0) throw FormatError(message(what, status));
}

class Database {
 public:
  explicit Database(int id) : id_(id) {}
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;
  ~Database() {
    if (id_ >= 0) ex_close(id_);
  }
  int id() const { return id_; }
  void close(std::string_view what) {
    const int status = ex_close(id_);
    id_ = -1;
    check(status, what);
  }

 private:
  int id_;
};

}  // namespace mchex::io_detail::exodus_library
