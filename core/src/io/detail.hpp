// Internal helpers shared by the point cloud readers and writers (the files of core/src/io/). Not
// installed.
//
// Readers work on the whole file held in memory (FileBytes) and never trust a declared size:
// every count is bounded by the bytes that are actually left before anything is allocated.
// Writers emit into a Sink, which output.cpp backs with a temporary file that is renamed over the
// target only when complete.
#pragma once

#include "nhnet/errors.hpp"
#include "nhnet/io/cloud.hpp"

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace nhnet::io_detail {

/// Largest element / point count accepted from a header (2^40).
constexpr uint64_t kMaxCount = uint64_t(1) << 40;
/// Largest PLY / PCD header accepted, in bytes.
constexpr size_t kMaxHeaderBytes = 64 * 1024;

/// A whole input file held in memory, with the path used in error messages.
struct FileBytes {
  std::string path;
  std::string bytes;
};

/// Throws InputError("<path>: <what>").
[[noreturn]] void input_error(const std::string& path, const std::string& what);
/// Throws OutputError "<path>: <what>".
[[noreturn]] void output_error(const std::string& path, const std::string& what);

/// Appends `note` to `warnings` when it is not null.
inline void warn(std::vector<std::string>* warnings, std::string note) {
  if (warnings) warnings->push_back(std::move(note));
}

// ---------------------------------------------------------------------------------------------
// Text scanning

/// Walks a byte range line by line; accepts "\n", "\r\n" and "\r" line endings.
class LineCursor {
 public:
  /// `first_line` is the 1-based number of the line that starts at `offset`.
  LineCursor(std::string_view data, size_t offset, size_t first_line)
      : data_(data), pos_(offset), next_line_(first_line) {}

  /// Returns the next line (without its terminator) or false at the end of the data.
  bool next(std::string_view& line);
  /// 1-based number of the line last returned by next().
  size_t line_number() const { return next_line_ - 1; }
  /// Byte offset just past the terminator of the line last returned.
  size_t offset() const { return pos_; }

 private:
  std::string_view data_;
  size_t pos_;
  size_t next_line_;
};

/// Lazily yields the whitespace-separated (space, tab, other control blanks) tokens of a line.
class Tokens {
 public:
  explicit Tokens(std::string_view line) : line_(line) {}
  /// Stores the next token in `token`; false when the line has no more tokens.
  bool next(std::string_view& token);
  /// True when only whitespace is left.
  bool done();

 private:
  std::string_view line_;
  size_t pos_ = 0;
};

/// True when `c` separates tokens (space, tab, vertical tab, form feed, NUL).
inline bool is_blank(char c) {
  return c == ' ' || c == '\t' || c == '\v' || c == '\f' || c == '\0';
}

/// True when the line has no tokens.
bool is_blank_line(std::string_view line);

/// Parses a decimal floating point token exactly as a whole ("1.5", "-2e3", "+4", "nan", "inf");
/// out-of-range magnitudes become +-inf or +-0. Locale independent. False when malformed.
bool parse_double(std::string_view token, double& value);

/// Parses a non-negative decimal integer made of digits only ("0", "42"), at most `max`.
bool parse_count(std::string_view token, uint64_t max, uint64_t& value);

/// Quotes a token for an error message, shortened to a sensible length.
std::string quote_token(std::string_view token);

// ---------------------------------------------------------------------------------------------
// XYZ text lines (xyz.cpp; also the streaming reader of pipeline/stream.cpp)

/// Most columns accepted on one XYZ line (bounds the work spent on a garbage line).
constexpr size_t kMaxXyzColumns = 4096;

/// The XYZ line rules, the one copy that read_xyz and the streaming reader share: blank lines
/// and '#' comments are skipped; a lone non-negative integer on the first data line is a .pts
/// point count (skipped, checked by count_mismatch()); the first data line fixes the columns (at
/// least 3, at most kMaxXyzColumns) and every later one must have as many. Malformed lines are
/// InputErrors naming the file and the line. The state carries over from one LineCursor to the
/// next, so a file may be fed in chunks of whole lines (line numbers continuing).
class XyzLines {
 public:
  /// `columns` > 0: the columns are already known (a later pass over the same bytes).
  explicit XyzLines(std::string path, size_t columns = 0)
      : path_(std::move(path)), columns_(columns) {}

  /// Moves to the next data line of `lines` (the count line skipped); false at their end.
  bool next(LineCursor& lines);
  /// Parses the data line next() moved to into `values` (cleared first); the first one fixes
  /// the columns.
  void parse(std::vector<double>& values);
  /// Columns per data line; 0 until the first data line is parsed.
  size_t columns() const { return columns_; }
  /// Throws InputError when no data line was parsed (only blank or comment lines).
  void require_points() const;
  /// The note when a point count line disagrees with `points` read; "" otherwise.
  std::string count_mismatch(uint64_t points) const;

 private:
  std::string path_;
  size_t columns_;
  std::string_view line_;
  size_t line_no_ = 0;
  bool first_ = true;
  bool has_declared_ = false;
  uint64_t declared_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Scalars

/// Size in bytes of a scalar type.
size_t scalar_size(ScalarType type);
/// True for the integer scalar types.
bool is_integer(ScalarType type);
/// True when `value` is an integer within the range of the integer scalar `type`.
bool fits_integer(double value, ScalarType type);
/// PLY type name ("uchar", "float", ...).
const char* ply_type_name(ScalarType type);

/// True when this machine stores integers little endian.
bool host_is_little_endian();

/// Reads one scalar of `type` from `p` (unaligned), swapping bytes when `swap` is set.
double decode_scalar(const unsigned char* p, ScalarType type, bool swap);

/// Converts `value` to `type` (integers: rounded, clamped to range, NaN -> 0) and appends its
/// little-endian bytes to `out`.
void encode_scalar_le(double value, ScalarType type, std::string& out);

/// Appends `value` as text: integers exactly, Float32 as the shortest text that reads back as
/// the same float, Float64 as the shortest text that reads back as the same double.
void append_number(double value, ScalarType type, std::string& out);

/// True when every coordinate is exactly representable as float (NaN and inf included).
bool points_fit_float(const Points& points);

// ---------------------------------------------------------------------------------------------
// Output

/// Destination of a writer. Implementations throw OutputError on failure.
class Sink {
 public:
  virtual ~Sink() = default;
  /// Appends bytes; may buffer.
  virtual void write(const char* data, size_t size) = 0;
  void write(const std::string& s) { write(s.data(), s.size()); }
};

/// A temporary file `<dir>/.<name>.nhnet-tmp-<pid>-<random>` next to `target`, renamed over it
/// by commit(); the destructor removes the temporary if commit() did not complete. Writes are
/// buffered and every system call checked (OutputError naming the target).
class AtomicFile final : public Sink {
 public:
  explicit AtomicFile(const std::string& target);
  ~AtomicFile() override;
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  void write(const char* data, size_t size) override;
  using Sink::write;
  /// Flushes, fsyncs and closes the temporary, then renames it over the target.
  void commit();

 private:
  static constexpr size_t kFlushBytes = size_t(1) << 20;
  [[noreturn]] void fail(const std::string& what);
  void open_temp(const std::filesystem::path& dir, const std::string& name);
  void flush();
  void sync_directory();

  std::string target_;
  std::string temp_;
  std::string buffer_;
  int fd_ = -1;
  bool committed_ = false;
};

/// Validates that `cloud` can be written (sizes agree, extra names usable); throws OutputError
/// naming `path` otherwise.
void check_writable(const std::string& path, const Cloud& cloud);

/// Extras written for `cloud`, skipping those whose name collides with `reserved` names.
std::vector<const ExtraProperty*> writable_extras(const Cloud& cloud,
                                                  const std::vector<std::string>& reserved);

/// Where a read per-point value goes: a coordinate or normal column, an extra, or nowhere.
struct Slot {
  enum Kind { Coord, Normal, Extra, Skip } kind = Skip;
  int index = 0;  ///< coordinate / normal column, or index into Cloud::extras
};

/// Stores one value of row `row` where its slot says.
inline void store(Cloud& cloud, const Slot& slot, Eigen::Index row, double value) {
  switch (slot.kind) {
    case Slot::Coord: cloud.points(row, slot.index) = value; break;
    case Slot::Normal: cloud.normals(row, slot.index) = value; break;
    case Slot::Extra: cloud.extras[size_t(slot.index)].values[size_t(row)] = value; break;
    case Slot::Skip: break;
  }
}

/// One written per-point column.
struct Column {
  std::string name;
  ScalarType type;
  const double* values;  ///< element i at values[first + i * stride]
  Eigen::Index first;    ///< offset of element 0 (kept apart: values is null for 0 rows)
  Eigen::Index stride;
};

/// Columns written for `cloud`, in output order: x y z (float when every coordinate is exact
/// in float, else double), the normals as float under `normal_names` when present, then the
/// extras whose names collide with none of these nor with `extra_reserved`.
std::vector<Column> cloud_columns(const Cloud& cloud, const char* const (&normal_names)[3],
                                  const std::vector<std::string>& extra_reserved = {});

/// Appends the N rows of `cols` to `out` (ascii: space-separated text lines; binary: little
/// endian), handing `out` to `sink` every 64 KiB and at the end.
void write_rows(Sink& sink, const std::vector<Column>& cols, Eigen::Index rows, bool ascii,
                std::string& out);

// ---------------------------------------------------------------------------------------------
// Format readers and writers (ply.cpp, pcd.cpp, xyz.cpp, las.cpp, e57.cpp)

Cloud read_ply(const FileBytes& file, std::vector<std::string>* warnings);
Cloud read_pcd(const FileBytes& file, std::vector<std::string>* warnings);
Cloud read_xyz(const FileBytes& file, std::vector<std::string>* warnings);

void write_ply(Sink& sink, const Cloud& cloud, bool ascii);
void write_pcd(Sink& sink, const Cloud& cloud, bool ascii);
void write_xyz(Sink& sink, const Cloud& cloud);

/// LAS 1.0-1.4 and LAZ (las.cpp, las_write.cpp), E57 (e57.cpp); `path` names the output in
/// errors.
Cloud read_las(const FileBytes& file, std::vector<std::string>* warnings);
Cloud read_e57(const FileBytes& file, std::vector<std::string>* warnings);
void write_las(Sink& sink, const Cloud& cloud, bool compressed, const std::string& path);
void write_e57(Sink& sink, const Cloud& cloud, const std::string& path);

/// Decompresses an LZF stream into exactly `out_size` bytes. False when the stream is corrupt,
/// would write past `out_size` or reference data before the output start, or ends short.
bool lzf_decompress(const unsigned char* in, size_t in_size, unsigned char* out, size_t out_size);

}  // namespace nhnet::io_detail
