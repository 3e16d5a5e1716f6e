// Out-of-core estimation (not a paper stage; issue 10: a cloud larger than RAM completes).
// The in-memory tiling (tiling.cpp) holds the whole cloud; this driver holds one tile. Passes:
//  1. scan the XYZ text file in chunks: point count, bounding box, a reservoir sample;
//  2. place the tile boundaries on the sample (the same recursive longest-axis quantile splits
//     as the in-memory tiling) and bin every finite point into its tile's file on disk;
//  3. the noise probe, tile by tile on each tile's own points (an evenly spaced subset, only
//     points whose probe neighbourhood lies inside their tile's cell); one estimate_noise() over
//     all of them gives the whole cloud's noise level, spacing and neighbourhood radius;
//  4. (MFPS, NH-Net) every point's surface variation at the smooth size, tile by tile with a
//     halo, for the whole cloud's candidate threshold (feature_detection.hpp);
//  5. the estimator (estimate_cloud) on each tile plus its halo (points of the neighbouring tiles' files
//     within tile_halo radii of the largest neighbourhood), with the whole cloud's decisions;
//     the tile's own results go to its result file in input order;
//  6. read the input again and write the output in the input's order (temporary file +
//     rename), each point's normal taken from its tile's result file (the routing is a pure
//     function of the coordinates), oriented chunk by chunk (keep / viewpoint).
// Memory: one tile's working set, the plan sample, the probe rows and at most variation_sample
// floats; disk: 32 bytes per point (tiles) + 12 (results).
#include "nhnet/pipeline/stream.hpp"

#include "io/detail.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/geometry/feature_detection.hpp"
#include "nhnet/io/io.hpp"
#include "nhnet/neighbors/neighbors.hpp"
#include "nhnet/learned/nhnet_model.hpp"
#include "nhnet/geometry/pca.hpp"
#include "nhnet/geometry/scales.hpp"
#include "util/parallel.hpp"
#include "util/stats.hpp"
#include "pipeline/estimator.hpp"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>
#include <set>

namespace nhnet {
namespace {

namespace fs = std::filesystem;
using io_detail::input_error;

constexpr double kInf = std::numeric_limits<double>::infinity();

/// True when the row's x y z (its first three values) are all finite.
bool finite_xyz(const double* v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }

// ---------------------------------------------------------------------------------------------
// Input: the XYZ text file, chunk by chunk (io_xyz.cpp's line rules).

class XyzStream {
 public:
  explicit XyzStream(std::string path) : path_(std::move(path)) {
    std::error_code ec;
    size_ = fs::file_size(path_, ec);
    if (ec) input_error(path_, "cannot read: " + ec.message());
  }

  /// Calls row(index, values, columns) for every data line, in order; progress(fraction of the
  /// bytes) after each chunk (returns false to stop). Returns the number of data lines.
  template <class Row, class Report>
  int64_t for_each(Row&& row, Report&& progress) {
    std::FILE* f = std::fopen(path_.c_str(), "rb");
    if (!f) input_error(path_, std::string("cannot open: ") + std::strerror(errno));
    struct Closer {
      std::FILE* f;
      ~Closer() { std::fclose(f); }
    } closer{f};
    std::string buf;
    std::vector<double> values;
    size_t line_no = 1, done_bytes = 0;
    int64_t index = 0;
    bool first = true, has_declared = false;
    uint64_t declared = 0;
    std::vector<char> chunk(kChunk);
    for (bool eof = false; !eof;) {
      const size_t got = std::fread(chunk.data(), 1, chunk.size(), f);
      if (got < chunk.size()) {
        if (std::ferror(f)) input_error(path_, "read error");
        eof = true;
      }
      done_bytes += got;
      buf.append(chunk.data(), got);
      // Lines complete in this buffer: up to the last '\n' (a '\r' at the very end may be half
      // of a "\r\n" that the next chunk completes).
      size_t cut = buf.size();
      if (!eof) {
        const size_t nl = buf.rfind('\n');
        if (nl != std::string::npos) {
          cut = nl + 1;
        } else {
          const size_t cr = buf.size() > 1 ? buf.rfind('\r', buf.size() - 2) : std::string::npos;
          cut = cr == std::string::npos ? 0 : cr + 1;
        }
        if (cut == 0 && buf.size() > kMaxLine)
          input_error(path_, "a line longer than " + std::to_string(kMaxLine) + " bytes" +
                                 " (line " + std::to_string(line_no) + ")");
      }
      io_detail::LineCursor lines(std::string_view(buf.data(), cut), 0, line_no);
      std::string_view line;
      while (io_detail::next_xyz_data_line(lines, line)) {
        if (first && io_detail::is_xyz_count_line(line, declared)) {
          first = false;
          has_declared = true;
          continue;
        }
        first = false;
        values.clear();
        if (columns_ == 0) {
          const size_t got_cols = io_detail::parse_xyz_line(path_, line, lines.line_number(), 0, values);
          if (got_cols < 3)
            input_error(path_, "expected at least 3 columns (x y z), found " +
                                   std::to_string(got_cols) + " (line " +
                                   std::to_string(lines.line_number()) + ")");
          columns_ = got_cols;
        } else {
          io_detail::parse_xyz_line(path_, line, lines.line_number(), columns_, values);
        }
        row(index++, values.data(), columns_);
      }
      // Line numbers continue after the consumed part (count its terminators once more).
      line_no = count_lines(buf, cut, line_no);
      buf.erase(0, cut);
      if (!progress(size_ ? double(done_bytes) / double(size_) : 1.0)) return index;
    }
    if (columns_ == 0) input_error(path_, "no points (only blank or comment lines)");
    if (has_declared && declared != uint64_t(index))
      declared_mismatch_ = "point count line says " + std::to_string(declared) +
                           " but the file has " + std::to_string(index) + " points";
    return index;
  }

  size_t columns() const { return columns_; }
  const std::string& path() const { return path_; }
  /// Non-empty when a .pts count line disagrees with the points read.
  const std::string& declared_mismatch() const { return declared_mismatch_; }

 private:
  static constexpr size_t kChunk = size_t(16) << 20;
  static constexpr size_t kMaxLine = size_t(64) << 20;

  // Line number after buf[0, cut) that starts at line `first`: "\r\n", "\r", "\n" count once.
  static size_t count_lines(const std::string& buf, size_t cut, size_t first) {
    size_t n = first;
    for (size_t i = 0; i < cut; ++i) {
      if (buf[i] == '\n') ++n;
      else if (buf[i] == '\r' && !(i + 1 < cut && buf[i + 1] == '\n')) ++n;
    }
    return n;
  }

  std::string path_;
  uintmax_t size_ = 0;
  size_t columns_ = 0;
  std::string declared_mismatch_;
};

// ---------------------------------------------------------------------------------------------
// The tile plan: a kd-tree of split planes placed on a sample.

struct Frame {
  Eigen::RowVector3d centre = Eigen::RowVector3d::Zero();
  double scale = 1;  // frame length = scale x input length (a power of two)
  Eigen::RowVector3d to_frame(const double* p) const {
    return (Eigen::RowVector3d(p[0], p[1], p[2]) - centre) * scale;
  }
};

struct Plan {
  struct Node {
    int axis = -1;     // -1: leaf
    double value = 0;  // coordinate < value: left
    int left = -1, right = -1, leaf = -1;
  };
  std::vector<Node> nodes;
  // Leaf cells (frame units; +-inf where unbounded).
  std::vector<Eigen::RowVector3d> cell_lo, cell_hi;

  int route(const Eigen::RowVector3d& p) const {
    int n = 0;
    while (nodes[size_t(n)].axis >= 0)
      n = p[nodes[size_t(n)].axis] < nodes[size_t(n)].value ? nodes[size_t(n)].left
                                                           : nodes[size_t(n)].right;
    return nodes[size_t(n)].leaf;
  }

  // Splits sample rows order[begin, end) into `parts` leaves (detail::split_range, the in-memory
  // tiling's rule); points at a cut's value go right.
  int build(const Points& s, std::vector<int64_t>& order, int64_t begin, int64_t end, int64_t parts,
            Eigen::RowVector3d lo_cell, Eigen::RowVector3d hi_cell) {
    const int id = int(nodes.size());
    nodes.emplace_back();
    if (parts <= 1 || end - begin < 2) {
      nodes[size_t(id)].leaf = int(cell_lo.size());
      cell_lo.push_back(lo_cell);
      cell_hi.push_back(hi_cell);
      return id;
    }
    const detail::RangeCut cut = detail::split_range(s, order, begin, end, parts);
    const int axis = cut.axis;
    const double value = cut.value;
    const int64_t mid = cut.mid, left = parts / 2;
    Eigen::RowVector3d hi_left = hi_cell, lo_right = lo_cell;
    hi_left[axis] = value;
    lo_right[axis] = value;
    const int l = build(s, order, begin, mid, left, lo_cell, hi_left);
    const int r = build(s, order, mid, end, parts - left, lo_right, hi_cell);
    nodes[size_t(id)].axis = axis;
    nodes[size_t(id)].value = value;
    nodes[size_t(id)].left = l;
    nodes[size_t(id)].right = r;
    return id;
  }

  size_t tiles() const { return cell_lo.size(); }
};

// ---------------------------------------------------------------------------------------------
// Temporary files.

/// A fresh folder `<parent>/.nhnet-stream-<pid>-<random>`, removed with everything in it.
class TempDir {
 public:
  explicit TempDir(const fs::path& parent) {
    std::random_device device;
    std::error_code ec;
    for (int attempt = 0; attempt < 16; ++attempt) {
      const fs::path p = parent / (".nhnet-stream-" + std::to_string(::getpid()) + "-" +
                                   std::to_string((uint64_t(device()) << 32) ^ device()));
      if (fs::create_directory(p, ec)) {
        path_ = p;
        return;
      }
      if (ec) break;
    }
    throw OutputError(parent.string() + ": cannot create a temporary folder for the tiles" +
                      (ec ? ": " + ec.message() : std::string()));
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  fs::path file(const std::string& name) const { return path_ / name; }

 private:
  fs::path path_;
};

/// Appends fixed-size records to a file, a buffer at a time (the file is opened per flush, so
/// thousands of tiles need no open descriptors).
class Appender {
 public:
  explicit Appender(fs::path path) : path_(std::move(path)) {}
  void add(const void* data, size_t size) {
    buf_.append(static_cast<const char*>(data), size);
    if (buf_.size() >= kBuffer) flush();
  }
  void flush() {
    if (buf_.empty()) return;
    std::FILE* f = std::fopen(path_.c_str(), "ab");
    const bool ok = f && std::fwrite(buf_.data(), 1, buf_.size(), f) == buf_.size();
    if (f && std::fclose(f) != 0) fail();
    if (!ok) fail();
    buf_.clear();
  }

 private:
  static constexpr size_t kBuffer = size_t(1) << 16;
  [[noreturn]] void fail() const {
    throw OutputError(path_.string() + ": cannot write a temporary tile file: " +
                      std::strerror(errno) + " (is the disk full? set the temporary folder)");
  }
  fs::path path_;
  std::string buf_;
};

/// Reads a whole temporary file.
std::string slurp(const fs::path& path) {
  std::string out;
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return out;  // a tile without points has no file
  char buf[1 << 16];
  for (size_t n; (n = std::fread(buf, 1, sizeof buf, f)) > 0;) out.append(buf, n);
  const bool bad = std::ferror(f);
  std::fclose(f);
  if (bad) throw InputError(path.string() + ": cannot read a temporary tile file");
  return out;
}

/// Sequential reader of fixed-size records, reopening the file per refill.
class Cursor {
 public:
  Cursor(fs::path path, size_t record) : path_(std::move(path)), record_(record) {}
  const char* next() {
    if (pos_ + record_ > buf_.size()) refill();
    const char* p = buf_.data() + pos_;
    pos_ += record_;
    return p;
  }

 private:
  void refill() {
    buf_.erase(0, pos_);
    pos_ = 0;
    std::FILE* f = std::fopen(path_.c_str(), "rb");
    if (!f || std::fseek(f, long(offset_), SEEK_SET) != 0) {
      if (f) std::fclose(f);
      throw InputError(path_.string() + ": cannot read a temporary result file");
    }
    char tmp[1 << 16];
    const size_t n = std::fread(tmp, 1, sizeof tmp, f);
    std::fclose(f);
    offset_ += n;
    buf_.append(tmp, n);
    if (buf_.size() < record_)
      throw InputError(path_.string() + ": temporary result file ends early");
  }
  fs::path path_;
  size_t record_;
  std::string buf_;
  size_t pos_ = 0;
  uint64_t offset_ = 0;
};

struct PointRecord {
  int64_t row;
  double p[3];
};

struct Box {
  Eigen::RowVector3d lo = Eigen::RowVector3d::Constant(kInf);
  Eigen::RowVector3d hi = Eigen::RowVector3d::Constant(-kInf);
  bool meets(const Box& o, double margin) const {
    return ((lo.array() - margin) <= o.hi.array()).all() && ((hi.array() + margin) >= o.lo.array()).all();
  }
};

/// A tile's points: its own (first `own`, input order) then its halo.
struct TilePoints {
  Points pts;
  std::vector<int64_t> rows;
  size_t own = 0;
};

class Tiles {
 public:
  Tiles(const TempDir& dir, size_t count) : dir_(dir), boxes_(count), counts_(count, 0) {
    for (size_t t = 0; t < count; ++t) out_.emplace_back(point_file(t));
  }
  void add(int t, int64_t row, const Eigen::RowVector3d& p) {
    const PointRecord r{row, {p[0], p[1], p[2]}};
    out_[size_t(t)].add(&r, sizeof r);
    boxes_[size_t(t)].lo = boxes_[size_t(t)].lo.cwiseMin(p);
    boxes_[size_t(t)].hi = boxes_[size_t(t)].hi.cwiseMax(p);
    ++counts_[size_t(t)];
  }
  void finish() {
    for (Appender& a : out_) a.flush();
    out_.clear();
  }
  size_t size() const { return counts_.size(); }
  int64_t count(size_t t) const { return counts_[t]; }

  /// Tile t's own points and every point of the other tiles within `halo` of its box.
  TilePoints load(size_t t, double halo) const {
    TilePoints tp;
    std::vector<Eigen::RowVector3d> p;
    append(tp, p, t, nullptr, 0);
    tp.own = tp.rows.size();
    if (halo > 0)
      for (size_t u = 0; u < size(); ++u)
        if (u != t && counts_[u] > 0 && boxes_[u].meets(boxes_[t], halo)) append(tp, p, u, &boxes_[t], halo);
    tp.pts.resize(Eigen::Index(p.size()), 3);
    for (size_t i = 0; i < p.size(); ++i) tp.pts.row(Eigen::Index(i)) = p[i];
    return tp;
  }

  fs::path result_file(size_t t) const { return dir_.file("result-" + std::to_string(t)); }

 private:
  fs::path point_file(size_t t) const { return dir_.file("tile-" + std::to_string(t)); }
  void append(TilePoints& tp, std::vector<Eigen::RowVector3d>& p, size_t u, const Box* near,
              double halo) const {
    const std::string bytes = slurp(point_file(u));
    const size_t n = bytes.size() / sizeof(PointRecord);
    for (size_t i = 0; i < n; ++i) {
      PointRecord r;
      std::memcpy(&r, bytes.data() + i * sizeof r, sizeof r);
      const Eigen::RowVector3d q(r.p[0], r.p[1], r.p[2]);
      if (near && !(((q.array() >= near->lo.array() - halo) && (q.array() <= near->hi.array() + halo)).all()))
        continue;
      p.push_back(q);
      tp.rows.push_back(r.row);
    }
  }

  const TempDir& dir_;
  std::vector<Box> boxes_;
  std::vector<int64_t> counts_;
  std::vector<Appender> out_;
};

/// Output format from the extension: PLY or XYZ text (PCD is not written in stream mode).
bool output_is_ply(const std::string& output) {
  const FileFormat f = format_from_extension(output);
  if (f == FileFormat::Ply) return true;
  if (f == FileFormat::Xyz) return false;
  throw InvalidOptions(output + ": streaming writes .ply or .xyz / .xyzn / .txt output, not " +
                       (f == FileFormat::Pcd ? std::string("PCD") : "this extension"));
}

/// Refuses inputs that are not XYZ text (by extension and by their first bytes).
void check_xyz_input(const std::string& input) {
  const FileFormat f = format_from_extension(input);
  std::FILE* fp = std::fopen(input.c_str(), "rb");
  if (!fp) input_error(input, std::string("cannot open: ") + std::strerror(errno));
  char head[16] = {};
  const size_t n = std::fread(head, 1, sizeof head, fp);
  std::fclose(fp);
  const std::string_view h(head, n);
  const bool ply = h.substr(0, 3) == "ply";
  const bool pcd = h.substr(0, 6) == "# .PCD" || h.substr(0, 7) == "VERSION";
  if (f == FileFormat::Ply || f == FileFormat::Pcd || ply || pcd)
    throw InvalidOptions(input + ": streaming reads XYZ text (x y z per line); this is a " +
                         std::string(ply || f == FileFormat::Ply ? "PLY" : "PCD") +
                         " file: process it without streaming, or convert it to .xyz");
}

}  // namespace

StreamResult estimate_stream(const std::string& input, const std::string& output,
                             const StreamOptions& options) {
  const EstimateOptions& eo = options.estimate;
  detail::check_options(eo);
  if (eo.tiles.points <= 0) throw InvalidOptions("streaming needs tile points > 0");
  if (options.orient.mode == OrientMode::Mst)
    throw InvalidOptions("--orient mst needs the whole cloud in memory; with streaming use "
                         "none, keep or viewpoint X Y Z");
  if (options.plan_sample < 1000 || options.variation_sample < 1000)
    throw InvalidOptions("plan and variation samples must be at least 1000 points");
  const bool ply = output_is_ply(output);
  check_xyz_input(input);
  {
    std::error_code ec;
    if (fs::equivalent(input, output, ec))
      throw InvalidOptions(output + ": the output would replace the input; choose another name");
  }
  // The output's temporary file first: an unwritable folder fails before any work.
  io_detail::AtomicFile file(output);
  detail::start_threads(eo.run.threads);
  const RunContext& run = eo.run;
  detail::Progress top(run.progress);
  StreamResult res;

  // 1. Scan: count, box, reservoir sample, whether the coordinates fit float.
  XyzStream in(input);
  Eigen::RowVector3d lo = Eigen::RowVector3d::Constant(kInf), hi = -lo;
  std::vector<std::array<double, 3>> sample;
  std::mt19937_64 rng(eo.mfps.seed);
  int64_t finite = 0;
  bool fits_float = true;
  if (run.progress) top.stage("reading", 0, 0.05);
  res.points = in.for_each(
      [&](int64_t, const double* v, size_t) {
        for (int k = 0; k < 3; ++k) fits_float = fits_float && (std::isnan(v[k]) || double(float(v[k])) == v[k]);
        if (!finite_xyz(v)) return;
        const Eigen::RowVector3d p(v[0], v[1], v[2]);
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
        if (int64_t(sample.size()) < options.plan_sample) {
          sample.push_back({v[0], v[1], v[2]});
        } else {
          const uint64_t j = rng() % uint64_t(finite + 1);
          if (j < uint64_t(options.plan_sample)) sample[size_t(j)] = {v[0], v[1], v[2]};
        }
        ++finite;
      },
      [&](double f) { return top.report(f); });
  top.throw_if_cancelled();
  if (!in.declared_mismatch().empty()) res.warnings.push_back(in.declared_mismatch());
  if (finite < res.points)
    res.warnings.push_back(std::to_string(res.points - finite) +
                           " non-finite points skipped (reported as failed)");
  if (finite < 3)
    throw UnprocessableInput("only " + std::to_string(finite) + " finite points; at least 3 are needed");
  if (in.columns() > 6 || in.columns() == 4 || in.columns() == 5)
    res.warnings.push_back("streaming writes x y z nx ny nz only: the input's other " +
                           std::to_string(in.columns() - (in.columns() >= 6 ? 6 : 3)) +
                           " columns are not carried over");

  // The frame: centred on the box, scaled by a power of two into [-2, 2) (see normalise()).
  Frame frame;
  frame.centre = (lo + hi) / 2;
  const double half = ((hi - lo) / 2).maxCoeff();
  if (half > 0 && std::isfinite(half)) frame.scale = std::ldexp(1.0, -std::ilogb(half));

  // 2. Plan and bin.
  Points s(Eigen::Index(sample.size()), 3);
  for (size_t i = 0; i < sample.size(); ++i) s.row(Eigen::Index(i)) = frame.to_frame(sample[i].data());
  std::vector<std::array<double, 3>>().swap(sample);
  Plan plan;
  {
    std::vector<int64_t> order(size_t(s.rows()));
    for (size_t i = 0; i < order.size(); ++i) order[i] = int64_t(i);
    const int64_t parts = (finite + eo.tiles.points - 1) / eo.tiles.points;
    plan.build(s, order, 0, int64_t(order.size()), parts, Eigen::RowVector3d::Constant(-kInf),
               Eigen::RowVector3d::Constant(kInf));
  }
  const size_t ntiles = plan.tiles();
  const fs::path out_dir = fs::path(output).parent_path();
  TempDir tmp(options.temp_dir.empty() ? (out_dir.empty() ? fs::path(".") : out_dir)
                                       : fs::path(options.temp_dir));
  Tiles tiles(tmp, ntiles);
  if (run.progress) top.stage("binning", 0.05, 0.1);
  in.for_each(
      [&](int64_t row, const double* v, size_t) {
        if (!finite_xyz(v)) return;
        const Eigen::RowVector3d p = frame.to_frame(v);
        tiles.add(plan.route(p), row, p);
      },
      [&](double f) { return top.report(f); });
  top.throw_if_cancelled();
  tiles.finish();

  // 3. Noise probe: every probe_step-th own point of each tile (the in-memory run probes every
  // point of clouds up to kProbeAllPoints, an evenly spaced subset of larger ones), with a halo
  // of twice a rough probe radius so that the neighbourhoods are complete. The rough radius comes
  // from a sparse first pass on the tiles' own points, keeping only points whose neighbourhood
  // lies inside their tile's cell.
  if (run.progress) top.stage("noise probe", 0.1, 0.15);
  std::vector<std::vector<float>> probe_d2;  // rows of squared distances (frame units)
  std::vector<double> probe_residual;
  int kprobe = 0;
  const auto probe_pass = [&](int64_t step, double halo, double progress_begin, double progress_end) {
    probe_d2.clear();
    probe_residual.clear();
    for (size_t t = 0; t < ntiles; ++t) {
      if (tiles.count(t) < 3) continue;
      const TilePoints tp = tiles.load(t, halo);
      std::vector<std::string> ignored;
      const detail::Canonical canon = detail::canonical_points(tp.pts, ignored);
      const int k = int(std::min<Eigen::Index>(kNoiseProbeK, canon.pts.rows()));
      if (k < 4) continue;
      kprobe = kprobe ? std::min(kprobe, k) : k;
      std::vector<int64_t> rows;
      int64_t own = 0;
      for (Eigen::Index i = 0; i < canon.pts.rows(); ++i)
        if (size_t(canon.rows[size_t(i)]) < tp.own && own++ % step == 0) rows.push_back(i);
      const Neighbors tree(canon.pts);
      IndexMatrix idx;
      DistanceMatrix d2;
      tree.knn_rows(k, rows, idx, &d2, RunContext{run.threads, {}});
      const Eigen::RowVector3d& clo = plan.cell_lo[t];
      const Eigen::RowVector3d& chi = plan.cell_hi[t];
      for (size_t r = 0; r < rows.size(); ++r) {
        if (halo == 0) {
          const Eigen::RowVector3d p = tp.pts.row(canon.rows[size_t(rows[r])]);
          const double room = std::min((p - clo).minCoeff(), (chi - p).minCoeff());
          const double reach = std::sqrt(double(d2(Eigen::Index(r), k - 1))) * canon.unit;
          if (!(reach < room)) continue;  // the neighbourhood may cross into the next tile
        }
        Eigen::Vector3d ev;
        fit_plane(canon.pts, &idx(Eigen::Index(r), 0), k, nullptr, &ev);
        probe_residual.push_back(std::sqrt(std::max(0.0, ev[0])) * canon.unit);
        std::vector<float> row(static_cast<size_t>(k));
        for (int c = 0; c < k; ++c)
          row[size_t(c)] = float(double(d2(Eigen::Index(r), c)) * canon.unit * canon.unit);
        probe_d2.push_back(std::move(row));
      }
      top.report(progress_begin + (progress_end - progress_begin) * double(t + 1) / double(ntiles));
      top.throw_if_cancelled();
    }
    if (probe_d2.empty())
      throw UnprocessableInput(input + ": no point has a complete noise-probe neighbourhood");
    DistanceMatrix d2(Eigen::Index(probe_d2.size()), kprobe);
    for (size_t r = 0; r < probe_d2.size(); ++r)
      for (int c = 0; c < kprobe; ++c) d2(Eigen::Index(r), c) = probe_d2[r][size_t(c)];
    probe_d2.clear();
    return detail::probe_from_rows(
        d2, Eigen::Map<const Eigen::VectorXd>(probe_residual.data(), Eigen::Index(probe_residual.size())));
  };
  const detail::Probe rough =
      probe_pass(std::max<int64_t>(1, finite / 20000), 0, 0, 0.2);
  const detail::Probe probe =
      probe_pass(std::max<int64_t>(1, finite / kProbeAllPoints), 2 * rough.far_radius, 0.2, 1);
  const detail::TileSizes sizes = detail::tile_sizes(probe, eo, finite);
  const ScaleChoice& choice = sizes.choice;
  const auto radius = [&](int k) { return sizes.radius(k); };

  EstimateOptions o = eo;
  detail::TileOverrides ov;
  ov.noise_ratio = probe.noise.ratio;
  ov.spacing = probe.noise.spacing;  // frame units, as the tiles' coordinates
  if (eo.method == Method::NhNet) o.model.loaded = model_for(eo.model, eo.run.threads);

  // 4. The candidate threshold from the whole cloud's surface variations.
  const double span1 = eo.method == Method::Pca ? 0.0 : 0.15;
  if (eo.method != Method::Pca) {
    if (run.progress) top.stage("surface variation", 0.15, 0.15 + span1);
    const int64_t vstep = std::max<int64_t>(1, (finite + options.variation_sample - 1) / options.variation_sample);
    std::vector<double> variation;
    int64_t seen = 0;
    for (size_t t = 0; t < ntiles; ++t) {
      if (tiles.count(t) == 0) continue;
      const TilePoints tp = tiles.load(t, eo.tiles.halo * radius(choice.k_smooth));
      std::vector<std::string> ignored;
      const detail::Canonical canon = detail::canonical_points(tp.pts, ignored);
      const int k = int(std::min<Eigen::Index>(choice.k_smooth, canon.pts.rows()));
      IndexMatrix knn;
      Neighbors(canon.pts).knn_all(k, knn, nullptr, RunContext{run.threads, {}});
      const PcaResult pca = pca_normals(canon.pts, knn, PcaOptions{k}, RunContext{run.threads, {}});
      // Own points only, one value per distinct position (the in-memory run's canonical points).
      for (Eigen::Index c = 0; c < canon.pts.rows(); ++c) {
        if (size_t(canon.rows[size_t(c)]) >= tp.own) continue;
        if (seen++ % vstep == 0) variation.push_back(pca.variation[c]);
      }
      top.report(double(t + 1) / double(ntiles));
      top.throw_if_cancelled();
    }
    ov.variation_threshold =
        detect_feature_candidates(Eigen::Map<const Eigen::VectorXd>(variation.data(), Eigen::Index(variation.size())))
            .absolute_threshold;
  }

  // 5. Each tile with its halo; own results to the tile's result file (input order).
  const double halo = eo.tiles.halo * radius(sizes.kneed);
  const double begin = 0.15 + span1, span = (0.95 - begin) / double(ntiles);
  std::set<std::string> seen_warnings(res.warnings.begin(), res.warnings.end());
  int64_t degenerate = 0;
  bool first_tile = true;
  for (size_t t = 0; t < ntiles; ++t) {
    if (tiles.count(t) == 0) continue;
    const TilePoints tp = tiles.load(t, halo);
    o.run = detail::narrow(run, begin + span * double(t), begin + span * double(t + 1));
    const EstimateResult tr = detail::estimate_cloud(tp.pts, o, ov);
    Appender out(tiles.result_file(t));
    for (size_t r = 0; r < tp.own; ++r) {
      float n[3];
      for (int k = 0; k < 3; ++k) n[k] = tr.valid[r] ? float(tr.normals(Eigen::Index(r), k)) : NAN;
      out.add(n, sizeof n);
      degenerate += tr.valid[r] ? 0 : 1;
      if (!tr.candidate.empty()) res.candidates += tr.candidate[r];
    }
    out.flush();
    if (first_tile) {
      res.k_used = tr.k_used;
      res.scales_used = tr.scales_used;
      res.device_used = tr.device_used;
      first_tile = false;
    }
    for (const std::string& w : tr.warnings)
      if (w.find("degenerate neighbourhood") == std::string::npos &&
          w.find("exact duplicate") == std::string::npos && seen_warnings.insert(w).second)
        res.warnings.push_back(w);
  }
  if (degenerate > 0)
    res.warnings.push_back(std::to_string(degenerate) +
                           " points with a degenerate neighbourhood (identical or collinear "
                           "neighbours) got no normal (reported as failed)");

  // 6. Write in input order, oriented chunk by chunk.
  if (run.progress) top.stage("writing", 0.95, 1.0);
  std::vector<Cursor> results;
  for (size_t t = 0; t < ntiles; ++t) results.emplace_back(tiles.result_file(t), 3 * sizeof(float));
  {
    std::string head;
    if (ply) {
      const char* type = fits_float ? "float" : "double";
      head = std::string("ply\nformat ") + (options.ascii ? "ascii" : "binary_little_endian") +
             " 1.0\ncomment written by nhnet (streamed)\nelement vertex " + std::to_string(res.points) +
             "\nproperty " + type + " x\nproperty " + type + " y\nproperty " + type +
             " z\nproperty float nx\nproperty float ny\nproperty float nz\nend_header\n";
      file.write(head);
    }
  }
  const ScalarType xyz_type = ply && fits_float ? ScalarType::Float32 : ScalarType::Float64;
  OrientMode mode = options.orient.mode;
  if (mode == OrientMode::Keep && in.columns() < 6) {
    if (options.warn_keep_without_normals)
      res.warnings.push_back("orient keep: " + input + " has no normals; output normals stay unoriented");
    mode = OrientMode::None;
  }
  const bool keep = mode == OrientMode::Keep;
  res.orient_mode = mode;
  const size_t chunk = 65536;
  Points cp(Eigen::Index(chunk), 3);
  Normals cn(Eigen::Index(chunk), 3), ref(keep ? Eigen::Index(chunk) : 0, 3);
  size_t filled = 0;
  std::string text;
  const auto flush_chunk = [&] {
    if (filled == 0) return;
    if (mode != OrientMode::None) {
      Points p = cp.topRows(Eigen::Index(filled));
      Normals n = cn.topRows(Eigen::Index(filled));
      OrientOptions oo = options.orient;
      oo.run = RunContext{run.threads, {}};
      const OrientResult r = keep ? orient_normals(p, n, oo, ref.topRows(Eigen::Index(filled)))
                                  : orient_normals(p, n, oo);
      cn.topRows(Eigen::Index(filled)) = n;
      res.orient.flipped += r.flipped;
      res.orient.unoriented += r.unoriented;
      res.orient.invalid += r.invalid;
    }
    text.clear();
    for (size_t i = 0; i < filled; ++i) {
      for (int k = 0; k < 6; ++k) {
        const double v = k < 3 ? cp(Eigen::Index(i), k) : cn(Eigen::Index(i), k - 3);
        const ScalarType type = k < 3 ? xyz_type : ScalarType::Float32;
        if (ply && !options.ascii) {
          io_detail::encode_scalar_le(v, type, text);
        } else {
          if (k > 0) text += ' ';
          io_detail::append_number(v, type, text);
        }
      }
      if (!ply || options.ascii) text += '\n';
    }
    file.write(text);
    filled = 0;
  };
  int64_t failed = 0;
  in.for_each(
      [&](int64_t, const double* v, size_t columns) {
        const Eigen::Index i = Eigen::Index(filled);
        cp.row(i) = Eigen::RowVector3d(v[0], v[1], v[2]);
        if (keep) {
          if (columns >= 6) ref.row(i) = Eigen::RowVector3d(v[3], v[4], v[5]);
          else ref.row(i).setConstant(NAN);
        }
        if (finite_xyz(v)) {
          const char* rec = results[size_t(plan.route(frame.to_frame(v)))].next();
          float n[3];
          std::memcpy(n, rec, sizeof n);
          cn.row(i) = Eigen::RowVector3d(n[0], n[1], n[2]);
          failed += std::isfinite(n[0]) ? 0 : 1;
        } else {
          cn.row(i).setConstant(NAN);
          ++failed;
        }
        if (++filled == chunk) flush_chunk();
      },
      [&](double f) { return top.report(f); });
  top.throw_if_cancelled();
  flush_chunk();
  file.commit();
  res.failed = failed;
  res.tiles = int(ntiles);
  res.noise_ratio = probe.noise.ratio;
  res.spacing = probe.noise.spacing / frame.scale;
  if (run.progress) {
    top.stage("done", 1, 1);
    top.throw_if_cancelled();
  }
  return res;
}

}  // namespace nhnet
