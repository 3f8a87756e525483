#include "core/pipeline/estimate.h"

#include <unistd.h>

#include <cctype>
#include <cmath>
#include <fstream>
#include <sstream>
#include <utility>

#include <fmt/format.h>

#include "core/base/error.h"

namespace mchex {
namespace {

// Measured (see the header): the process before the grid, and its peak per output hex.
constexpr double kBaseBytes = 100.0 * (1 << 20);
constexpr double kMchexBytesPerHex = 190, kRoBytesPerHex = 140;
constexpr double kHexesPerUncutCell = 8, kExtraHexesPerCutCell = 8, kCutCellsPerAxisSquared = 3;

}  // namespace

RunEstimate estimate_cells(double cells, double cells_per_axis, const std::string& method) {
  RunEstimate e;
  if (method == "ro") {
    e.hexes = cells;
    e.bytes = kBaseBytes + e.hexes * kRoBytesPerHex;
    return e;
  }
  const double cut = std::min(cells, kCutCellsPerAxisSquared * cells_per_axis * cells_per_axis);
  e.hexes = kHexesPerUncutCell * cells + kExtraHexesPerCutCell * cut;
  e.bytes = kBaseBytes + e.hexes * kMchexBytesPerHex;
  return e;
}

RunEstimate estimate_uniform(int depth, const std::string& method) {
  const double n = std::pow(3.0, depth);
  return estimate_cells(n * n * n, n, method);
}

std::size_t default_memory_budget() {
  double available = 0;
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  double kib = 0;
  std::string unit;
  while (meminfo >> key >> kib >> unit) {
    if (key == "MemAvailable:") {
      available = kib * 1024;
      break;
    }
  }
  if (available <= 0) available = double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGE_SIZE));
  return std::size_t(0.8 * available);
}

std::optional<std::size_t> parse_memory_size(const std::string& text) {
  std::size_t used = 0;
  double value = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    return std::nullopt;
  }
  std::string unit = text.substr(used);
  for (char& c : unit) c = char(std::toupper(static_cast<unsigned char>(c)));
  if (unit.ends_with("IB")) unit.resize(unit.size() - 2);
  else if (unit.ends_with("B")) unit.resize(unit.size() - 1);
  double scale = 1;
  if (unit == "K") scale = 1024.0;
  else if (unit == "M") scale = 1024.0 * 1024;
  else if (unit == "G") scale = 1024.0 * 1024 * 1024;
  else if (unit == "T") scale = 1024.0 * 1024 * 1024 * 1024;
  else if (!unit.empty()) return std::nullopt;
  if (!std::isfinite(value) || value <= 0 || value * scale >= 1e19) return std::nullopt;
  return std::size_t(value * scale);
}

std::string format_memory_size(double bytes) {
  if (bytes >= 0.95 * (1 << 30)) return fmt::format("{:.1f} GiB", bytes / (1 << 30));
  return fmt::format("{:.0f} MiB", std::max(1.0, bytes / (1 << 20)));
}

void enforce_memory_budget(const std::string& what, const RunEstimate& estimate, std::size_t budget,
                           const std::string& budget_name,
                           const std::optional<std::pair<std::string, RunEstimate>>& suggestion) {
  if (estimate.bytes <= double(budget)) return;
  std::string line =
      fmt::format("{} needs about {} ({:.2g} output hexes), over {} {}", what, format_memory_size(estimate.bytes),
                  estimate.hexes, budget_name, format_memory_size(double(budget)));
  if (suggestion)
    line += fmt::format("; {} would need about {}", suggestion->first, format_memory_size(suggestion->second.bytes));
  else line += "; no setting of this kind fits";
  throw ResourceError(line);
}

}  // namespace mchex
