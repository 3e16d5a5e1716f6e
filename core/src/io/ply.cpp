// PLY reader and writer: ascii, binary_little_endian and binary_big_endian.
//
// Reader: the header is parsed with a 64 KiB bound; every declared element is checked against
// the bytes left in the file before anything is allocated; non-vertex elements and list
// properties are parsed past (never allocated) and reported as warnings. Writer: one vertex
// element, x y z as float when lossless (else double), nx ny nz as float, extras as declared.
//
// Sensor (orient auto, auto.hpp), PCL's convention (pcl::PLYWriter): "element camera 1" with
// view_px view_py view_pz (the sensor's position), x_axisx ... z_axisz (the rotation, row by row
// as PCL writes it) and viewportx viewporty (the grid of an organized cloud when their product
// is the vertex count); also "obj_info num_cols W" / "obj_info num_rows H" (PCL without camera)
// for the grid. PCL writes a camera at the origin on every cloud: on an unorganized cloud that
// default pose says nothing and no sensor is read (as PCD's default VIEWPOINT, pcd.cpp). The
// writer adds the camera element when the cloud has a single sensor or a grid.
#include "io/detail.hpp"
#include "io/sensor.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

namespace nhnet::io_detail {
namespace {

enum class Encoding { Ascii, BinaryLittle, BinaryBig };

struct Property {
  std::string name;
  bool is_list = false;
  ScalarType type = ScalarType::Float32;      ///< scalar type, or list item type
  ScalarType count_type = ScalarType::UInt8;  ///< list length type (lists only)
};

struct Element {
  std::string name;
  uint64_t count = 0;
  std::vector<Property> props;
};

struct Header {
  Encoding encoding = Encoding::Ascii;
  std::vector<Element> elements;
  size_t data_offset = 0;  ///< first byte after the end_header line
  size_t data_line = 0;    ///< number of the first line after end_header
  int64_t num_cols = 0;    ///< obj_info num_cols (0 = none)
  int64_t num_rows = 0;    ///< obj_info num_rows (0 = none)
};

/// Maps a PLY type name (classic and sized spellings) to a scalar type.
bool type_from_name(std::string_view name, ScalarType& type) {
  static const std::array<std::pair<std::string_view, ScalarType>, 16> kTypes = {{
      {"char", ScalarType::Int8},
      {"int8", ScalarType::Int8},
      {"uchar", ScalarType::UInt8},
      {"uint8", ScalarType::UInt8},
      {"short", ScalarType::Int16},
      {"int16", ScalarType::Int16},
      {"ushort", ScalarType::UInt16},
      {"uint16", ScalarType::UInt16},
      {"int", ScalarType::Int32},
      {"int32", ScalarType::Int32},
      {"uint", ScalarType::UInt32},
      {"uint32", ScalarType::UInt32},
      {"float", ScalarType::Float32},
      {"float32", ScalarType::Float32},
      {"double", ScalarType::Float64},
      {"float64", ScalarType::Float64},
  }};
  for (const auto& [n, t] : kTypes) {
    if (n == name) {
      type = t;
      return true;
    }
  }
  return false;
}

/// "vertex" -> "vertices", "face" -> "faces".
std::string plural(const std::string& name) {
  return name == "vertex" ? std::string("vertices") : name + "s";
}

/// " (line L)" suffix for header messages.
std::string at_line(size_t line) { return " (line " + std::to_string(line) + ")"; }

/// Splits a header line into at most 8 tokens (more are counted, not stored).
struct HeaderLine {
  std::array<std::string_view, 8> token{};
  size_t count = 0;
  explicit HeaderLine(std::string_view line) {
    Tokens tokens(line);
    std::string_view t;
    while (tokens.next(t)) {
      if (count < token.size()) token[count] = t;
      ++count;
    }
  }
};

/// Parses the scalar type named `name`; InputError when unknown.
ScalarType parse_type(const FileBytes& file, std::string_view name, size_t line) {
  ScalarType type{};
  if (!type_from_name(name, type))
    input_error(file.path, "unknown property type " + quote_token(name) + at_line(line));
  return type;
}

/// Handles a "format <encoding> <version>" line.
void parse_format_line(const FileBytes& file, const HeaderLine& h, size_t line, Header& header) {
  if (h.count != 3) input_error(file.path, "bad format line" + at_line(line));
  if (h.token[1] == "ascii")
    header.encoding = Encoding::Ascii;
  else if (h.token[1] == "binary_little_endian")
    header.encoding = Encoding::BinaryLittle;
  else if (h.token[1] == "binary_big_endian")
    header.encoding = Encoding::BinaryBig;
  else
    input_error(file.path, "unknown PLY format " + quote_token(h.token[1]) + at_line(line));
  double version = 0;
  if (!parse_double(h.token[2], version) || version != 1.0)
    input_error(file.path, "unsupported PLY version " + quote_token(h.token[2]) + at_line(line));
}

/// Handles an "element <name> <count>" line.
void parse_element_line(const FileBytes& file, const HeaderLine& h, size_t line, Header& header) {
  if (h.count != 3) input_error(file.path, "bad element line" + at_line(line));
  Element e;
  e.name = std::string(h.token[1]);
  if (!parse_count(h.token[2], kMaxCount, e.count))
    input_error(file.path, "invalid element count " + quote_token(h.token[2]) +
                               " (must be an integer from 0 to 2^40)" + at_line(line));
  for (const Element& other : header.elements)
    if (other.name == e.name)
      input_error(file.path, "duplicate element " + quote_token(e.name) + at_line(line));
  header.elements.push_back(std::move(e));
}

/// Handles a "property <type> <name>" or "property list <count type> <item type> <name>" line.
void parse_property_line(const FileBytes& file, const HeaderLine& h, size_t line, Header& header) {
  if (header.elements.empty())
    input_error(file.path, "property before any element" + at_line(line));
  Property p;
  if (h.count >= 2 && h.token[1] == "list") {
    if (h.count != 5) input_error(file.path, "bad list property line" + at_line(line));
    p.is_list = true;
    p.count_type = parse_type(file, h.token[2], line);
    if (!is_integer(p.count_type))
      input_error(file.path, "list count type " + quote_token(h.token[2]) +
                                 " is not an integer type" + at_line(line));
    p.type = parse_type(file, h.token[3], line);
    p.name = std::string(h.token[4]);
  } else {
    if (h.count != 3) input_error(file.path, "bad property line" + at_line(line));
    p.type = parse_type(file, h.token[1], line);
    p.name = std::string(h.token[2]);
  }
  Element& e = header.elements.back();
  for (const Property& other : e.props)
    if (other.name == p.name)
      input_error(file.path, "duplicate property " + quote_token(p.name) + " in element " +
                                 quote_token(e.name) + at_line(line));
  e.props.push_back(std::move(p));
}

/// "obj_info num_cols N" / "obj_info num_rows N" (the grid, when well-formed); other obj_info
/// lines are notes.
void parse_obj_info(const HeaderLine& h, Header& header) {
  uint64_t v = 0;
  if (h.count != 3 || !parse_count(h.token[2], kMaxCount, v)) return;
  if (h.token[1] == "num_cols") header.num_cols = int64_t(v);
  if (h.token[1] == "num_rows") header.num_rows = int64_t(v);
}

/// Offset just past the terminator of `line` (a view into file.bytes). A "\r\n" pair counts as
/// one terminator only when the header itself uses "\r\n".
size_t end_of_line(const FileBytes& file, std::string_view line, bool crlf) {
  const std::string& b = file.bytes;
  size_t e = size_t(line.data() - b.data()) + line.size();
  if (e < b.size() && b[e] == '\r') {
    ++e;
    if (crlf && e < b.size() && b[e] == '\n') ++e;
  } else if (e < b.size() && b[e] == '\n') {
    ++e;
  }
  return e;
}

/// Parses the header up to end_header (at most kMaxHeaderBytes).
Header parse_header(const FileBytes& file) {
  const std::string& b = file.bytes;
  if (b.compare(0, 4, "ply\n") != 0 && b.compare(0, 4, "ply\r") != 0)
    input_error(file.path, "not a PLY file (bad magic: the first line is not 'ply')");
  const bool crlf = b.compare(0, 5, "ply\r\n") == 0;
  Header header;
  bool have_format = false;
  LineCursor lines(b, 0, 1);
  std::string_view line;
  lines.next(line);  // "ply"
  for (;;) {
    if (lines.offset() >= kMaxHeaderBytes)
      input_error(file.path, "header not terminated within 64 KiB (no end_header line)");
    if (!lines.next(line)) input_error(file.path, "header not terminated (no end_header line)");
    const size_t n = lines.line_number();
    const HeaderLine h(line);
    if (h.count == 0) continue;
    const std::string_view key = h.token[0];
    if (key == "comment") continue;
    if (key == "obj_info") {
      parse_obj_info(h, header);
      continue;
    }
    if (key == "end_header") {
      header.data_offset = end_of_line(file, line, crlf);
      header.data_line = n + 1;
      break;
    }
    if (key == "format") {
      if (have_format) input_error(file.path, "duplicate format line" + at_line(n));
      parse_format_line(file, h, n, header);
      have_format = true;
    } else if (key == "element") {
      parse_element_line(file, h, n, header);
    } else if (key == "property") {
      parse_property_line(file, h, n, header);
    } else {
      input_error(file.path, "unknown header keyword " + quote_token(key) + at_line(n));
    }
  }
  if (!have_format) input_error(file.path, "header has no format line");
  return header;
}

/// a + b, saturating at UINT64_MAX.
uint64_t add_sat(uint64_t a, uint64_t b) { return a > UINT64_MAX - b ? UINT64_MAX : a + b; }

/// a * b, saturating at UINT64_MAX.
uint64_t mul_sat(uint64_t a, uint64_t b) {
  return (b != 0 && a > UINT64_MAX / b) ? UINT64_MAX : a * b;
}

/// Checks that the declared rows can fit in the bytes after the header: binary rows need at
/// least their fixed bytes, ascii rows at least two characters per property. Returns the
/// problem, or "" when the sizes are plausible.
std::string check_declared_sizes(const FileBytes& file, const Header& header) {
  const uint64_t remaining = file.bytes.size() - header.data_offset;
  const bool ascii = header.encoding == Encoding::Ascii;
  uint64_t needed = 0;
  for (const Element& e : header.elements) {
    if (e.count > 0 && e.props.empty())
      input_error(file.path, "element " + quote_token(e.name) + " has rows but no properties");
    uint64_t row = 0;
    for (const Property& p : e.props)
      row += ascii ? 2 : scalar_size(p.is_list ? p.count_type : p.type);
    needed = add_sat(needed, mul_sat(e.count, row));
    if (needed > (ascii ? remaining + 1 : remaining))
      return "element " + quote_token(e.name) + " declares " + std::to_string(e.count) + " " +
             plural(e.name) + " of at least " + std::to_string(row) +
             " bytes each, more than the " + std::to_string(remaining) + " bytes after the header" +
             (ascii
                  ? std::string()
                  : " (unexpected end of file at byte " + std::to_string(file.bytes.size()) + ")");
  }
  return "";
}

/// Index of the property named `name` in `e`, or -1.
int find_property(const Element& e, const char* name) {
  for (size_t i = 0; i < e.props.size(); ++i)
    if (e.props[i].name == name) return int(i);
  return -1;
}

/// Maps the vertex properties to coordinates / normals / extras, sizes `cloud` for `e.count`
/// points and notes skipped list properties.
std::vector<Slot> plan_vertex(const FileBytes& file, const Element& e, Cloud& cloud,
                              std::vector<std::string>* warnings) {
  std::vector<Slot> slots(e.props.size());
  const char* coords[3] = {"x", "y", "z"};
  const char* normals[3] = {"nx", "ny", "nz"};
  bool has_normals = true;
  for (int k = 0; k < 3; ++k) {
    const int i = find_property(e, coords[k]);
    if (i < 0)
      input_error(file.path, "vertex element has no '" + std::string(coords[k]) + "' property");
    if (e.props[size_t(i)].is_list)
      input_error(file.path, "vertex property '" + std::string(coords[k]) + "' is a list");
    slots[size_t(i)] = Slot{Slot::Coord, k};
    const int j = find_property(e, normals[k]);
    has_normals = has_normals && j >= 0 && !e.props[size_t(j)].is_list;
  }
  if (has_normals)
    for (int k = 0; k < 3; ++k) slots[size_t(find_property(e, normals[k]))] = Slot{Slot::Normal, k};
  const auto n = Eigen::Index(e.count);
  cloud.points.resize(n, 3);
  cloud.normals.resize(has_normals ? n : 0, 3);
  for (size_t i = 0; i < e.props.size(); ++i) {
    const Property& p = e.props[i];
    if (p.is_list) {
      warn(warnings, "vertex list property '" + p.name + "' not carried to the output");
    } else if (slots[i].kind == Slot::Skip) {
      slots[i] = Slot{Slot::Extra, int(cloud.extras.size())};
      cloud.extras.push_back(ExtraProperty{p.name, p.type, std::vector<double>(size_t(n))});
    }
  }
  return slots;
}

/// "vertex 13 of 1000"
std::string row_name(const Element& e, uint64_t row) {
  return e.name + " " + std::to_string(row) + " of " + std::to_string(e.count);
}

/// Bounds-checked reader of the binary body.
class BinaryBody {
 public:
  BinaryBody(const FileBytes& file, size_t offset, bool swap)
      : file_(file),
        data_(reinterpret_cast<const unsigned char*>(file.bytes.data())),
        size_(file.bytes.size()),
        pos_(offset),
        swap_(swap) {}

  /// Reads one scalar; InputError naming the byte offset when the file ends first.
  double scalar(ScalarType type, const Element& e, uint64_t row) {
    const size_t n = scalar_size(type);
    if (size_ - pos_ < n) truncated(e, row);
    const double v = decode_scalar(data_ + pos_, type, swap_);
    pos_ += n;
    return v;
  }

  /// Skips a list: its length (checked to be a non-negative integer), then its items, which
  /// must lie within the file.
  void skip_list(const Property& p, const Element& e, uint64_t row) {
    const double length = scalar(p.count_type, e, row);
    if (length < 0)
      input_error(file_.path, "negative list length " + std::to_string(int64_t(length)) + " in " +
                                  row_name(e, row));
    const size_t item = scalar_size(p.type);
    if (uint64_t(length) > (size_ - pos_) / item)
      input_error(file_.path,
                  "list of " + std::to_string(uint64_t(length)) + " items in " + row_name(e, row) +
                      " runs past the end of the file (unexpected end of file at byte " +
                      std::to_string(size_) + ")");
    pos_ += size_t(length) * item;
  }

  size_t left() const { return size_ - pos_; }

 private:
  [[noreturn]] void truncated(const Element& e, uint64_t row) {
    input_error(file_.path, "unexpected end of file at byte " + std::to_string(size_) +
                                " (reading " + row_name(e, row) + ")");
  }

  const FileBytes& file_;
  const unsigned char* data_;
  size_t size_;
  size_t pos_;
  bool swap_;
};

/// Reads every element of a binary body; vertex values go to `cloud`.
/// The first camera row's values go to `camera` (one per property, NaN for lists).
void read_binary(const FileBytes& file, const Header& header, const std::vector<Slot>& slots,
                 Cloud& cloud, std::vector<double>& camera, std::vector<std::string>* warnings) {
  const bool big = header.encoding == Encoding::BinaryBig;
  BinaryBody body(file, header.data_offset, big == host_is_little_endian());
  for (const Element& e : header.elements) {
    const bool vertex = e.name == "vertex";
    for (uint64_t r = 0; r < e.count; ++r) {
      const bool cam = e.name == "camera" && r == 0;
      if (cam) camera.assign(e.props.size(), std::nan(""));
      for (size_t i = 0; i < e.props.size(); ++i) {
        const Property& p = e.props[i];
        if (p.is_list) {
          body.skip_list(p, e, r);
        } else {
          const double v = body.scalar(p.type, e, r);
          if (vertex) store(cloud, slots[i], Eigen::Index(r), v);
          if (cam) camera[i] = v;
        }
      }
    }
  }
  if (body.left() > 0)
    warn(warnings, std::to_string(body.left()) + " bytes after the last element ignored");
}

/// Reads one ascii row of `e` from `line`.
/// With `values` (not null), every scalar goes there too (one per property, lists left as NaN).
void read_ascii_row(const FileBytes& file, const Element& e, uint64_t r, std::string_view line,
                    size_t line_no, const std::vector<Slot>* slots, Cloud& cloud,
                    std::vector<double>* values = nullptr) {
  Tokens tokens(line);
  std::string_view t;
  const auto fail = [&](const std::string& what) {
    input_error(file.path, what + " in " + row_name(e, r) + at_line(line_no));
  };
  for (size_t i = 0; i < e.props.size(); ++i) {
    const Property& p = e.props[i];
    if (!tokens.next(t)) fail("too few values");
    if (p.is_list) {
      uint64_t length = 0;
      if (!parse_count(t, UINT32_MAX, length)) fail("invalid list length " + quote_token(t));
      for (uint64_t k = 0; k < length; ++k)
        if (!tokens.next(t))
          fail("list of " + std::to_string(length) + " items runs past the line");
      continue;
    }
    double v = 0;
    if (!parse_double(t, v)) fail("malformed number " + quote_token(t));
    if (is_integer(p.type) && !fits_integer(v, p.type))
      fail("value " + quote_token(t) + " is not a valid " + ply_type_name(p.type));
    if (p.type == ScalarType::Float32) v = double(float(v));  // the declared precision
    if (slots) store(cloud, (*slots)[i], Eigen::Index(r), v);
    if (values) (*values)[i] = v;
  }
  if (!tokens.done()) fail("too many values");
}

/// Reads every element of an ascii body, one row per non-blank line.
/// With `slots` null nothing is stored (a dry run that finds where a short file ends). The first
/// camera row's values go to `camera` when given.
void read_ascii(const FileBytes& file, const Header& header, const std::vector<Slot>* slots,
                Cloud& cloud, std::vector<std::string>* warnings,
                std::vector<double>* camera = nullptr) {
  LineCursor lines(file.bytes, header.data_offset, header.data_line);
  std::string_view line;
  for (const Element& e : header.elements) {
    const std::vector<Slot>* target = e.name == "vertex" ? slots : nullptr;
    for (uint64_t r = 0; r < e.count; ++r) {
      bool got = false;
      while ((got = lines.next(line)) && is_blank_line(line)) {
      }
      if (!got)
        input_error(file.path, "expected " + std::to_string(e.count) + " " + plural(e.name) +
                                   ", file ends after " + std::to_string(r) +
                                   at_line(lines.line_number()));
      const bool cam = camera && e.name == "camera" && r == 0;
      if (cam) camera->assign(e.props.size(), std::nan(""));
      read_ascii_row(file, e, r, line, lines.line_number(), target, cloud, cam ? camera : nullptr);
    }
  }
  size_t extra_lines = 0;
  while (lines.next(line))
    if (!is_blank_line(line)) ++extra_lines;
  if (extra_lines > 0)
    warn(warnings, std::to_string(extra_lines) + " lines after the last element ignored");
}

/// The value of the camera property `name`, NaN when absent.
double camera_value(const Header& header, const std::vector<double>& camera, const char* name) {
  for (const Element& e : header.elements)
    if (e.name == "camera") {
      const int i = find_property(e, name);
      return i < 0 || camera.empty() ? std::nan("") : camera[size_t(i)];
    }
  return std::nan("");
}

/// The grid (camera viewport or obj_info num_cols / num_rows, when they give the vertex count)
/// and the sensor of the camera element (see the top of this file).
void set_sensor(const FileBytes& file, const Header& header, const std::vector<double>& camera,
                Cloud& cloud) {
  const auto grid = [&](double w, double h) {
    if (cloud.organized() || !(w >= 1 && h > 1) || w * h != double(cloud.size())) return;
    cloud.grid_width = int64_t(w);
    cloud.grid_height = int64_t(h);
  };
  grid(camera_value(header, camera, "viewportx"), camera_value(header, camera, "viewporty"));
  grid(double(header.num_cols), double(header.num_rows));
  if (camera.empty()) return;
  const std::array<double, 3> t{camera_value(header, camera, "view_px"),
                                camera_value(header, camera, "view_py"),
                                camera_value(header, camera, "view_pz")};
  if (std::isnan(t[0]) && std::isnan(t[1]) && std::isnan(t[2])) return;  // not PCL's camera
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  const char* axes[3][3] = {{"x_axisx", "x_axisy", "x_axisz"},
                            {"y_axisx", "y_axisy", "y_axisz"},
                            {"z_axisx", "z_axisy", "z_axisz"}};
  for (int a = 0; a < 3; ++a)
    for (int c = 0; c < 3; ++c) {
      const double v = camera_value(header, camera, axes[a][c]);
      if (!std::isnan(v) || a == c) r(a, c) = std::isnan(v) ? 1.0 : v;
    }
  const Sensor s = sensor_from_axes(file.path, t, r, "PLY camera");
  if (cloud.organized() || !default_pose(s)) cloud.sensors.push_back(s);
}

}  // namespace

Cloud read_ply(const FileBytes& file, std::vector<std::string>* warnings) {
  const Header header = parse_header(file);
  const auto vertex = std::find_if(header.elements.begin(), header.elements.end(),
                                   [](const Element& e) { return e.name == "vertex"; });
  if (vertex == header.elements.end()) input_error(file.path, "no vertex element");
  const bool ascii = header.encoding == Encoding::Ascii;
  Cloud cloud;
  const std::string too_big = check_declared_sizes(file, header);  // before any allocation
  if (!too_big.empty()) {
    // An ascii file this short ends early: a dry run reports where, with the line number.
    if (ascii) read_ascii(file, header, nullptr, cloud, nullptr);
    input_error(file.path, too_big);
  }
  const std::vector<Slot> slots = plan_vertex(file, *vertex, cloud, warnings);
  std::vector<double> camera;
  if (ascii)
    read_ascii(file, header, &slots, cloud, warnings, &camera);
  else
    read_binary(file, header, slots, cloud, camera, warnings);
  set_sensor(file, header, camera, cloud);
  for (const Element& e : header.elements)
    if (e.name != "vertex" && e.name != "camera" && e.count > 0)
      warn(warnings, e.name + " element (" + std::to_string(e.count) + " " + plural(e.name) +
                         ") not carried to the output");
  return cloud;
}

// ---------------------------------------------------------------------------------------------
// Writer

namespace {

/// PCL's camera element (see the top of this file): the header lines and the one row, for a
/// cloud with a single sensor or a grid; "" otherwise.
std::string camera_header(const Cloud& cloud) {
  if (!single_sensor(cloud) && !cloud.organized()) return "";
  std::string h = "element camera 1\n";
  for (const char* name : {"view_px", "view_py", "view_pz", "x_axisx", "x_axisy", "x_axisz",
                           "y_axisx", "y_axisy", "y_axisz", "z_axisx", "z_axisy", "z_axisz",
                           "focal", "scalex", "scaley", "centerx", "centery"})
    h += std::string("property float ") + name + "\n";
  return h +
         "property int viewportx\nproperty int viewporty\nproperty float k1\n"
         "property float k2\n";
}

void camera_row(const Cloud& cloud, bool ascii, std::string& out) {
  const Sensor* s = single_sensor(cloud);
  const Sensor origin;
  const Sensor& cam = s ? *s : origin;
  std::vector<std::pair<double, ScalarType>> v;
  for (int d = 0; d < 3; ++d) v.emplace_back(cam.position[d], ScalarType::Float32);
  for (int a = 0; a < 3; ++a)
    for (int c = 0; c < 3; ++c) v.emplace_back(cam.rotation(a, c), ScalarType::Float32);
  for (int i = 0; i < 5; ++i) v.emplace_back(0.0, ScalarType::Float32);
  const bool grid = cloud.organized();
  v.emplace_back(grid ? double(cloud.grid_width) : double(cloud.size()), ScalarType::Int32);
  v.emplace_back(grid ? double(cloud.grid_height) : 1.0, ScalarType::Int32);
  for (int i = 0; i < 2; ++i) v.emplace_back(0.0, ScalarType::Float32);
  for (size_t i = 0; i < v.size(); ++i) {
    if (ascii) {
      if (i > 0) out += ' ';
      append_number(v[i].first, v[i].second, out);
    } else {
      encode_scalar_le(v[i].first, v[i].second, out);
    }
  }
  if (ascii) out += '\n';
}

}  // namespace

void write_ply(Sink& sink, const Cloud& cloud, bool ascii) {
  const char* const normal_names[3] = {"nx", "ny", "nz"};
  const std::vector<Column> cols = cloud_columns(cloud, normal_names);
  std::string out = "ply\nformat ";
  out += ascii ? "ascii" : "binary_little_endian";
  out += " 1.0\ncomment written by nhnet\nelement vertex " + std::to_string(cloud.size()) + "\n";
  for (const Column& c : cols)
    out += std::string("property ") + ply_type_name(c.type) + " " + c.name + "\n";
  const std::string camera = camera_header(cloud);
  out += camera + "end_header\n";
  write_rows(sink, cols, cloud.size(), ascii, out);
  if (camera.empty()) return;
  std::string row;
  camera_row(cloud, ascii, row);
  sink.write(row);
}

}  // namespace nhnet::io_detail
