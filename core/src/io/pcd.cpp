// PCD (v0.7) reader and writer: DATA ascii, binary and binary_compressed (LZF, read only).
//
// Reader: fields x y z are required; normal_x normal_y normal_z become normals; other COUNT 1
// fields become extras; COUNT > 1 fields and unsupported 64-bit integers are dropped with a
// warning; "_" padding is ignored. Sizes are checked against the file before allocating.
// Writer: x y z (float when lossless, else double), normal_x..z as float, extras as declared.
//
// Sensor (orient auto, auto.hpp): VIEWPOINT tx ty tz qw qx qy qz is the sensor's pose. PCL writes
// the default "0 0 0 1 0 0 0" on every cloud, so on an unorganized cloud (HEIGHT 1) that default
// says nothing and no sensor is read; on an organized cloud (HEIGHT > 1, a depth image in its
// camera's frame) it is the sensor at the origin. HEIGHT > 1 also gives the grid (WIDTH x
// HEIGHT, row-major). The writer stores the cloud's single sensor as VIEWPOINT and its grid as
// WIDTH x HEIGHT.
#include "io/detail.hpp"
#include "io/sensor.hpp"

#include <algorithm>
#include <array>

namespace nhnet::io_detail {
namespace {

enum class DataKind { Ascii, Binary, Compressed };

struct Field {
  std::string name;
  size_t size = 0;
  char type = 'F';
  uint64_t count = 1;
  bool supported = false;  ///< size/type combination maps to a ScalarType
  ScalarType scalar = ScalarType::Float32;
  size_t offset = 0;  ///< byte offset inside one point (binary, ascii: value index)
};

struct PcdHeader {
  std::vector<Field> fields;
  uint64_t points = 0;
  uint64_t width = 0, height = 1;
  bool has_viewpoint = false;
  Sensor viewpoint;  ///< the VIEWPOINT line's pose (default pose when absent)
  DataKind data = DataKind::Ascii;
  size_t data_offset = 0;
  size_t data_line = 0;
  size_t point_size = 0;    ///< bytes per point (binary layouts)
  size_t point_values = 0;  ///< values per point (ascii)
};

std::string at_line(size_t line) { return " (line " + std::to_string(line) + ")"; }

/// Raw keyword values collected from the header lines.
struct RawHeader {
  std::vector<std::string> fields, size, type, count, viewpoint;
  std::string width, height = "1", points, data;
  bool have_fields = false, have_size = false, have_type = false, have_count = false;
};

/// Reads the remaining tokens of a line into `out`.
void rest_tokens(Tokens& tokens, std::vector<std::string>& out) {
  std::string_view t;
  while (tokens.next(t)) out.emplace_back(t);
}

/// Reads the single value of a keyword line; InputError unless there is exactly one.
std::string single_value(const FileBytes& file, Tokens& tokens, std::string_view key, size_t line) {
  std::vector<std::string> v;
  rest_tokens(tokens, v);
  if (v.size() != 1) input_error(file.path, "bad " + std::string(key) + " line" + at_line(line));
  return v[0];
}

/// Collects the header keywords up to and including the DATA line.
RawHeader scan_header(const FileBytes& file, PcdHeader& header) {
  RawHeader raw;
  LineCursor lines(file.bytes, 0, 1);
  std::string_view line;
  for (;;) {
    if (lines.offset() >= kMaxHeaderBytes)
      input_error(file.path, "header not terminated within 64 KiB (no DATA line)");
    if (!lines.next(line)) input_error(file.path, "header not terminated (no DATA line)");
    const size_t n = lines.line_number();
    Tokens tokens(line);
    std::string_view key;
    if (!tokens.next(key) || key[0] == '#') continue;
    if (key == "VERSION") {
      const std::string v = single_value(file, tokens, key, n);
      if (v != ".7" && v != "0.7" && v != ".6" && v != "0.6" && v != ".5" && v != "0.5")
        input_error(file.path, "unsupported PCD version " + quote_token(v) + at_line(n));
    } else if (key == "FIELDS" || key == "COLUMNS") {
      rest_tokens(tokens, raw.fields);
      raw.have_fields = true;
    } else if (key == "SIZE") {
      rest_tokens(tokens, raw.size);
      raw.have_size = true;
    } else if (key == "TYPE") {
      rest_tokens(tokens, raw.type);
      raw.have_type = true;
    } else if (key == "COUNT") {
      rest_tokens(tokens, raw.count);
      raw.have_count = true;
    } else if (key == "WIDTH") {
      raw.width = single_value(file, tokens, key, n);
    } else if (key == "HEIGHT") {
      raw.height = single_value(file, tokens, key, n);
    } else if (key == "POINTS") {
      raw.points = single_value(file, tokens, key, n);
    } else if (key == "VIEWPOINT") {
      raw.viewpoint.clear();
      rest_tokens(tokens, raw.viewpoint);
      if (raw.viewpoint.size() != 7)
        input_error(file.path, "bad VIEWPOINT line (expected tx ty tz qw qx qy qz)" + at_line(n));
    } else if (key == "DATA") {
      raw.data = single_value(file, tokens, key, n);
      header.data_offset = lines.offset();
      header.data_line = n + 1;
      return raw;
    } else {
      input_error(file.path, "unknown header keyword " + quote_token(key) + at_line(n));
    }
  }
}

/// Parses a header count (WIDTH, HEIGHT, POINTS).
uint64_t header_count(const FileBytes& file, const std::string& key, const std::string& value) {
  uint64_t v = 0;
  if (value.empty()) input_error(file.path, "header has no " + key + " line");
  if (!parse_count(value, kMaxCount, v))
    input_error(file.path, "invalid " + key + " " + quote_token(value) +
                               " (must be an integer from 0 to 2^40)");
  return v;
}

/// Maps a PCD TYPE/SIZE pair to a scalar type; false for 64-bit integers (unsupported but
/// legal), InputError for combinations that do not exist.
bool scalar_for(const FileBytes& file, const Field& f, ScalarType& out) {
  static const std::array<std::pair<std::pair<char, size_t>, ScalarType>, 8> kTypes = {{
      {{'I', 1}, ScalarType::Int8},
      {{'U', 1}, ScalarType::UInt8},
      {{'I', 2}, ScalarType::Int16},
      {{'U', 2}, ScalarType::UInt16},
      {{'I', 4}, ScalarType::Int32},
      {{'U', 4}, ScalarType::UInt32},
      {{'F', 4}, ScalarType::Float32},
      {{'F', 8}, ScalarType::Float64},
  }};
  for (const auto& [key, type] : kTypes) {
    if (key.first == f.type && key.second == f.size) {
      out = type;
      return true;
    }
  }
  if ((f.type == 'I' || f.type == 'U') && f.size == 8) return false;
  input_error(file.path, "unsupported SIZE " + std::to_string(f.size) + " for TYPE " +
                             std::string(1, f.type) + " (field '" + f.name + "')");
}

/// Builds the field list from FIELDS / SIZE / TYPE / COUNT, checking that they agree.
void build_fields(const FileBytes& file, const RawHeader& raw, PcdHeader& header) {
  if (!raw.have_fields || raw.fields.empty()) input_error(file.path, "header has no FIELDS line");
  if (!raw.have_size) input_error(file.path, "header has no SIZE line");
  if (!raw.have_type) input_error(file.path, "header has no TYPE line");
  const size_t n = raw.fields.size();
  const auto check_length = [&](const std::vector<std::string>& v, const char* key) {
    if (v.size() != n)
      input_error(file.path, "FIELDS has " + std::to_string(n) + " entries but " + key + " has " +
                                 std::to_string(v.size()));
  };
  check_length(raw.size, "SIZE");
  check_length(raw.type, "TYPE");
  if (raw.have_count) check_length(raw.count, "COUNT");
  for (size_t i = 0; i < n; ++i) {
    Field f;
    f.name = raw.fields[i];
    uint64_t size = 0;
    if (!parse_count(raw.size[i], 8, size) || size == 0)
      input_error(file.path,
                  "invalid SIZE " + quote_token(raw.size[i]) + " for field '" + f.name + "'");
    f.size = size_t(size);
    if (raw.type[i].size() != 1 || std::string("FIU").find(raw.type[i][0]) == std::string::npos)
      input_error(file.path,
                  "invalid TYPE " + quote_token(raw.type[i]) + " for field '" + f.name + "'");
    f.type = raw.type[i][0];
    if (raw.have_count && (!parse_count(raw.count[i], uint64_t(1) << 20, f.count) || f.count == 0))
      input_error(file.path,
                  "invalid COUNT " + quote_token(raw.count[i]) + " for field '" + f.name + "'");
    f.supported = scalar_for(file, f, f.scalar);
    f.offset = header.point_size;
    header.point_size += f.size * size_t(f.count);
    header.point_values += size_t(f.count);
    if (f.name != "_")
      for (const Field& other : header.fields)
        if (other.name == f.name) input_error(file.path, "duplicate field '" + f.name + "'");
    header.fields.push_back(std::move(f));
  }
}

/// The VIEWPOINT line's pose; InputError for a malformed number or a quaternion that is not a
/// rotation.
Sensor parse_viewpoint(const FileBytes& file, const std::vector<std::string>& v) {
  double x[7];
  for (size_t i = 0; i < 7; ++i)
    if (!parse_double(v[i], x[i]))
      input_error(file.path, "malformed VIEWPOINT value " + quote_token(v[i]));
  return sensor_from_quaternion(file.path, {x[0], x[1], x[2]}, {x[3], x[4], x[5], x[6]},
                                "PCD VIEWPOINT");
}

/// Parses and validates the whole header.
PcdHeader parse_header(const FileBytes& file) {
  PcdHeader header;
  const RawHeader raw = scan_header(file, header);
  build_fields(file, raw, header);
  const uint64_t width = header_count(file, "WIDTH", raw.width);
  const uint64_t height = header_count(file, "HEIGHT", raw.height);
  const uint64_t wh = (height != 0 && width > kMaxCount / height) ? kMaxCount + 1 : width * height;
  header.points = raw.points.empty() ? wh : header_count(file, "POINTS", raw.points);
  header.width = width;
  header.height = height;
  header.has_viewpoint = !raw.viewpoint.empty();
  if (header.has_viewpoint) header.viewpoint = parse_viewpoint(file, raw.viewpoint);
  if (header.points != wh)
    input_error(file.path, "POINTS " + std::to_string(header.points) +
                               " does not match WIDTH*HEIGHT " + std::to_string(width) + "*" +
                               std::to_string(height));
  if (raw.data == "ascii")
    header.data = DataKind::Ascii;
  else if (raw.data == "binary")
    header.data = DataKind::Binary;
  else if (raw.data == "binary_compressed")
    header.data = DataKind::Compressed;
  else
    input_error(file.path, "unknown DATA type " + quote_token(raw.data));
  return header;
}

int find_field(const PcdHeader& h, const char* name) {
  for (size_t i = 0; i < h.fields.size(); ++i)
    if (h.fields[i].name == name) return int(i);
  return -1;
}

/// True when field `i` is a single supported scalar.
bool usable(const PcdHeader& h, int i) {
  return i >= 0 && h.fields[size_t(i)].count == 1 && h.fields[size_t(i)].supported;
}

/// Maps fields to coordinates / normals / extras and sizes `cloud`.
std::vector<Slot> plan_fields(const FileBytes& file, const PcdHeader& h, Cloud& cloud,
                              std::vector<std::string>* warnings) {
  std::vector<Slot> slots(h.fields.size());
  const char* coords[3] = {"x", "y", "z"};
  const char* normals[3] = {"normal_x", "normal_y", "normal_z"};
  bool has_normals = true;
  for (int k = 0; k < 3; ++k) {
    const int i = find_field(h, coords[k]);
    if (i < 0) input_error(file.path, "no '" + std::string(coords[k]) + "' field");
    if (!usable(h, i))
      input_error(file.path, "field '" + std::string(coords[k]) +
                                 "' must be one scalar of at most 32-bit integer or float type");
    slots[size_t(i)] = Slot{Slot::Coord, k};
    has_normals = has_normals && usable(h, find_field(h, normals[k]));
  }
  if (has_normals)
    for (int k = 0; k < 3; ++k) slots[size_t(find_field(h, normals[k]))] = Slot{Slot::Normal, k};
  const auto n = Eigen::Index(h.points);
  cloud.points.resize(n, 3);
  cloud.normals.resize(has_normals ? n : 0, 3);
  for (size_t i = 0; i < h.fields.size(); ++i) {
    const Field& f = h.fields[i];
    if (f.name == "_" || slots[i].kind != Slot::Skip) continue;
    if (f.count != 1) {
      warn(warnings, "field '" + f.name + "' (COUNT " + std::to_string(f.count) +
                         ") not carried to the output");
    } else if (!f.supported) {
      warn(warnings, "field '" + f.name + "' (64-bit integer) not carried to the output");
    } else {
      slots[i] = Slot{Slot::Extra, int(cloud.extras.size())};
      cloud.extras.push_back(ExtraProperty{f.name, f.scalar, std::vector<double>(size_t(n))});
    }
  }
  return slots;
}

/// Reads DATA ascii: one point per non-blank line, exactly point_values tokens. With `slots`
/// null nothing is stored (a dry run that finds where a short file ends).
void read_ascii(const FileBytes& file, const PcdHeader& h, const std::vector<Slot>* slots,
                Cloud& cloud) {
  LineCursor lines(file.bytes, h.data_offset, h.data_line);
  std::string_view line, t;
  for (uint64_t r = 0; r < h.points; ++r) {
    bool got = false;
    while ((got = lines.next(line)) && is_blank_line(line)) {
    }
    if (!got)
      input_error(file.path, "expected " + std::to_string(h.points) + " points, file ends after " +
                                 std::to_string(r) + at_line(lines.line_number()));
    const size_t n = lines.line_number();
    Tokens tokens(line);
    for (size_t i = 0; i < h.fields.size(); ++i) {
      const Field& f = h.fields[i];
      for (uint64_t c = 0; c < f.count; ++c) {
        if (!tokens.next(t))
          input_error(file.path, "too few values in point " + std::to_string(r) + at_line(n));
        double v = 0;
        if (!parse_double(t, v))
          input_error(file.path, "malformed number " + quote_token(t) + " in point " +
                                     std::to_string(r) + at_line(n));
        if (f.supported && is_integer(f.scalar) && !fits_integer(v, f.scalar))
          input_error(file.path, "value " + quote_token(t) + " does not fit field '" + f.name +
                                     "'" + at_line(n));
        if (f.supported && f.scalar == ScalarType::Float32) v = double(float(v));
        if (c == 0 && slots) store(cloud, (*slots)[i], Eigen::Index(r), v);
      }
    }
    if (!tokens.done())
      input_error(file.path, "too many values in point " + std::to_string(r) + at_line(n));
  }
}

/// Decodes points from a binary layout: value (point r, field i) at
/// data + field_base[i] + r * field_stride[i].
void read_layout(const unsigned char* data, const PcdHeader& h, const std::vector<Slot>& slots,
                 const std::vector<size_t>& field_base, const std::vector<size_t>& field_stride,
                 Cloud& cloud) {
  const bool swap = !host_is_little_endian();
  for (size_t i = 0; i < h.fields.size(); ++i) {
    if (slots[i].kind == Slot::Skip) continue;
    const unsigned char* p = data + field_base[i];
    for (uint64_t r = 0; r < h.points; ++r, p += field_stride[i])
      store(cloud, slots[i], Eigen::Index(r), decode_scalar(p, h.fields[i].scalar, swap));
  }
}

/// Reads DATA binary (array of structures, little endian).
void read_binary(const FileBytes& file, const PcdHeader& h, const std::vector<Slot>& slots,
                 Cloud& cloud) {
  std::vector<size_t> base, stride;
  for (const Field& f : h.fields) {
    base.push_back(f.offset);
    stride.push_back(h.point_size);
  }
  read_layout(reinterpret_cast<const unsigned char*>(file.bytes.data()) + h.data_offset, h, slots,
              base, stride, cloud);
}

/// Reads the little-endian uint32 at `p`.
uint32_t load_u32(const unsigned char* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

/// Reads DATA binary_compressed: sizes, LZF block, then structure of arrays.
void read_compressed(const FileBytes& file, const PcdHeader& h, const std::vector<Slot>& slots,
                     Cloud& cloud) {
  const auto* data = reinterpret_cast<const unsigned char*>(file.bytes.data()) + h.data_offset;
  const size_t remaining = file.bytes.size() - h.data_offset;
  if (remaining < 8) {
    if (h.points == 0) return;
    input_error(file.path, "unexpected end of file at byte " + std::to_string(file.bytes.size()) +
                               " (binary_compressed sizes missing)");
  }
  const uint32_t compressed = load_u32(data);
  const uint32_t uncompressed = load_u32(data + 4);
  const uint64_t expected = h.points * uint64_t(h.point_size);
  if (uncompressed != expected)
    input_error(file.path, "corrupt binary_compressed data: uncompressed size " +
                               std::to_string(uncompressed) + " but the header implies " +
                               std::to_string(expected) + " bytes");
  if (compressed > remaining - 8)
    input_error(file.path, "corrupt binary_compressed data: compressed size " +
                               std::to_string(compressed) + " exceeds the " +
                               std::to_string(remaining - 8) + " bytes left in the file");
  // LZF expands at most ~88x (3-byte back references of 264 bytes): refuse before allocating.
  if (uint64_t(uncompressed) > uint64_t(compressed) * 90)
    input_error(file.path, "corrupt binary_compressed data: sizes " + std::to_string(compressed) +
                               " -> " + std::to_string(uncompressed) + " are impossible for LZF");
  std::vector<unsigned char> raw(uncompressed);
  if (uncompressed > 0 && !lzf_decompress(data + 8, compressed, raw.data(), raw.size()))
    input_error(file.path, "corrupt binary_compressed data: LZF stream does not decode to " +
                               std::to_string(uncompressed) + " bytes");
  std::vector<size_t> base, stride;
  size_t offset = 0;
  for (const Field& f : h.fields) {
    base.push_back(offset);
    stride.push_back(f.size * size_t(f.count));
    offset += size_t(h.points) * f.size * size_t(f.count);
  }
  read_layout(raw.data(), h, slots, base, stride, cloud);
}

}  // namespace

bool lzf_decompress(const unsigned char* in, size_t in_size, unsigned char* out, size_t out_size) {
  size_t ip = 0, op = 0;
  while (ip < in_size) {
    const unsigned ctrl = in[ip++];
    if (ctrl < 32) {  // literal run of ctrl + 1 bytes
      const size_t len = ctrl + 1;
      if (in_size - ip < len || out_size - op < len) return false;
      std::memcpy(out + op, in + ip, len);
      ip += len;
      op += len;
      continue;
    }
    size_t len = ctrl >> 5;  // back reference
    if (len == 7) {
      if (ip >= in_size) return false;
      len += in[ip++];
    }
    len += 2;
    if (ip >= in_size) return false;
    const size_t distance = ((size_t(ctrl) & 0x1f) << 8) + in[ip++] + 1;
    if (distance > op || out_size - op < len) return false;
    for (size_t k = 0; k < len; ++k, ++op) out[op] = out[op - distance];  // may overlap
  }
  return op == out_size;
}

namespace {

/// The grid and the sensor of the header (see the top of this file).
void set_sensor(const PcdHeader& h, Cloud& cloud) {
  const bool organized = h.height > 1 && h.width > 0;
  if (organized) {
    cloud.grid_width = int64_t(h.width);
    cloud.grid_height = int64_t(h.height);
  }
  if (h.has_viewpoint && (organized || !default_pose(h.viewpoint)))
    cloud.sensors.push_back(h.viewpoint);
}

}  // namespace

Cloud read_pcd(const FileBytes& file, std::vector<std::string>* warnings) {
  const PcdHeader h = parse_header(file);
  const uint64_t remaining = file.bytes.size() - h.data_offset;
  if (h.data == DataKind::Binary && h.points > remaining / std::max<size_t>(h.point_size, 1))
    input_error(file.path, "header declares " + std::to_string(h.points) + " points of " +
                               std::to_string(h.point_size) + " bytes, more than the " +
                               std::to_string(remaining) +
                               " bytes after the header (unexpected end of file at byte " +
                               std::to_string(file.bytes.size()) + ")");
  Cloud cloud;
  if (h.data == DataKind::Ascii && h.points > 0 &&
      h.points > (remaining + 1) / (2 * h.point_values)) {
    read_ascii(file, h, nullptr, cloud);  // a short file: report where it ends
    input_error(file.path, "header declares " + std::to_string(h.points) +
                               " points, more than the " + std::to_string(remaining) +
                               " bytes after the header can hold");
  }
  const std::vector<Slot> slots = plan_fields(file, h, cloud, warnings);
  switch (h.data) {
    case DataKind::Ascii: read_ascii(file, h, &slots, cloud); break;
    case DataKind::Binary: read_binary(file, h, slots, cloud); break;
    case DataKind::Compressed: read_compressed(file, h, slots, cloud); break;
  }
  set_sensor(h, cloud);
  return cloud;
}

// ---------------------------------------------------------------------------------------------
// Writer

namespace {

/// PCD TYPE letter of a scalar type.
char pcd_type(ScalarType t) {
  if (!is_integer(t)) return 'F';
  return (t == ScalarType::Int8 || t == ScalarType::Int16 || t == ScalarType::Int32) ? 'I' : 'U';
}

/// "tx ty tz qw qx qy qz" of the cloud's single sensor, else the default pose.
std::string viewpoint_text(const Cloud& cloud) {
  const Sensor* s = single_sensor(cloud);
  if (!s) return "0 0 0 1 0 0 0";
  const std::array<double, 4> q = quaternion_of(s->rotation);
  std::string text;
  for (const double v :
       {s->position.x(), s->position.y(), s->position.z(), q[0], q[1], q[2], q[3]}) {
    if (!text.empty()) text += ' ';
    append_number(v, ScalarType::Float64, text);
  }
  return text;
}

}  // namespace

void write_pcd(Sink& sink, const Cloud& cloud, bool ascii) {
  const char* const normal_names[3] = {"normal_x", "normal_y", "normal_z"};
  const std::vector<Column> cols = cloud_columns(cloud, normal_names, {"_"});
  std::string fields = "FIELDS", size = "SIZE", type = "TYPE", count = "COUNT";
  for (const Column& c : cols) {
    fields += " " + c.name;
    size += " " + std::to_string(scalar_size(c.type));
    type += std::string(" ") + pcd_type(c.type);
    count += " 1";
  }
  const std::string n = std::to_string(cloud.size());
  const bool grid = cloud.organized();
  std::string out = "# .PCD v0.7 - Point Cloud Data file format (written by nhnet)\nVERSION 0.7\n" +
                    fields + "\n" + size + "\n" + type + "\n" + count + "\nWIDTH " +
                    (grid ? std::to_string(cloud.grid_width) : n) + "\nHEIGHT " +
                    (grid ? std::to_string(cloud.grid_height) : "1") + "\nVIEWPOINT " +
                    viewpoint_text(cloud) + "\nPOINTS " + n + "\nDATA " +
                    (ascii ? "ascii" : "binary") + "\n";
  write_rows(sink, cols, cloud.size(), ascii, out);
}

}  // namespace nhnet::io_detail
