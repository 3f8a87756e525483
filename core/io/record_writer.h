// Writing a long table of records (points, hexes, converted arrays) in file order on all threads.
//
// The records are formatted chunk by chunk on all threads (ordered_pipeline) into a few buffers
// that are reused from chunk to chunk, and the chunks are written in order: the file is the same
// as a serial write gives, one thread's write(2) calls overlap the others' formatting, and memory
// stays bounded by the chunks in flight. The buffers are allocated once per table, not once per
// chunk: a fresh allocation is paid in page faults, which cost 23 us per 4 KiB page on the 2-core
// development VM (measured), more than formatting the page's records.
#pragma once

#include <algorithm>
#include <cstddef>
#include <memory>
#include <mutex>
#include <string_view>
#include <vector>

#include "core/base/parallel.h"
#include "core/io/atomic_file.h"
#include "core/io/text_numbers.h"
#include "core/mesh/hex_mesh.h"

namespace mchex::io_detail {

// The bytes a chunk aims at: large enough that a write(2) call per chunk costs little (6 us each,
// measured), small enough that a chunk's buffer stays in the core's cache until it is written.
inline constexpr std::size_t kChunkBytes = std::size_t{1} << 18;

// The buffers of the chunks in flight: one is taken per chunk and given back once the chunk is
// written; a new one is made only when all are in use.
class ChunkBuffers {
 public:
  explicit ChunkBuffers(std::size_t bytes) : bytes_(bytes) {}

  char* take() {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (free_.empty()) {
      owned_.push_back(std::make_unique_for_overwrite<char[]>(bytes_));
      return owned_.back().get();
    }
    char* buffer = free_.back();
    free_.pop_back();
    return buffer;
  }
  void give(char* buffer) {
    const std::lock_guard<std::mutex> lock(mutex_);
    free_.push_back(buffer);
  }

 private:
  std::size_t bytes_;
  std::mutex mutex_;
  std::vector<std::unique_ptr<char[]>> owned_;
  std::vector<char*> free_;
};

// How many records of at most `record_bytes` write_records puts in one chunk (for a caller that
// needs to know where chunks start).
inline std::size_t records_per_chunk(std::size_t record_bytes) {
  return std::max<std::size_t>(1, kChunkBytes / record_bytes);
}

// Records [0, count) formatted on all threads and written in order. format(begin, end, out)
// writes records [begin, end) at `out` and returns the end of what it wrote; a record takes at most
// `record_bytes`, and the numbers' writers may store up to kNumberRoom bytes past the last one.
template <class Format>
void write_records(AtomicFile& out, std::size_t count, std::size_t record_bytes, const Format& format) {
  if (count == 0) return;
  const std::size_t per_chunk = records_per_chunk(record_bytes);
  ChunkBuffers buffers(per_chunk * record_bytes + kNumberRoom);
  struct Chunk {
    char* data = nullptr;
    std::size_t size = 0;
  };
  ordered_pipeline((count + per_chunk - 1) / per_chunk,
                   [&](std::size_t c) {
                     char* buffer = buffers.take();
                     const char* end = format(c * per_chunk, std::min(count, (c + 1) * per_chunk), buffer);
                     return Chunk{buffer, static_cast<std::size_t>(end - buffer)};
                   },
                   [&](const Chunk& chunk) {
                     out.write(chunk.data, chunk.size);
                     buffers.give(chunk.data);
                   });
}

// The longest "x y z" of three doubles (24 characters each: -2.2250738585072014e-308).
inline constexpr std::size_t kPointTextBytes = 3 * 25;

// One point per line, "x y z" followed by `line_end`.
inline void write_points_text(AtomicFile& out, const std::vector<Vec3>& points, std::string_view line_end) {
  write_records(out, points.size(), kPointTextBytes + line_end.size(),
                [&](std::size_t begin, std::size_t end, char* p) {
                  for (std::size_t i = begin; i < end; ++i) {
                    p = put_real(p, points[i].x);
                    *p++ = ' ';
                    p = put_real(p, points[i].y);
                    *p++ = ' ';
                    p = put_real(p, points[i].z);
                    std::memcpy(p, line_end.data(), line_end.size());
                    p += line_end.size();
                  }
                  return p;
                });
}

}  // namespace mchex::io_detail
