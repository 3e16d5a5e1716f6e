// XYZ text reader and writer: "x y z" or "x y z nx ny nz" per line, whitespace separated.
//
// Reader: blank lines and lines starting with '#' are skipped; every data line must have the
// same number of columns (at least 3); columns 3..5 are normals when there are 6 or more,
// every other column beyond x y z becomes a Float64 extra "scalar_<column>". A single integer
// on the first data line (the point count of .pts files) is skipped. Malformed tokens are errors
// with the line number; nan/inf are kept. Writer: shortest text that reads back bit-exact.
#include "io/detail.hpp"

namespace nhnet::io_detail {
namespace {

std::string at_line(size_t line) { return " (line " + std::to_string(line) + ")"; }

/// An empty cloud of `n` points with `columns` per point (normals from 6 columns on).
Cloud allocate(size_t n, size_t columns) {
  Cloud cloud;
  cloud.points.resize(Eigen::Index(n), 3);
  const bool normals = columns >= 6;
  cloud.normals.resize(normals ? Eigen::Index(n) : 0, 3);
  for (size_t c = 3; c < columns; ++c) {
    if (normals && c < 6) continue;
    cloud.extras.push_back(
        ExtraProperty{"scalar_" + std::to_string(c), ScalarType::Float64, std::vector<double>(n)});
  }
  return cloud;
}

/// Stores one point's `columns` values as row i of the cloud.
void store(Cloud& cloud, size_t i, const double* row, size_t columns) {
  const bool normals = columns >= 6;
  size_t extra = 0;
  for (size_t c = 0; c < columns; ++c) {
    if (c < 3)
      cloud.points(Eigen::Index(i), Eigen::Index(c)) = row[c];
    else if (normals && c < 6)
      cloud.normals(Eigen::Index(i), Eigen::Index(c - 3)) = row[c];
    else
      cloud.extras[extra++].values[i] = row[c];
  }
}

// Parses the numbers of one data line, appending them to `values`; returns their count.
// `expected` = 0: any count up to kMaxXyzColumns; else exactly that many (a ragged line is an
// InputError naming `path` and `line_no`).
size_t parse_xyz_line(const std::string& path, std::string_view line, size_t line_no,
                      size_t expected, std::vector<double>& values) {
  Tokens tokens(line);
  std::string_view t;
  size_t n = 0;
  const size_t limit = expected ? expected : kMaxXyzColumns;
  while (tokens.next(t)) {
    if (++n > limit) break;
    double v = 0;
    if (!parse_double(t, v))
      input_error(path, "malformed number " + quote_token(t) + " in column " + std::to_string(n) +
                            at_line(line_no));
    values.push_back(v);
  }
  if (n > limit && !expected)
    input_error(path,
                "more than " + std::to_string(kMaxXyzColumns) + " columns" + at_line(line_no));
  if (expected && n != expected) {
    while (tokens.next(t)) ++n;
    input_error(path, "ragged line: " + std::to_string(n) + " columns, expected " +
                          std::to_string(expected) + " like the first data line" +
                          at_line(line_no));
  }
  return n;
}

// True when the line is a lone non-negative integer (a .pts point count).
bool is_xyz_count_line(std::string_view line, uint64_t& count) {
  Tokens tokens(line);
  std::string_view t;
  return tokens.next(t) && parse_count(t, kMaxCount, count) && tokens.done();
}

// Next line with data (not blank, not a '#' comment); false at the end.
bool next_xyz_data_line(LineCursor& lines, std::string_view& line) {
  while (lines.next(line)) {
    Tokens tokens(line);
    std::string_view t;
    if (tokens.next(t) && t[0] != '#') return true;
  }
  return false;
}

}  // namespace

bool XyzLines::next(LineCursor& lines) {
  while (next_xyz_data_line(lines, line_)) {
    line_no_ = lines.line_number();
    if (first_ && is_xyz_count_line(line_, declared_)) {
      first_ = false;
      has_declared_ = true;
      continue;
    }
    first_ = false;
    return true;
  }
  return false;
}

void XyzLines::parse(std::vector<double>& values) {
  values.clear();
  if (columns_ != 0) {
    parse_xyz_line(path_, line_, line_no_, columns_, values);
    return;
  }
  const size_t got = parse_xyz_line(path_, line_, line_no_, 0, values);
  if (got < 3)
    input_error(path_, "expected at least 3 columns (x y z), found " + std::to_string(got) +
                           at_line(line_no_));
  columns_ = got;
}

void XyzLines::require_points() const {
  if (columns_ == 0) input_error(path_, "no points (only blank or comment lines)");
}

std::string XyzLines::count_mismatch(uint64_t points) const {
  if (!has_declared_ || declared_ == points) return std::string();
  return "point count line says " + std::to_string(declared_) + " but the file has " +
         std::to_string(points) + " points";
}

// Two passes over the bytes: the first finds the columns (first data line) and counts the data
// lines, the second parses every line straight into the cloud, so memory is the file plus the
// cloud (no growing intermediate array of every value: at 10M points that was 2-3x the cloud).
Cloud read_xyz(const FileBytes& file, std::vector<std::string>* warnings) {
  XyzLines scan(file.path);
  size_t count = 0;
  {
    LineCursor lines(file.bytes, 0, 1);
    std::vector<double> values;
    while (scan.next(lines)) {
      if (scan.columns() == 0) scan.parse(values);
      ++count;
    }
  }
  scan.require_points();
  const size_t columns = scan.columns();
  Cloud cloud = allocate(count, columns);
  XyzLines rows(file.path, columns);
  LineCursor lines(file.bytes, 0, 1);
  std::vector<double> row;
  row.reserve(columns);
  size_t i = 0;
  while (rows.next(lines)) {
    rows.parse(row);
    store(cloud, i++, row.data(), columns);
  }
  const std::string mismatch = scan.count_mismatch(uint64_t(cloud.size()));
  if (!mismatch.empty()) warn(warnings, mismatch);
  return cloud;
}

void write_xyz(Sink& sink, const Cloud& cloud) {
  const bool normals = cloud.has_normals();
  std::string out;
  for (Eigen::Index i = 0; i < cloud.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      if (k > 0) out += ' ';
      append_number(cloud.points(i, k), ScalarType::Float64, out);
    }
    for (int k = 0; normals && k < 3; ++k) {
      out += ' ';
      append_number(cloud.normals(i, k), ScalarType::Float64, out);
    }
    if (cloud.confidence.size() != 0) {
      out += ' ';
      append_number(cloud.confidence[i], ScalarType::Float32, out);
    }
    out += '\n';
    if (out.size() >= (size_t(1) << 16)) {
      sink.write(out);
      out.clear();
    }
  }
  sink.write(out);
}

}  // namespace nhnet::io_detail
