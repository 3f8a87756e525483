// The netCDF classic file format (CDF-1, CDF-2 "64-bit offset", CDF-5 "64-bit data"), read from
// bytes in memory: the header parsed and checked in full, then the data of fixed-size variables
// fetched by name. The Exodus II reader (exodus.cpp) stands on it, so that a truncated or corrupt
// .exo is one FormatError and never reaches the netCDF library, whose classic-header parser
// crashes on corrupted bytes (a segmentation fault found by tests/test_mesh_io.cpp).
//
// The layout (netCDF's "Classic Format Specification"; docs/formats.md): big-endian throughout;
// "CDF" and a version byte; the record count; the dimension, global attribute and variable lists,
// each a tag (10, 12, 11) and a count, or two zeros when absent; a name is a length and its bytes
// padded to 4; a variable lists its dimension ids, its attributes, its type, its size and the
// offset of its data. CDF-5 widens counts, dimension lengths, ids and sizes to 8 bytes; CDF-2 and
// CDF-5 widen offsets to 8. Checked: every tag, type and count, names non-empty and unique, every
// dimension id in range, and every fixed-size variable's data inside the file.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace mchex::io_detail {

class NetcdfClassic {
 public:
  // Throws FormatError naming what is wrong.
  explicit NetcdfClassic(std::string_view bytes);

  // The length of a dimension, if there is one of that name.
  std::optional<std::uint64_t> dimension(std::string_view name) const;
  bool has_variable(std::string_view name) const { return find(name) != nullptr; }
  // The dimension lengths of a variable (FormatError when there is none of that name).
  std::vector<std::uint64_t> shape(std::string_view name) const;
  // All values of a numeric variable converted (FormatError for a char variable, a record
  // variable or a value that does not fit).
  std::vector<double> reals(std::string_view name) const;
  std::vector<std::int64_t> integers(std::string_view name) const;
  // A char variable's bytes, and a char attribute of a variable ("" when absent).
  std::string chars(std::string_view name) const;
  std::string text_attribute(std::string_view variable, std::string_view attribute) const;

 private:
  struct Attribute {
    std::string name;
    int type;
    std::string values;  // raw bytes
  };
  struct Variable {
    std::string name;
    std::vector<std::uint64_t> dims;  // dimension ids
    std::vector<Attribute> attributes;
    int type;
    std::uint64_t begin;
    bool record;
  };
  const Variable* find(std::string_view name) const;
  const Variable& get(std::string_view name) const;
  std::uint64_t count(const Variable& v) const;

  std::string_view bytes_;
  std::vector<std::pair<std::string, std::uint64_t>> dimensions_;
  std::vector<Variable> variables_;
};

}  // namespace mchex::io_detail
