// The region values of a mesh in ascending order, each with how many hexes it labels and its first
// and last hex, in one pass on all threads: what the writers that group hexes by region (.inp's
// element sets, .exo's element blocks) need, without sorting the hexes. A mesher's output has a
// handful of values; past kMaxRegionGroups the pass gives up (`many`) and the caller sorts.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/base/parallel.h"

namespace mchex::io_detail {

inline constexpr std::size_t kMaxRegionGroups = 256;

struct RegionGroup {
  int32_t region = 0;
  std::size_t count = 0;
  std::size_t first = 0, last = 0;  // hex indices
};

struct RegionGroups {
  std::vector<RegionGroup> groups;  // ascending region
  bool many = false;                // more than kMaxRegionGroups values: `groups` is empty

  // The group of a region value that is in the list.
  std::size_t index_of(int32_t region) const {
    return static_cast<std::size_t>(std::lower_bound(groups.begin(), groups.end(), region,
                                                     [](const RegionGroup& g, int32_t r) { return g.region < r; }) -
                                    groups.begin());
  }

  void add(int32_t region, std::size_t count, std::size_t first, std::size_t last) {
    if (many) return;
    const auto it = groups.begin() + static_cast<std::ptrdiff_t>(index_of(region));
    if (it != groups.end() && it->region == region) {
      it->count += count;
      it->first = std::min(it->first, first);
      it->last = std::max(it->last, last);
      return;
    }
    if (groups.size() == kMaxRegionGroups) {
      many = true;
      groups.clear();
      return;
    }
    groups.insert(it, RegionGroup{region, count, first, last});
  }
  void join(const RegionGroups& other) {
    if (other.many) {
      many = true;
      groups.clear();
    }
    for (const RegionGroup& g : other.groups) add(g.region, g.count, g.first, g.last);
  }
};

inline RegionGroups region_groups(const std::vector<int32_t>& region) {
  // Counts, minima and maxima are exact whatever the split, so the result is too.
  return parallel_reduce(
      region.size(), std::size_t{1} << 16, RegionGroups{},
      [&](std::size_t begin, std::size_t end, RegionGroups acc) {
        // Labels come in runs: one list update per run.
        for (std::size_t h = begin; h < end && !acc.many;) {
          std::size_t e = h + 1;
          while (e < end && region[e] == region[h]) ++e;
          acc.add(region[h], e - h, h, e - 1);
          h = e;
        }
        return acc;
      },
      [](RegionGroups a, const RegionGroups& b) {
        a.join(b);
        return a;
      });
}

}  // namespace mchex::io_detail
