// Shared text and scalar helpers of the readers and writers (declared in detail.hpp): line and
// token scanning, number parsing, scalar encoding and decoding.
#include "io/detail.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>

namespace nhnet::io_detail {

void input_error(const std::string& path, const std::string& what) {
  throw InputError(path + ": " + what);
}

// ---------------------------------------------------------------------------------------------
// Text scanning

bool LineCursor::next(std::string_view& line) {
  if (pos_ >= data_.size()) return false;
  const size_t start = pos_;
  size_t end = start;
  while (end < data_.size() && data_[end] != '\n' && data_[end] != '\r') ++end;
  line = data_.substr(start, end - start);
  pos_ = end;
  if (pos_ < data_.size()) {
    // "\r\n" is one terminator; a lone "\r" or "\n" is one too.
    if (data_[pos_] == '\r' && pos_ + 1 < data_.size() && data_[pos_ + 1] == '\n') ++pos_;
    ++pos_;
  }
  ++next_line_;
  return true;
}

bool Tokens::next(std::string_view& token) {
  while (pos_ < line_.size() && is_blank(line_[pos_])) ++pos_;
  if (pos_ >= line_.size()) return false;
  const size_t start = pos_;
  while (pos_ < line_.size() && !is_blank(line_[pos_])) ++pos_;
  token = line_.substr(start, pos_ - start);
  return true;
}

bool Tokens::done() {
  while (pos_ < line_.size() && is_blank(line_[pos_])) ++pos_;
  return pos_ >= line_.size();
}

bool is_blank_line(std::string_view line) { return Tokens(line).done(); }

/// Value of a token that std::from_chars found out of range: +-inf for huge magnitudes, +-0 for
/// tiny ones (negative exponent, or no non-zero integer digit).
static double out_of_range_value(std::string_view t) {
  const bool negative = !t.empty() && t[0] == '-';
  const size_t e = t.find_first_of("eE");
  bool tiny;
  if (e != std::string_view::npos) {
    tiny = e + 1 < t.size() && t[e + 1] == '-';
  } else {
    const std::string_view integer = t.substr(0, t.find('.'));
    tiny = integer.find_first_of("123456789") == std::string_view::npos;
  }
  const double magnitude = tiny ? 0.0 : std::numeric_limits<double>::infinity();
  return negative ? -magnitude : magnitude;
}

bool parse_double(std::string_view token, double& value) {
  const char* begin = token.data();
  const char* end = begin + token.size();
  if (begin != end && *begin == '+') {
    ++begin;
    if (begin != end && *begin == '-') return false;
  }
  if (begin == end) return false;
  double v = 0;
  const auto result = std::from_chars(begin, end, v, std::chars_format::general);
  if (result.ptr != end) return false;
  if (result.ec == std::errc::result_out_of_range) {
    value = out_of_range_value(std::string_view(begin, size_t(end - begin)));
    return true;
  }
  if (result.ec != std::errc()) return false;
  value = v;
  return true;
}

bool parse_count(std::string_view token, uint64_t max, uint64_t& value) {
  if (token.empty() || token.size() > 19) return false;
  uint64_t v = 0;
  for (const char c : token) {
    if (c < '0' || c > '9') return false;
    v = v * 10 + uint64_t(c - '0');
  }
  if (v > max) return false;
  value = v;
  return true;
}

std::string quote_token(std::string_view token) {
  constexpr size_t kMax = 40;
  std::string s = "'";
  for (size_t i = 0; i < std::min(token.size(), kMax); ++i) {
    const unsigned char c = static_cast<unsigned char>(token[i]);
    s += std::isprint(c) ? char(c) : '?';
  }
  if (token.size() > kMax) s += "...";
  return s + "'";
}

// ---------------------------------------------------------------------------------------------
// Scalars

size_t scalar_size(ScalarType type) {
  switch (type) {
    case ScalarType::Int8:
    case ScalarType::UInt8: return 1;
    case ScalarType::Int16:
    case ScalarType::UInt16: return 2;
    case ScalarType::Int32:
    case ScalarType::UInt32:
    case ScalarType::Float32: return 4;
    case ScalarType::Float64: return 8;
  }
  return 8;
}

bool is_integer(ScalarType type) {
  return type != ScalarType::Float32 && type != ScalarType::Float64;
}

/// Inclusive range of an integer scalar type.
static void integer_range(ScalarType type, double& lo, double& hi) {
  switch (type) {
    case ScalarType::Int8:
      lo = -128;
      hi = 127;
      return;
    case ScalarType::UInt8:
      lo = 0;
      hi = 255;
      return;
    case ScalarType::Int16:
      lo = -32768;
      hi = 32767;
      return;
    case ScalarType::UInt16:
      lo = 0;
      hi = 65535;
      return;
    case ScalarType::Int32:
      lo = -2147483648.0;
      hi = 2147483647.0;
      return;
    case ScalarType::UInt32:
      lo = 0;
      hi = 4294967295.0;
      return;
    default:
      lo = -std::numeric_limits<double>::infinity();
      hi = -lo;
      return;
  }
}

bool fits_integer(double value, ScalarType type) {
  double lo = 0, hi = 0;
  integer_range(type, lo, hi);
  return std::isfinite(value) && value == std::floor(value) && value >= lo && value <= hi;
}

const char* ply_type_name(ScalarType type) {
  switch (type) {
    case ScalarType::Int8: return "char";
    case ScalarType::UInt8: return "uchar";
    case ScalarType::Int16: return "short";
    case ScalarType::UInt16: return "ushort";
    case ScalarType::Int32: return "int";
    case ScalarType::UInt32: return "uint";
    case ScalarType::Float32: return "float";
    case ScalarType::Float64: return "double";
  }
  return "double";
}

bool host_is_little_endian() {
  const uint16_t probe = 1;
  unsigned char first = 0;
  std::memcpy(&first, &probe, 1);
  return first == 1;
}

/// Copies `n` bytes from `p` into `out`, reversing their order when `swap` is set.
static void load_bytes(const unsigned char* p, size_t n, bool swap, unsigned char* out) {
  for (size_t i = 0; i < n; ++i) out[i] = swap ? p[n - 1 - i] : p[i];
}

/// Reads a T from unaligned memory, optionally byte-swapped.
template <typename T>
static T load(const unsigned char* p, bool swap) {
  unsigned char bytes[sizeof(T)];
  load_bytes(p, sizeof(T), swap, bytes);
  T v;
  std::memcpy(&v, bytes, sizeof(T));
  return v;
}

double decode_scalar(const unsigned char* p, ScalarType type, bool swap) {
  switch (type) {
    case ScalarType::Int8: return load<int8_t>(p, false);
    case ScalarType::UInt8: return load<uint8_t>(p, false);
    case ScalarType::Int16: return load<int16_t>(p, swap);
    case ScalarType::UInt16: return load<uint16_t>(p, swap);
    case ScalarType::Int32: return load<int32_t>(p, swap);
    case ScalarType::UInt32: return load<uint32_t>(p, swap);
    case ScalarType::Float32: return load<float>(p, swap);
    case ScalarType::Float64: return load<double>(p, swap);
  }
  return 0;
}

/// Rounds and clamps `value` into the range of the integer type (NaN -> 0).
static double to_integer_value(double value, ScalarType type) {
  if (std::isnan(value)) return 0;
  double lo = 0, hi = 0;
  integer_range(type, lo, hi);
  return std::clamp(std::nearbyint(value), lo, hi);
}

/// Appends the little-endian bytes of `v`.
template <typename T>
static void store_le(T v, std::string& out) {
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, &v, sizeof(T));
  const bool swap = !host_is_little_endian();
  for (size_t i = 0; i < sizeof(T); ++i) out += char(bytes[swap ? sizeof(T) - 1 - i : i]);
}

void encode_scalar_le(double value, ScalarType type, std::string& out) {
  const double iv = is_integer(type) ? to_integer_value(value, type) : 0;
  switch (type) {
    case ScalarType::Int8: store_le(int8_t(iv), out); return;
    case ScalarType::UInt8: store_le(uint8_t(iv), out); return;
    case ScalarType::Int16: store_le(int16_t(iv), out); return;
    case ScalarType::UInt16: store_le(uint16_t(iv), out); return;
    case ScalarType::Int32: store_le(int32_t(iv), out); return;
    case ScalarType::UInt32: store_le(uint32_t(iv), out); return;
    case ScalarType::Float32: store_le(float(value), out); return;
    case ScalarType::Float64: store_le(value, out); return;
  }
}

void append_number(double value, ScalarType type, std::string& out) {
  char buf[64];
  std::to_chars_result r{};
  if (is_integer(type)) {
    r = std::to_chars(buf, buf + sizeof(buf),
                      static_cast<long long>(to_integer_value(value, type)));
  } else if (std::isnan(value)) {
    out += "nan";  // no "-nan": some readers only know the plain spelling
    return;
  } else if (type == ScalarType::Float32) {
    r = std::to_chars(buf, buf + sizeof(buf), static_cast<float>(value));
  } else {
    r = std::to_chars(buf, buf + sizeof(buf), value);
  }
  out.append(buf, r.ptr);
}

bool points_fit_float(const Points& points) {
  const double* p = points.data();
  for (Eigen::Index i = 0; i < points.size(); ++i) {
    const double v = p[i];
    if (std::isnan(v)) continue;
    if (static_cast<double>(static_cast<float>(v)) != v) return false;
  }
  return true;
}

}  // namespace nhnet::io_detail
