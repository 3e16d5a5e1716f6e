// XYZ text reader and writer: "x y z" or "x y z nx ny nz" per line, whitespace separated.
//
// Reader: blank lines and lines starting with '#' are skipped; every data line must have the
// same number of columns (at least 3); columns 3..5 are normals when there are 6 or more,
// every other column beyond x y z becomes a Float64 extra "scalar_<column>". A single integer
// on the first data line (the point count of .pts files) is skipped. Malformed tokens are errors
// with the line number; nan/inf are kept. Writer: shortest text that reads back bit-exact.
#include "io_detail.hpp"

namespace nhnet::io_detail {
namespace {

/// Most columns accepted on one line (bounds the work spent on a garbage line).
constexpr size_t kMaxColumns = 4096;

std::string at_line(size_t line) { return " (line " + std::to_string(line) + ")"; }

/// Parses the numbers of one data line, appending them to `values`; returns their count.
size_t parse_line(const FileBytes& file, std::string_view line, size_t line_no,
                  size_t expected, std::vector<double>& values) {
  Tokens tokens(line);
  std::string_view t;
  size_t n = 0;
  const size_t limit = expected ? expected : kMaxColumns;
  while (tokens.next(t)) {
    if (++n > limit) break;
    double v = 0;
    if (!parse_double(t, v))
      input_error(file.path, "malformed number " + quote_token(t) + " in column " + std::to_string(n) +
                                 at_line(line_no));
    values.push_back(v);
  }
  if (n > limit && !expected)
    input_error(file.path, "more than " + std::to_string(kMaxColumns) + " columns" + at_line(line_no));
  if (expected && n != expected) {
    while (tokens.next(t)) ++n;
    input_error(file.path, "ragged line: " + std::to_string(n) + " columns, expected " +
                               std::to_string(expected) + " like the first data line" +
                               at_line(line_no));
  }
  return n;
}

/// True when the line is a lone non-negative integer (a .pts point count).
bool is_count_line(std::string_view line, uint64_t& count) {
  Tokens tokens(line);
  std::string_view t;
  return tokens.next(t) && parse_count(t, kMaxCount, count) && tokens.done();
}

/// Builds the cloud from row-major values with `columns` per point.
Cloud assemble(const std::vector<double>& values, size_t columns) {
  const size_t n = columns ? values.size() / columns : 0;
  Cloud cloud;
  cloud.points.resize(Eigen::Index(n), 3);
  const bool normals = columns >= 6;
  cloud.normals.resize(normals ? Eigen::Index(n) : 0, 3);
  for (size_t c = 3; c < columns; ++c) {
    if (normals && c < 6) continue;
    cloud.extras.push_back(
        ExtraProperty{"scalar_" + std::to_string(c), ScalarType::Float64, std::vector<double>(n)});
  }
  for (size_t i = 0; i < n; ++i) {
    const double* row = values.data() + i * columns;
    size_t extra = 0;
    for (size_t c = 0; c < columns; ++c) {
      if (c < 3) cloud.points(Eigen::Index(i), Eigen::Index(c)) = row[c];
      else if (normals && c < 6) cloud.normals(Eigen::Index(i), Eigen::Index(c - 3)) = row[c];
      else cloud.extras[extra++].values[i] = row[c];
    }
  }
  return cloud;
}

}  // namespace

Cloud read_xyz(const FileBytes& file, std::vector<std::string>* warnings) {
  LineCursor lines(file.bytes, 0, 1);
  std::string_view line;
  std::vector<double> values;
  size_t columns = 0;
  bool first = true;
  uint64_t declared = 0;
  bool has_declared = false;
  while (lines.next(line)) {
    Tokens tokens(line);
    std::string_view t;
    if (!tokens.next(t) || t[0] == '#') continue;
    const size_t n = lines.line_number();
    if (first && is_count_line(line, declared)) {
      first = false;
      has_declared = true;
      continue;
    }
    first = false;
    const size_t got = parse_line(file, line, n, columns, values);
    if (columns == 0) {
      if (got < 3)
        input_error(file.path, "expected at least 3 columns (x y z), found " + std::to_string(got) +
                                   at_line(n));
      columns = got;
    }
  }
  if (columns == 0) input_error(file.path, "no points (only blank or comment lines)");
  const Cloud cloud = assemble(values, columns);
  if (has_declared && declared != uint64_t(cloud.size()))
    warn(warnings, "point count line says " + std::to_string(declared) + " but the file has " +
                       std::to_string(cloud.size()) + " points");
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
    out += '\n';
    if (out.size() >= (size_t(1) << 16)) {
      sink.write(out);
      out.clear();
    }
  }
  sink.write(out);
}

}  // namespace nhnet::io_detail
