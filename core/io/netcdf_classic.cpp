// netcdf_classic.h: the classic netCDF header and fixed-size variable data.
#include "core/io/netcdf_classic.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <set>

#include "core/io/format_error.h"
#include "core/io/text_numbers.h"

namespace mchex::io_detail {
namespace {

enum Type { kByte = 1, kChar, kShort, kInt, kFloat, kDouble, kUByte, kUShort, kUInt, kInt64, kUInt64 };

std::size_t type_size(int type) {
  switch (type) {
    case kByte:
    case kChar:
    case kUByte: return 1;
    case kShort:
    case kUShort: return 2;
    case kInt:
    case kFloat:
    case kUInt: return 4;
    default: return 8;
  }
}

class Cursor {
 public:
  Cursor(std::string_view bytes, int version) : bytes_(bytes), wide_(version == 5) {}

  [[noreturn]] void fail(const std::string& message) const {
    throw FormatError("netCDF header byte " + std::to_string(pos_ + 4) + ": " + message);  // after the 4-byte magic
  }
  std::uint64_t big(std::size_t size, std::string_view what) {
    if (bytes_.size() - pos_ < size)
      fail("unexpected end of file where " + std::string(what) + " was expected (truncated file?)");
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < size; ++i) v = v << 8 | static_cast<unsigned char>(bytes_[pos_ + i]);
    pos_ += size;
    return v;
  }
  std::uint32_t u32(std::string_view what) { return static_cast<std::uint32_t>(big(4, what)); }
  // A count, length or id: 4 bytes (8 in CDF-5), non-negative.
  std::uint64_t size(std::string_view what) {
    const std::uint64_t v = big(wide_ ? 8 : 4, what);
    if (v > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()) ||
        (!wide_ && v > static_cast<std::uint64_t>(std::numeric_limits<int32_t>::max())))
      fail(std::string(what) + " is negative");
    return v;
  }
  // A count of items of at least `min_bytes` each, refused when the rest cannot hold it.
  std::uint64_t count(std::string_view what, std::size_t min_bytes) {
    const std::uint64_t c = size(what);
    if (c > (bytes_.size() - pos_) / min_bytes)
      fail(std::string(what) + " " + std::to_string(c) + " is more than the file can hold");
    return c;
  }
  std::string name() {
    const std::uint64_t n = count("a name length", 1);
    if (n == 0) fail("an empty name");
    if (n > 256) fail("a name longer than 256 bytes");
    std::string s(bytes_.substr(pos_, n));
    if (s.find('\0') != std::string::npos || s.find('/') != std::string::npos) fail("a name with a NUL or '/'");
    skip(n + (4 - n % 4) % 4, "a name's padding");
    return s;
  }
  void skip(std::uint64_t n, std::string_view what) {
    if (bytes_.size() - pos_ < n) fail("unexpected end of file in " + std::string(what) + " (truncated file?)");
    pos_ += static_cast<std::size_t>(n);
  }
  std::string_view take(std::uint64_t n, std::string_view what) {
    const std::size_t at = pos_;
    skip(n, what);
    return bytes_.substr(at, static_cast<std::size_t>(n));
  }
  // The tag of a list and its element count; 0 for an absent list (two zeros).
  std::uint64_t list(std::uint32_t tag, std::string_view what, std::size_t min_bytes) {
    const std::uint32_t t = u32(what);
    if (t == 0) {
      if (size(what) != 0) fail(std::string(what) + ": an absent list with a non-zero count");
      return 0;
    }
    if (t != tag) fail(std::string(what) + ": tag " + std::to_string(t) + " where " + std::to_string(tag) + " belongs");
    return count(std::string(what) + " count", min_bytes);
  }
  bool wide() const { return wide_; }

 private:
  std::string_view bytes_;
  std::size_t pos_ = 0;
  bool wide_;
};

int read_type(Cursor& in, int version) {
  const auto type = static_cast<int>(in.u32("a type"));
  if (type < kByte || type > (version == 5 ? kUInt64 : kDouble)) in.fail("unknown type " + std::to_string(type));
  return type;
}

template <class T>
T load_big(const char* p) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < sizeof(T); ++i) v = v << 8 | static_cast<unsigned char>(p[i]);
  if constexpr (sizeof(T) == 8) {
    return std::bit_cast<T>(v);
  } else if constexpr (sizeof(T) == 4) {
    return std::bit_cast<T>(static_cast<std::uint32_t>(v));
  } else if constexpr (sizeof(T) == 2) {
    return std::bit_cast<T>(static_cast<std::uint16_t>(v));
  } else {
    return std::bit_cast<T>(static_cast<std::uint8_t>(v));
  }
}

}  // namespace

NetcdfClassic::NetcdfClassic(std::string_view bytes) : bytes_(bytes) {
  if (bytes.size() < 4 || bytes.substr(0, 3) != "CDF") throw FormatError("not a netCDF classic file");
  const int version = bytes[3];
  if (version != 1 && version != 2 && version != 5)
    throw FormatError("netCDF classic version " + std::to_string(version) + " is not 1, 2 or 5");
  Cursor in(bytes.substr(4), version);
  const std::size_t size_bytes = in.wide() ? 8 : 4;
  const std::uint64_t records = in.big(size_bytes, "the record count");

  const std::uint64_t dims = in.list(10, "the dimension list", 2 * size_bytes);
  std::set<std::string> names;
  std::optional<std::uint64_t> record_dim;
  for (std::uint64_t d = 0; d < dims; ++d) {
    std::string name = in.name();
    if (!names.insert(name).second) in.fail("dimension '" + shown(name) + "' is defined twice");
    const std::uint64_t length = in.size("a dimension length");
    if (length == 0) {
      if (record_dim) in.fail("two record dimensions");
      record_dim = d;
    }
    dimensions_.emplace_back(std::move(name), length);
  }
  auto attributes = [&](std::vector<Attribute>* out) {
    const std::uint64_t n = in.list(12, "an attribute list", 2 * size_bytes + 4);
    std::set<std::string> seen;
    for (std::uint64_t a = 0; a < n; ++a) {
      Attribute attribute;
      attribute.name = in.name();
      if (!seen.insert(attribute.name).second) in.fail("attribute '" + shown(attribute.name) + "' is defined twice");
      attribute.type = read_type(in, version);
      const std::uint64_t values = in.count("an attribute's value count", type_size(attribute.type));
      const std::uint64_t length = values * type_size(attribute.type);
      attribute.values = std::string(in.take(length, "an attribute's values"));
      in.skip((4 - length % 4) % 4, "an attribute's padding");
      if (out != nullptr) out->push_back(std::move(attribute));
    }
  };
  attributes(nullptr);  // global attributes: not needed

  const std::uint64_t vars = in.list(11, "the variable list", 4 * size_bytes + 8);
  names.clear();
  for (std::uint64_t k = 0; k < vars; ++k) {
    Variable v;
    v.name = in.name();
    if (!names.insert(v.name).second) in.fail("variable '" + shown(v.name) + "' is defined twice");
    const std::uint64_t rank = in.count("a variable's dimension count", size_bytes);
    for (std::uint64_t r = 0; r < rank; ++r) {
      const std::uint64_t id = in.size("a dimension id");
      if (id >= dimensions_.size())
        in.fail("variable '" + shown(v.name) + "' has dimension id " + std::to_string(id) + " out of range");
      if (record_dim && id == *record_dim && r != 0) in.fail("the record dimension is not a variable's first");
      v.dims.push_back(id);
    }
    attributes(&v.attributes);
    v.type = read_type(in, version);
    in.big(size_bytes, "a variable size");  // recomputed from the shape; only a hint in the format
    v.begin = in.big(version == 1 ? 4 : 8, "a variable's offset");
    v.record = !v.dims.empty() && record_dim && v.dims[0] == *record_dim;
    if (!v.record) {
      // count() cannot overflow once every factor is bounded by the file size.
      std::uint64_t bytes_needed = type_size(v.type);
      for (const std::uint64_t id : v.dims) {
        const std::uint64_t length = dimensions_[id].second;
        if (length != 0 && bytes_needed > bytes.size() / length)
          in.fail("variable '" + shown(v.name) + "' is larger than the file (truncated file?)");
        bytes_needed *= length;
      }
      if (v.begin > bytes.size() || bytes_needed > bytes.size() - v.begin)
        in.fail("the data of variable '" + shown(v.name) + "' lies past the end of the file (truncated file?)");
    }
    variables_.push_back(std::move(v));
  }
  (void)records;
}

std::optional<std::uint64_t> NetcdfClassic::dimension(std::string_view name) const {
  for (const auto& [n, length] : dimensions_)
    if (n == name) return length;
  return std::nullopt;
}

const NetcdfClassic::Variable* NetcdfClassic::find(std::string_view name) const {
  for (const Variable& v : variables_)
    if (v.name == name) return &v;
  return nullptr;
}

const NetcdfClassic::Variable& NetcdfClassic::get(std::string_view name) const {
  const Variable* v = find(name);
  if (v == nullptr) throw FormatError("no netCDF variable '" + std::string(name) + "'");
  if (v->record) throw FormatError("netCDF variable '" + std::string(name) + "' is a record variable");
  return *v;
}

std::vector<std::uint64_t> NetcdfClassic::shape(std::string_view name) const {
  const Variable* v = find(name);
  if (v == nullptr) throw FormatError("no netCDF variable '" + std::string(name) + "'");
  std::vector<std::uint64_t> s;
  for (const std::uint64_t id : v->dims) s.push_back(dimensions_[id].second);
  return s;
}

std::uint64_t NetcdfClassic::count(const Variable& v) const {
  std::uint64_t n = 1;
  for (const std::uint64_t id : v.dims) n *= dimensions_[id].second;  // bounded in the constructor
  return n;
}

std::vector<double> NetcdfClassic::reals(std::string_view name) const {
  const Variable& v = get(name);
  const std::uint64_t n = count(v);
  const char* p = bytes_.data() + v.begin;
  std::vector<double> out(n);
  for (std::uint64_t i = 0; i < n; ++i) {
    switch (v.type) {
      case kDouble: out[i] = load_big<double>(p + 8 * i); break;
      case kFloat: out[i] = load_big<float>(p + 4 * i); break;
      default: throw FormatError("netCDF variable '" + std::string(name) + "' is not of a real type");
    }
  }
  return out;
}

std::vector<std::int64_t> NetcdfClassic::integers(std::string_view name) const {
  const Variable& v = get(name);
  const std::uint64_t n = count(v);
  const char* p = bytes_.data() + v.begin;
  std::vector<std::int64_t> out(n);
  for (std::uint64_t i = 0; i < n; ++i) {
    switch (v.type) {
      case kInt: out[i] = load_big<int32_t>(p + 4 * i); break;
      case kInt64: out[i] = load_big<std::int64_t>(p + 8 * i); break;
      case kShort: out[i] = load_big<int16_t>(p + 2 * i); break;
      case kUInt: out[i] = load_big<std::uint32_t>(p + 4 * i); break;
      default: throw FormatError("netCDF variable '" + std::string(name) + "' is not of an integer type");
    }
  }
  return out;
}

std::string NetcdfClassic::chars(std::string_view name) const {
  const Variable& v = get(name);
  if (v.type != kChar) throw FormatError("netCDF variable '" + std::string(name) + "' is not of type char");
  return std::string(bytes_.substr(v.begin, count(v)));
}

std::string NetcdfClassic::text_attribute(std::string_view variable, std::string_view attribute) const {
  const Variable* v = find(variable);
  if (v == nullptr) return {};
  for (const Attribute& a : v->attributes)
    if (a.name == attribute && a.type == kChar) {
      std::string s = a.values;
      s.erase(std::find(s.begin(), s.end(), '\0'), s.end());
      return s;
    }
  return {};
}

}  // namespace mchex::io_detail
