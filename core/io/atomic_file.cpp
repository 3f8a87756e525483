#include "core/io/atomic_file.h"

#include <pthread.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <string>
#include <system_error>
#include <utility>

#include "core/base/error.h"

namespace mchex {
namespace {

std::string errno_message(int e) { return e != 0 ? std::generic_category().message(e) : std::string("I/O error"); }

// The registry the signal handler reads. A slot is free, being filled, a live temporary or a
// target committed in an open OutputGroup; the path is written before the state says so.
enum SlotState : int { kFree, kFilling, kTemporary, kCommitted };
constexpr std::size_t kSlots = 64;
constexpr std::size_t kMaxPath = 1024;
struct Slot {
  std::atomic<int> state{kFree};
  char path[kMaxPath];
};
std::array<Slot, kSlots> slots;
std::atomic<bool> group_open{false}, dying{false};
std::atomic<int> committing{0};
static_assert(std::atomic<int>::is_always_lock_free && std::atomic<bool>::is_always_lock_free);

// Returns the slot, or -1 when the path is too long or every slot is taken (then a signal leaves
// that one file behind; a command writes a handful).
int register_path(const std::filesystem::path& path, SlotState state) {
  const std::string& s = path.native();
  if (s.size() >= kMaxPath) return -1;
  for (std::size_t i = 0; i < kSlots; ++i) {
    int expected = kFree;
    if (slots[i].state.compare_exchange_strong(expected, kFilling)) {
      std::memcpy(slots[i].path, s.c_str(), s.size() + 1);
      slots[i].state.store(state);
      return int(i);
    }
  }
  return -1;
}

void release(int slot) {
  if (slot >= 0) slots[std::size_t(slot)].state.store(kFree);
}

extern "C" void remove_outputs_and_die(int sig) {
  dying.store(true);
  // A commit in flight on another thread finishes its rename and registry update first; the
  // committing thread blocks these signals, so this never waits on itself.
  while (committing.load() != 0) {
  }
  for (Slot& slot : slots) {
    const int state = slot.state.load();
    if (state == kTemporary || state == kCommitted) ::unlink(slot.path);
  }
  std::signal(sig, SIG_DFL);
  std::raise(sig);  // pending until this handler returns, then the default action
}

// Blocks SIGINT and SIGTERM on this thread for its lifetime.
class BlockSignals {
 public:
  BlockSignals() {
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &set, &old_);
  }
  ~BlockSignals() { pthread_sigmask(SIG_SETMASK, &old_, nullptr); }

 private:
  sigset_t old_;
};

}  // namespace

void install_signal_cleanup() {
  struct sigaction action {};
  action.sa_handler = remove_outputs_and_die;
  sigemptyset(&action.sa_mask);
  sigaddset(&action.sa_mask, SIGINT);
  sigaddset(&action.sa_mask, SIGTERM);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

OutputGroup::OutputGroup() { group_open.store(true); }

OutputGroup::~OutputGroup() {
  group_open.store(false);
  for (Slot& slot : slots) {
    int expected = kCommitted;
    slot.state.compare_exchange_strong(expected, kFree);
  }
}

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
  // Registered before it exists: a signal in between unlinks a name nobody else uses.
  slot_ = register_path(temp_, kTemporary);
  // "x" (exclusive): never truncate a file that is not ours, whatever its name.
  file_ = std::fopen(temp_.c_str(), "wbx");
  if (file_ == nullptr) {
    const int e = errno;
    release(slot_);
    throw InputError(target_.string() + ": cannot create a file in '" +
                     (folder.empty() ? std::string(".") : folder.string()) + "': " + errno_message(e));
  }
}

AtomicFile::~AtomicFile() {
  if (file_ != nullptr) std::fclose(file_);
  if (!committed_) {
    std::error_code ignored;
    std::filesystem::remove(temp_, ignored);
    release(slot_);
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
  {
    const BlockSignals blocked;
    committing.fetch_add(1);
    if (!dying.load()) {
      std::filesystem::rename(temp_, target_, ec);
      if (!ec) {
        if (group_open.load()) register_path(target_, kCommitted);
        release(std::exchange(slot_, -1));
      }
    }
    committing.fetch_sub(1);
  }
  if (ec) throw InputError(target_.string() + ": cannot move the finished file into place: " + ec.message());
  committed_ = true;
}

void AtomicFile::fail(int e) const { throw InputError(target_.string() + ": write failed: " + errno_message(e)); }

}  // namespace mchex
