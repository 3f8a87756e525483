// How big a run will be, before its large allocations: the output hexes and the process's peak
// memory, against a budget (mesh --max-memory; by default 80 % of MemAvailable in /proc/meminfo).
// A run over its budget is refused with ResourceError (exit 2) and a line naming a setting that
// fits, instead of dying half-way or driving the machine into swap.
//
// The counts: a uniform grid's cells and points are exact; RO makes one hex per cell; MCHex's
// midpoint subdivision makes 8 hexes per uncut cell and 8 + 2 per cut edge for a cut cell (Tong &
// Zhang 2025, Section 4; core/cutting/local_refinement.h local_refinement_hexes), so a cell the
// surface cuts adds about 8 more (about 4 cut edges, measured on the bench models). The cells the
// surface cuts are bounded by the cells themselves and, on a grid of n cells per axis, estimated as
// 3 n^2 (a surface that fills the padded cube like its inscribed sphere crosses about that many).
// An adaptive grid is estimated after the octree is refined, from its complex's cells, with n at
// the deepest level. The bytes: a fixed base (the libraries, the BVH of a small model) plus a
// peak per output hex measured on the bench models (perf/bench_end_to_end.py prints it):
// 190 B for MCHex (its hexes, points, key map and the checker's face records; 158 to 187 B
// measured at depth 4 on the two-holed shape, a bumpy torus and its adaptive grid) and 140 B for
// RO (135 B measured). The estimate is an order-of-magnitude guard, not a promise: a run within it may still exceed
// it by some percent.
#pragma once

#include <cstddef>
#include <optional>
#include <string>

namespace mchex {

struct RunEstimate {
  double hexes = 0;  // inside and outside together
  double bytes = 0;  // the process's peak
};

// A uniform grid of 3^depth cells per axis, method "mchex" or "ro".
RunEstimate estimate_uniform(int depth, const std::string& method);
// A grid of `cells` cells whose finest level has `cells_per_axis` cells per axis (adaptive).
RunEstimate estimate_cells(double cells, double cells_per_axis, const std::string& method);

// 80 % of MemAvailable (/proc/meminfo), or of the physical memory where that file is missing.
std::size_t default_memory_budget();

// "8G", "512M", "1.5G", "100000000" (bytes), K/M/G/T in powers of 1024, an optional trailing B or
// iB; nullopt for anything else.
std::optional<std::size_t> parse_memory_size(const std::string& text);
// "1.2 GiB", "512 MiB".
std::string format_memory_size(double bytes);

// ResourceError("WHAT needs about X, over BUDGET; SUGGESTION would need about Y") when
// estimate.bytes > budget. `suggestion` is the setting that fits ("--depth 4") and its estimate,
// or nullopt when none does.
void enforce_memory_budget(const std::string& what, const RunEstimate& estimate, std::size_t budget,
                           const std::string& budget_name,
                           const std::optional<std::pair<std::string, RunEstimate>>& suggestion);

}  // namespace mchex
