#include "core/device/backend.h"

#include <stdexcept>
#include <string>

#include "core/device/cell_words.h"

namespace mchex {

CellCode encode_cell(const CellClass& c) {
  CellCode out;
  out.subcase = c.subcase;
  out.sign_mask = c.sign_mask;
  out.face_joins = c.face_joins;
  out.tunnel = c.tunnel;
  out.symmetry = c.symmetry;
  out.inverted = c.inverted ? 1 : 0;
  out.cut_edges = c.cut_edges;
  return out;
}

CellCode decode_cell_words(std::uint32_t w0, std::uint32_t w1) {
  CellCode out;
  out.subcase = static_cast<Subcase>(w0 & 0xFF);
  out.sign_mask = static_cast<std::uint8_t>(w0 >> kCodeSignShift);
  out.face_joins = static_cast<std::uint8_t>(w0 >> kCodeFaceShift & 0x3F);
  out.tunnel = static_cast<std::int8_t>(int(w0 >> kCodeTunnelShift & 3) - 1);
  out.inverted = static_cast<std::uint8_t>(w0 >> kCodeInvertedShift & 1);
  out.symmetry = static_cast<std::uint8_t>(w1 & 0xFF);
  out.cut_edges = static_cast<std::uint16_t>(w1 >> kCodeCutShift);
  return out;
}

std::array<std::uint32_t, 2> encode_cell_words(const CellCode& c) {
  const std::uint32_t w0 = std::uint32_t(c.subcase) | std::uint32_t(c.sign_mask) << kCodeSignShift |
                           std::uint32_t(c.face_joins) << kCodeFaceShift |
                           std::uint32_t(c.tunnel + 1) << kCodeTunnelShift |
                           std::uint32_t(c.inverted) << kCodeInvertedShift;
  const std::uint32_t w1 = std::uint32_t(c.symmetry) | std::uint32_t(c.cut_edges) << kCodeCutShift;
  return {w0, w1};
}

void check_classify_sizes(const HexComplex& complex, std::span<const double> values, const CellClassification& out,
                          const ClassifyOptions& options) {
  const std::size_t cells = complex.cells.size();
  if (values.size() != complex.points.size() || out.subcases.size() != cells || out.offsets.size() != cells + 1 ||
      !(out.words.empty() || out.words.size() == 2 * cells) ||
      !(out.crossings.empty() || out.crossings.size() == 12 * cells))
    throw std::invalid_argument("classify_cells: batch size mismatch");
  if (!(options.zero_tolerance >= 0)) throw std::invalid_argument("classify_cells: negative zero tolerance");
  if (const std::uint64_t n = options.uniform_cells_per_axis) {
    if (cells != n * n * n || complex.points.size() != (n + 1) * (n + 1) * (n + 1))
      throw std::invalid_argument("classify_cells: the complex is not a uniform grid of " + std::to_string(n) +
                                  " cells per axis");
  }
}

void classify_cells_codes(Backend& backend, const HexComplex& complex, std::span<const double> values,
                          std::span<CellCode> codes, std::span<std::uint64_t> offsets, const ClassifyOptions& options) {
  const std::size_t n = complex.cells.size();
  if (codes.size() != n) throw std::invalid_argument("classify_cells_codes: batch size mismatch");
  std::vector<std::uint8_t> subcases(n);
  std::vector<std::uint32_t> words(2 * n);
  backend.classify_cells(complex, values, {subcases, offsets, words}, options);
  for (std::size_t i = 0; i < n; ++i) {
    codes[i] = decode_cell_words(words[2 * i], words[2 * i + 1]);
    if (static_cast<std::uint8_t>(codes[i].subcase) != subcases[i])
      throw std::logic_error("classify_cells: cell " + std::to_string(i) + "'s subcase byte and words disagree");
  }
}

}  // namespace mchex
