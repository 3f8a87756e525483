// Writing a long table of text records (points, hexes) in file order on all threads.
//
// The records are formatted chunk by chunk on all threads (ordered_pipeline) and the chunks are
// written in order, so the file is the same as a serial write gives, memory stays bounded by the
// chunks in flight and a 5M-hex mesh takes seconds.
#pragma once

#include <algorithm>
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "core/base/parallel.h"
#include "core/io/atomic_file.h"
#include "core/io/text_numbers.h"
#include "core/mesh/hex_mesh.h"

namespace mchex::io_detail {

// Formats records [0, count) in chunks on all threads and writes the chunks in order; the tokens
// in flight bound the memory to a few chunks per thread.
template <class Format>
void write_records(AtomicFile& out, std::size_t count, const Format& format) {
  constexpr std::size_t kChunk = std::size_t{1} << 14;
  if (count == 0) return;
  const std::size_t chunks = (count + kChunk - 1) / kChunk;
  ordered_pipeline(
      chunks,
      [&](std::size_t c) {
        std::string text;
        format(c * kChunk, std::min(count, (c + 1) * kChunk), text);
        return text;
      },
      [&](const std::string& text) { out.write(text); });
}

// One point per line, "x y z" followed by `line_end`.
inline void write_points_text(AtomicFile& out, const std::vector<Vec3>& points, std::string_view line_end) {
  write_records(out, points.size(), [&](std::size_t begin, std::size_t end, std::string& s) {
    s.reserve((end - begin) * 64);
    for (std::size_t i = begin; i < end; ++i) {
      put_number(s, points[i].x);
      s += ' ';
      put_number(s, points[i].y);
      s += ' ';
      put_number(s, points[i].z);
      s += line_end;
    }
  });
}

}  // namespace mchex::io_detail
