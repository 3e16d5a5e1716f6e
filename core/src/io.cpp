// Point cloud io entry points: reading the file, sniffing its format, dispatching to the format
// readers/writers, and the atomic (temp file + fsync + rename) output. Also the shared text and
// scalar helpers declared in io_detail.hpp.
#include "nhnet/io.hpp"

#include "io_detail.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <limits>
#include <random>

namespace nhnet {
namespace io_detail {

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
    case ScalarType::Int8: lo = -128; hi = 127; return;
    case ScalarType::UInt8: lo = 0; hi = 255; return;
    case ScalarType::Int16: lo = -32768; hi = 32767; return;
    case ScalarType::UInt16: lo = 0; hi = 65535; return;
    case ScalarType::Int32: lo = -2147483648.0; hi = 2147483647.0; return;
    case ScalarType::UInt32: lo = 0; hi = 4294967295.0; return;
    default: lo = -std::numeric_limits<double>::infinity(); hi = -lo; return;
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
    r = std::to_chars(buf, buf + sizeof(buf), static_cast<long long>(to_integer_value(value, type)));
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

// ---------------------------------------------------------------------------------------------
// Output helpers

[[noreturn]] static void output_error(const std::string& path, const std::string& what) {
  throw OutputError(path + ": " + what);
}

void check_writable(const std::string& path, const Cloud& cloud) {
  const Eigen::Index n = cloud.points.rows();
  if (cloud.normals.rows() != 0 && cloud.normals.rows() != n)
    output_error(path, "cloud has " + std::to_string(cloud.normals.rows()) + " normals for " +
                           std::to_string(n) + " points");
  for (const ExtraProperty& e : cloud.extras) {
    if (e.values.size() != size_t(n))
      output_error(path, "extra property '" + e.name + "' has " + std::to_string(e.values.size()) +
                             " values for " + std::to_string(n) + " points");
    const bool bad_name =
        e.name.empty() || std::any_of(e.name.begin(), e.name.end(), [](char c) {
          return !std::isgraph(static_cast<unsigned char>(c));
        });
    if (bad_name) output_error(path, "extra property name " + quote_token(e.name) + " is not writable");
  }
}

std::vector<const ExtraProperty*> writable_extras(const Cloud& cloud,
                                                  const std::vector<std::string>& reserved) {
  std::vector<const ExtraProperty*> out;
  std::vector<std::string> used = reserved;
  for (const ExtraProperty& e : cloud.extras) {
    if (std::find(used.begin(), used.end(), e.name) != used.end()) continue;
    used.push_back(e.name);
    out.push_back(&e);
  }
  return out;
}

std::vector<Column> cloud_columns(const Cloud& cloud, const char* const (&normal_names)[3],
                                  const std::vector<std::string>& extra_reserved) {
  std::vector<Column> cols;
  const ScalarType coord = points_fit_float(cloud.points) ? ScalarType::Float32 : ScalarType::Float64;
  const char* xyz[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) cols.push_back({xyz[k], coord, cloud.points.data(), k, 3});
  std::vector<std::string> reserved = {"x", "y", "z"};
  reserved.insert(reserved.end(), extra_reserved.begin(), extra_reserved.end());
  if (cloud.has_normals()) {
    for (int k = 0; k < 3; ++k) {
      cols.push_back({normal_names[k], ScalarType::Float32, cloud.normals.data(), k, 3});
      reserved.emplace_back(normal_names[k]);
    }
  }
  for (const ExtraProperty* e : writable_extras(cloud, reserved))
    cols.push_back({e->name, e->type, e->values.data(), 0, 1});
  return cols;
}

void write_rows(Sink& sink, const std::vector<Column>& cols, Eigen::Index rows, bool ascii,
                std::string& out) {
  for (Eigen::Index i = 0; i < rows; ++i) {
    for (size_t c = 0; c < cols.size(); ++c) {
      const double v = cols[c].values[cols[c].first + i * cols[c].stride];
      if (ascii) {
        if (c > 0) out += ' ';
        append_number(v, cols[c].type, out);
      } else {
        encode_scalar_le(v, cols[c].type, out);
      }
    }
    if (ascii) out += '\n';
    if (out.size() >= (size_t(1) << 16)) {
      sink.write(out);
      out.clear();
    }
  }
  sink.write(out);
}

// ---------------------------------------------------------------------------------------------
// Atomic writing

AtomicFile::AtomicFile(const std::string& target) : target_(target) {
  namespace fs = std::filesystem;
  const fs::path p(target);
  if (p.filename().empty()) output_error(target, "not a file name");
  fs::path dir = p.parent_path();
  if (dir.empty()) dir = ".";
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    output_error(target, "directory '" + dir.string() + "' does not exist");
  if (fs::is_directory(p, ec)) output_error(target, std::strerror(EISDIR));
  open_temp(dir, p.filename().string());
}

AtomicFile::~AtomicFile() {
  if (fd_ >= 0) ::close(fd_);
  if (!committed_ && !temp_.empty()) ::unlink(temp_.c_str());
}

void AtomicFile::write(const char* data, size_t size) {
  buffer_.append(data, size);
  if (buffer_.size() >= kFlushBytes) flush();
}

void AtomicFile::commit() {
  flush();
  if (::fsync(fd_) != 0) fail("fsync failed");
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) fail("close failed");
  if (::rename(temp_.c_str(), target_.c_str()) != 0) fail("rename failed");
  committed_ = true;
  sync_directory();
}

void AtomicFile::fail(const std::string& what) {
  const int err = errno;
  output_error(target_, what + ": " + std::strerror(err));
}

// Creates `<dir>/.<name>.nhnet-tmp-<pid>-<random>` exclusively; keeps an existing target's
// permission bits.
void AtomicFile::open_temp(const std::filesystem::path& dir, const std::string& name) {
  std::random_device device;
  for (int attempt = 0; attempt < 16 && fd_ < 0; ++attempt) {
    const uint64_t r = (uint64_t(device()) << 32) ^ device();
    char suffix[32];
    const auto end = std::to_chars(suffix, suffix + sizeof(suffix), r, 16).ptr;
    temp_ = (dir / ("." + name + ".nhnet-tmp-" + std::to_string(::getpid()) + "-" +
                    std::string(suffix, end)))
                .string();
    fd_ = ::open(temp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd_ < 0 && errno != EEXIST) {
      temp_.clear();
      fail("cannot create a file in '" + dir.string() + "'");
    }
  }
  if (fd_ < 0) {
    temp_.clear();
    output_error(target_, "cannot create a unique temporary file");
  }
  struct stat st {};
  if (::stat(target_.c_str(), &st) == 0 && S_ISREG(st.st_mode))
    ::fchmod(fd_, st.st_mode & 07777);  // best effort: keep the original's permissions
}

// Writes the buffer out completely (retrying short writes and EINTR).
void AtomicFile::flush() {
  size_t done = 0;
  while (done < buffer_.size()) {
    const ssize_t n = ::write(fd_, buffer_.data() + done, buffer_.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) fail("write failed");
    if (n == 0) {
      errno = ENOSPC;
      fail("write failed");
    }
    done += size_t(n);
  }
  buffer_.clear();
}

// Makes the rename durable; failures are ignored (the data itself is already synced).
void AtomicFile::sync_directory() {
  std::filesystem::path dir = std::filesystem::path(target_).parent_path();
  if (dir.empty()) dir = ".";
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd < 0) return;
  (void)::fsync(dfd);
  ::close(dfd);
}

}  // namespace io_detail

using namespace io_detail;

// ---------------------------------------------------------------------------------------------
// Reading

/// Lower-case extension of `path` including the dot ("" when none).
static std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

FileFormat format_from_extension(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext == ".ply") return FileFormat::Ply;
  if (ext == ".pcd") return FileFormat::Pcd;
  if (ext == ".xyz" || ext == ".xyzn" || ext == ".txt" || ext == ".pts") return FileFormat::Xyz;
  return FileFormat::Auto;
}

/// Reads the whole file; InputError with the strerror text when it cannot be opened or read.
static FileBytes load_file(const std::string& path) {
  FileBytes file{path, {}};
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) input_error(path, std::strerror(EISDIR));
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) input_error(path, std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_size > 0)
    file.bytes.reserve(size_t(st.st_size));
  char buffer[1 << 16];
  for (;;) {
    const ssize_t got = ::read(fd, buffer, sizeof(buffer));
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) {
      const int err = errno;
      ::close(fd);
      input_error(path, std::string("read failed: ") + std::strerror(err));
    }
    if (got == 0) break;
    file.bytes.append(buffer, size_t(got));
  }
  ::close(fd);
  return file;
}

/// True when the first line that is neither blank nor a '#' comment consists of numbers only
/// (at least one), looking at the first 4 KiB.
static bool looks_numeric(const std::string& bytes) {
  LineCursor lines(std::string_view(bytes).substr(0, 4096), 0, 1);
  std::string_view line;
  while (lines.next(line)) {
    Tokens tokens(line);
    std::string_view token;
    if (!tokens.next(token) || token[0] == '#') continue;
    do {
      double v = 0;
      if (!parse_double(token, v)) return false;
    } while (tokens.next(token));
    return true;
  }
  return false;
}

static bool starts_with(const std::string& s, std::string_view prefix) {
  return s.compare(0, prefix.size(), prefix) == 0;
}

/// Format of the content: magic line first, then the extension, then "is it numbers".
static FileFormat sniff(const FileBytes& file, std::vector<std::string>* warnings) {
  const std::string& b = file.bytes;
  if (starts_with(b, "ply\n") || starts_with(b, "ply\r")) return FileFormat::Ply;
  if (starts_with(b, "# .PCD") || starts_with(b, "VERSION") || starts_with(b, "FIELDS"))
    return FileFormat::Pcd;
  const FileFormat by_extension = format_from_extension(file.path);
  if (by_extension == FileFormat::Xyz) return FileFormat::Xyz;
  if (looks_numeric(b)) {
    if (by_extension != FileFormat::Auto)
      warn(warnings, "content is XYZ text despite the " + lower_extension(file.path) +
                         " extension; read as XYZ");
    return FileFormat::Xyz;
  }
  if (by_extension == FileFormat::Ply)
    input_error(file.path, "not a PLY file (bad magic: the first line is not 'ply')");
  if (by_extension == FileFormat::Pcd)
    input_error(file.path, "not a PCD file (bad magic: no '# .PCD' or VERSION header line)");
  input_error(file.path, "unrecognised format (not PLY, PCD or XYZ text)");
}

Cloud read_cloud(const std::string& path, const ReadOptions& options,
                 std::vector<std::string>* warnings) {
  const FileBytes file = load_file(path);
  if (file.bytes.empty()) input_error(path, "empty file");
  const FileFormat format = options.format == FileFormat::Auto ? sniff(file, warnings)
                                                               : options.format;
  switch (format) {
    case FileFormat::Ply: return read_ply(file, warnings);
    case FileFormat::Pcd: return read_pcd(file, warnings);
    case FileFormat::Xyz: return read_xyz(file, warnings);
    case FileFormat::Auto: break;
  }
  input_error(path, "unrecognised format");
}

// ---------------------------------------------------------------------------------------------
// Writing

void write_cloud(const std::string& path, const Cloud& cloud, const WriteOptions& options) {
  const FileFormat format =
      options.format == FileFormat::Auto ? format_from_extension(path) : options.format;
  if (format == FileFormat::Auto)
    output_error(path, "cannot tell the output format from the extension (use .ply, .pcd, .xyz)");
  check_writable(path, cloud);
  AtomicFile file(path);
  switch (format) {
    case FileFormat::Ply: write_ply(file, cloud, options.ascii); break;
    case FileFormat::Pcd: write_pcd(file, cloud, options.ascii); break;
    case FileFormat::Xyz: write_xyz(file, cloud); break;
    case FileFormat::Auto: break;
  }
  file.commit();
}

}  // namespace nhnet
