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
//  5. the estimator (estimate_cloud) on each tile plus its halo (points of the neighbouring
//     tiles' files within tile_halo radii of the largest neighbourhood), with the whole cloud's
//     decisions; the tile's own results go to its result file in input order;
//  6. read the input again and write the output in the input's order (temporary file +
//     rename), each point's normal taken from its tile's result file (the routing is a pure
//     function of the coordinates), oriented chunk by chunk (keep / viewpoint).
// Memory: one tile's working set, the plan sample, the probe rows and at most variation_sample
// floats; disk: 32 bytes per point (tiles) + 12 (results). The tiles on disk are
// stream_tiles.cpp; the XYZ line rules are read_xyz's (io_detail::XyzLines). The per-tile steps
// (probe, decisions, surface variation, estimate) are tiles.hpp's, shared with nhnet.distributed.
#include "nhnet/pipeline/stream.hpp"

#include "nhnet/pipeline/tiles.hpp"

#include "io/detail.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/geometry/feature_detection.hpp"
#include "nhnet/geometry/pca.hpp"
#include "nhnet/geometry/scales.hpp"
#include "nhnet/io/io.hpp"
#include "nhnet/learned/confidence.hpp"
#include "nhnet/learned/nhnet_model.hpp"
#include "nhnet/neighbors/neighbors.hpp"
#include "pipeline/estimator.hpp"
#include "pipeline/stream_tiles.hpp"
#include "util/parallel.hpp"
#include "util/stats.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
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
using stream_detail::Appender;
using stream_detail::Cursor;
using stream_detail::Frame;
using stream_detail::Plan;
using stream_detail::TempDir;
using stream_detail::TilePoints;
using stream_detail::Tiles;

constexpr double kInf = std::numeric_limits<double>::infinity();

/// True when the row's x y z (its first three values) are all finite.
bool finite_xyz(const double* v) {
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

// ---------------------------------------------------------------------------------------------
// Input: the XYZ text file, chunk by chunk (the line rules are read_xyz's: io_detail::XyzLines).

/// A text file read in chunks of whole lines, numbering the lines on across the chunks.
class TextChunks {
 public:
  /// Opens `path` (`size` bytes, for the progress).
  TextChunks(const std::string& path, uintmax_t size) : path_(path), size_(size) {
    f_ = std::fopen(path_.c_str(), "rb");
    if (!f_) input_error(path_, std::string("cannot open: ") + std::strerror(errno));
    chunk_.resize(kChunk);
  }
  ~TextChunks() { std::fclose(f_); }
  TextChunks(const TextChunks&) = delete;
  TextChunks& operator=(const TextChunks&) = delete;

  /// Points `lines` at the next chunk's whole lines (at the end of the file: all that is left);
  /// false once the file is done.
  bool next(io_detail::LineCursor& lines) {
    // Line numbers continue after the consumed part (count its terminators once more).
    line_no_ = count_lines(buf_, cut_, line_no_);
    buf_.erase(0, cut_);
    cut_ = 0;
    if (eof_) return false;
    const size_t got = std::fread(chunk_.data(), 1, chunk_.size(), f_);
    if (got < chunk_.size()) {
      if (std::ferror(f_)) input_error(path_, "read error");
      eof_ = true;
    }
    done_bytes_ += got;
    buf_.append(chunk_.data(), got);
    cut_ = whole_lines();
    lines = io_detail::LineCursor(std::string_view(buf_.data(), cut_), 0, line_no_);
    return true;
  }

  /// Fraction of the file's bytes read so far.
  double fraction() const { return size_ ? double(done_bytes_) / double(size_) : 1.0; }

 private:
  static constexpr size_t kChunk = size_t(16) << 20;
  static constexpr size_t kMaxLine = size_t(64) << 20;

  // End of the whole lines in the buffer: up to the last '\n' (a '\r' at the very end may be
  // half of a "\r\n" that the next chunk completes); everything at the end of the file.
  size_t whole_lines() const {
    if (eof_) return buf_.size();
    size_t cut = 0;
    const size_t nl = buf_.rfind('\n');
    if (nl != std::string::npos) {
      cut = nl + 1;
    } else {
      const size_t cr = buf_.size() > 1 ? buf_.rfind('\r', buf_.size() - 2) : std::string::npos;
      cut = cr == std::string::npos ? 0 : cr + 1;
    }
    if (cut == 0 && buf_.size() > kMaxLine)
      input_error(path_, "a line longer than " + std::to_string(kMaxLine) + " bytes" + " (line " +
                             std::to_string(line_no_) + ")");
    return cut;
  }

  // Line number after buf[0, cut) that starts at line `first`: "\r\n", "\r", "\n" count once.
  static size_t count_lines(const std::string& buf, size_t cut, size_t first) {
    size_t n = first;
    for (size_t i = 0; i < cut; ++i) {
      if (buf[i] == '\n')
        ++n;
      else if (buf[i] == '\r' && !(i + 1 < cut && buf[i + 1] == '\n'))
        ++n;
    }
    return n;
  }

  const std::string& path_;
  uintmax_t size_;
  std::FILE* f_ = nullptr;
  std::vector<char> chunk_;
  std::string buf_;
  size_t cut_ = 0, line_no_ = 1, done_bytes_ = 0;
  bool eof_ = false;
};

/// The XYZ input, read whole once per pass.
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
    TextChunks chunks(path_, size_);
    io_detail::XyzLines xyz(path_, columns_);
    io_detail::LineCursor lines(std::string_view(), 0, 1);
    std::vector<double> values;
    int64_t index = 0;
    while (chunks.next(lines)) {
      while (xyz.next(lines)) {
        xyz.parse(values);
        row(index++, values.data(), xyz.columns());
      }
      columns_ = xyz.columns();
      if (!progress(chunks.fraction())) return index;
    }
    xyz.require_points();
    const std::string mismatch = xyz.count_mismatch(uint64_t(index));
    if (!mismatch.empty()) declared_mismatch_ = mismatch;
    return index;
  }

  size_t columns() const { return columns_; }
  const std::string& path() const { return path_; }
  /// Non-empty when a .pts count line disagrees with the points read.
  const std::string& declared_mismatch() const { return declared_mismatch_; }

 private:
  std::string path_;
  uintmax_t size_ = 0;
  size_t columns_ = 0;
  std::string declared_mismatch_;
};

// ---------------------------------------------------------------------------------------------
// Checks.

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

/// Refuses the options and the files that streaming cannot take; returns whether the output is
/// PLY (else XYZ text).
bool check_stream(const std::string& input, const std::string& output,
                  const StreamOptions& options) {
  const EstimateOptions& eo = options.estimate;
  detail::check_options(eo);
  if (eo.tiles.points <= 0) throw InvalidOptions("streaming needs tile points > 0");
  const OrientMode m = options.orient.mode;
  if (m == OrientMode::Mst || m == OrientMode::Up || m == OrientMode::Sensors)
    throw InvalidOptions("--orient " + std::string(to_string(m)) +
                         " needs the whole cloud in memory; with streaming use "
                         "auto, none, keep or viewpoint X Y Z");
  if (options.plan_sample < 1000 || options.variation_sample < 1000)
    throw InvalidOptions("plan and variation samples must be at least 1000 points");
  const bool ply = output_is_ply(output);
  check_xyz_input(input);
  std::error_code ec;
  if (fs::equivalent(input, output, ec))
    throw InvalidOptions(output + ": the output would replace the input; choose another name");
  return ply;
}

// ---------------------------------------------------------------------------------------------
// Passes 1 and 2: the plan and the tile files.

/// Pass 1's findings over the finite points: count, box, reservoir sample for the plan, and
/// whether every coordinate (finite or not) is exact in float.
struct Scan {
  explicit Scan(std::mt19937_64::result_type seed) : rng(seed) {}

  /// Takes one input row into the counts, the box and a sample of at most `keep` points.
  void add(const double* v, int64_t keep) {
    for (int k = 0; k < 3; ++k)
      fits_float = fits_float && (std::isnan(v[k]) || double(float(v[k])) == v[k]);
    if (!finite_xyz(v)) return;
    const Eigen::RowVector3d p(v[0], v[1], v[2]);
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
    if (int64_t(sample.size()) < keep) {
      sample.push_back({v[0], v[1], v[2]});
    } else {
      const uint64_t j = rng() % uint64_t(finite + 1);
      if (j < uint64_t(keep)) sample[size_t(j)] = {v[0], v[1], v[2]};
    }
    ++finite;
  }

  Eigen::RowVector3d lo = Eigen::RowVector3d::Constant(kInf), hi = -lo;
  std::vector<std::array<double, 3>> sample;
  std::mt19937_64 rng;
  int64_t finite = 0;
  bool fits_float = true;
};

/// Pass 1: reads every point for the counts, the box and the plan's sample; notes the input's
/// warnings in `res` and refuses fewer than 3 finite points.
Scan scan_input(XyzStream& in, const StreamOptions& options, detail::Progress& top,
                StreamResult& res) {
  Scan scan(options.estimate.mfps.seed);
  if (options.estimate.run.progress) top.stage("reading", 0, 0.05);
  res.points =
      in.for_each([&](int64_t, const double* v, size_t) { scan.add(v, options.plan_sample); },
                  [&](double f) { return top.report(f); });
  top.throw_if_cancelled();
  if (!in.declared_mismatch().empty()) res.warnings.push_back(in.declared_mismatch());
  if (scan.finite < res.points)
    res.warnings.push_back(std::to_string(res.points - scan.finite) +
                           " non-finite points skipped (reported as failed)");
  if (scan.finite < 3)
    throw UnprocessableInput("only " + std::to_string(scan.finite) +
                             " finite points; at least 3 are needed");
  if (in.columns() > 6 || in.columns() == 4 || in.columns() == 5)
    res.warnings.push_back("streaming writes x y z nx ny nz only: the input's other " +
                           std::to_string(in.columns() - (in.columns() >= 6 ? 6 : 3)) +
                           " columns are not carried over");
  return scan;
}

/// The tiles' frame: centred on the box, scaled by a power of two into [-2, 2) (see
/// normalise()).
Frame frame_of(const Scan& scan) {
  const TileFrame f = tile_frame(scan.lo, scan.hi);
  Frame frame;
  frame.centre = f.centre;
  frame.scale = f.scale;
  return frame;
}

/// The tile plan: ceil(finite / tile_points) tiles placed on the sample (which is freed).
Plan plan_tiles(Scan& scan, const Frame& frame, int64_t tile_points) {
  Points s(Eigen::Index(scan.sample.size()), 3);
  for (size_t i = 0; i < scan.sample.size(); ++i)
    s.row(Eigen::Index(i)) = frame.to_frame(scan.sample[i].data());
  std::vector<std::array<double, 3>>().swap(scan.sample);
  Plan plan;
  std::vector<int64_t> order(size_t(s.rows()));
  for (size_t i = 0; i < order.size(); ++i) order[i] = int64_t(i);
  const int64_t parts = (scan.finite + tile_points - 1) / tile_points;
  plan.build(s, order, 0, int64_t(order.size()), parts, Eigen::RowVector3d::Constant(-kInf),
             Eigen::RowVector3d::Constant(kInf));
  return plan;
}

/// Folder of the temporary tile files: the option's, else the output's.
fs::path temp_parent(const StreamOptions& options, const std::string& output) {
  const fs::path out_dir = fs::path(output).parent_path();
  return options.temp_dir.empty() ? (out_dir.empty() ? fs::path(".") : out_dir)
                                  : fs::path(options.temp_dir);
}

/// Pass 2: appends every finite point (frame units) to its tile's file.
void bin_points(XyzStream& in, const Frame& frame, const Plan& plan, Tiles& tiles,
                const RunContext& run, detail::Progress& top) {
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
}

// ---------------------------------------------------------------------------------------------
// Tile by tile: the whole cloud's decisions, then the normals.

/// What the tile-by-tile steps share: the input's name, the tiles, their frame and plan, the
/// threads and the progress.
struct TileRun {
  const std::string& input;
  const Frame& frame;
  const Plan& plan;
  const Tiles& tiles;
  const RunContext& run;
  detail::Progress& top;
};

/// One probe pass over every tile (progress from `begin` to `end` of the stage): the whole
/// cloud's decisions from the rows it collects (probe_tile, tiles.hpp).
TileDecisions probe_pass(const TileRun& tr, const EstimateOptions& eo, int64_t finite, bool rough,
                         double halo, double begin, double end) {
  const size_t ntiles = tr.plan.tiles();
  std::vector<TileProbeRows> rows;
  for (size_t t = 0; t < ntiles; ++t) {
    if (tr.tiles.count(t) < 3) continue;
    const TilePoints tp = tr.tiles.load(t, halo);
    rows.push_back(probe_tile(tp.pts, int64_t(tp.own), probe_step(finite, rough), halo,
                              tr.plan.cell_lo[t], tr.plan.cell_hi[t], tr.run.threads));
    tr.top.report(begin + (end - begin) * double(t + 1) / double(ntiles));
    tr.top.throw_if_cancelled();
  }
  try {
    return decide_tiles(rows, eo, finite);
  } catch (const UnprocessableInput& e) {
    throw UnprocessableInput(tr.input + ": " + e.what());
  }
}

/// The whole cloud's noise probe and decisions: every probe_step-th own point of each tile (the
/// in-memory run probes every point of clouds up to kProbeAllPoints, an evenly spaced subset of
/// larger ones), with a halo of twice a rough probe radius so that the neighbourhoods are
/// complete. The rough radius comes from a sparse first pass on the tiles' own points, keeping
/// only points whose neighbourhood lies inside their tile's cell.
TileDecisions noise_probe(const TileRun& tr, const EstimateOptions& eo, int64_t finite) {
  if (tr.run.progress) tr.top.stage("noise probe", 0.1, 0.15);
  const TileDecisions rough = probe_pass(tr, eo, finite, true, 0, 0, 0.2);
  return probe_pass(tr, eo, finite, false, 2 * rough.far_radius, 0.2, 1);
}

/// What every tile runs with: the options (the model loaded once) and the whole cloud's
/// decisions.
struct TileSetup {
  EstimateOptions options;
  TileDecisions decisions;
};

/// The tiles' options (the NH-Net model loaded once) and the whole cloud's decisions.
TileSetup tile_setup(const EstimateOptions& eo, const TileDecisions& decisions) {
  TileSetup setup{eo, decisions};
  if (eo.method == Method::NhNet) setup.options.model.loaded = model_for(eo.model, eo.run.threads);
  return setup;
}

/// Share of the progress that the surface variation stage takes (none for PCA).
double variation_span(Method method) { return method == Method::Pca ? 0.0 : 0.15; }

/// (MFPS, NH-Net) The candidate threshold from the whole cloud's surface variations at the
/// smooth size: each tile's own points with a halo, an evenly spaced subset of at most
/// variation_sample values (tile_variation, tiles.hpp).
double tiles_variation_threshold(const TileRun& tr, const StreamOptions& options,
                                 const TileDecisions& d, int64_t finite) {
  const EstimateOptions& eo = options.estimate;
  if (tr.run.progress) tr.top.stage("surface variation", 0.15, 0.15 + variation_span(eo.method));
  const int64_t vstep = variation_step(finite, options.variation_sample);
  const size_t ntiles = tr.plan.tiles();
  std::vector<double> variation;
  for (size_t t = 0; t < ntiles; ++t) {
    if (tr.tiles.count(t) == 0) continue;
    const TilePoints tp = tr.tiles.load(t, d.variation_halo);
    const Eigen::VectorXd v =
        tile_variation(tp.pts, int64_t(tp.own), d.k_smooth, vstep, tr.run.threads);
    variation.insert(variation.end(), v.data(), v.data() + v.size());
    tr.top.report(double(t + 1) / double(ntiles));
    tr.top.throw_if_cancelled();
  }
  return variation_threshold(
      Eigen::Map<const Eigen::VectorXd>(variation.data(), Eigen::Index(variation.size())));
}

/// Writes a tile's own points' normals and, when estimated, their confidences (NaN where
/// estimation failed), in input order, to its result file; adds their candidates to `res`.
/// Returns how many failed.
int64_t write_tile_result(const fs::path& file, size_t own, const EstimateResult& est,
                          StreamResult& res) {
  Appender out(file);
  const bool confidence = est.confidence.size() != 0;
  int64_t degenerate = 0;
  for (size_t r = 0; r < own; ++r) {
    float n[4];
    for (int k = 0; k < 3; ++k) n[k] = est.valid[r] ? float(est.normals(Eigen::Index(r), k)) : NAN;
    n[3] = confidence && est.valid[r] ? float(est.confidence[Eigen::Index(r)]) : NAN;
    out.add(n, (confidence ? 4 : 3) * sizeof(float));
    degenerate += est.valid[r] ? 0 : 1;
    if (!est.candidate.empty()) res.candidates += est.candidate[r];
  }
  out.flush();
  if (confidence)
    res.low_confidence += count_low_confidence(est.confidence.head(Eigen::Index(own)));
  return degenerate;
}

/// The estimator on each tile plus its halo (setup.decisions.halo, frame units); the own points'
/// normals go to the tile's result file. `res` takes the first tile's sizes and device, every
/// tile's other warnings once, and one count of the degenerate points.
void estimate_tiles(const TileRun& tr, TileSetup setup, StreamResult& res) {
  const size_t ntiles = tr.plan.tiles();
  EstimateOptions& o = setup.options;
  o.neighbours = 0;  // a tile's table is not the cloud's
  const double begin = 0.15 + variation_span(o.method), span = (0.95 - begin) / double(ntiles);
  std::set<std::string> seen_warnings(res.warnings.begin(), res.warnings.end());
  if (o.confidence) res.low_confidence = 0;
  int64_t degenerate = 0;
  bool first_tile = true;
  for (size_t t = 0; t < ntiles; ++t) {
    if (tr.tiles.count(t) == 0) continue;
    const TilePoints tp = tr.tiles.load(t, setup.decisions.halo);
    o.run = detail::narrow(tr.run, begin + span * double(t), begin + span * double(t + 1));
    const EstimateResult est = estimate_tile(tp.pts, o, setup.decisions);
    degenerate += write_tile_result(tr.tiles.result_file(t), tp.own, est, res);
    res.cell_means += est.cell_means;
    if (first_tile) {
      res.k_used = est.k_used;
      res.scales_used = est.scales_used;
      res.device_used = est.device_used;
      res.precision_used = est.precision_used;
      first_tile = false;
    }
    for (const std::string& w : est.warnings)
      if (w.find("degenerate neighbourhood") == std::string::npos &&
          w.find("exact duplicate") == std::string::npos && seen_warnings.insert(w).second)
        res.warnings.push_back(w);
  }
  if (degenerate > 0)
    res.warnings.push_back(std::to_string(degenerate) +
                           " points with a degenerate neighbourhood (identical or collinear "
                           "neighbours) got no normal (reported as failed)");
}

// ---------------------------------------------------------------------------------------------
// Pass 3: the output, in input order.

/// The PLY header of the output: x y z (float when every coordinate is exact in float, else
/// double), float normals and, when asked, a float confidence for `points` vertices.
std::string ply_header(bool ascii, bool fits_float, int64_t points, bool confidence) {
  const char* type = fits_float ? "float" : "double";
  return std::string("ply\nformat ") + (ascii ? "ascii" : "binary_little_endian") +
         " 1.0\ncomment written by nhnet (streamed)\nelement vertex " + std::to_string(points) +
         "\nproperty " + type + " x\nproperty " + type + " y\nproperty " + type +
         " z\nproperty float nx\nproperty float ny\nproperty float nz\n" +
         (confidence ? "property float confidence\n" : "") + "end_header\n";
}

/// The orientation used: Auto is Keep when the input has normals, else None (an XYZ file names
/// no sensor, and the MST needs the whole cloud); Keep falls back to None (with a warning unless
/// told not to) when the input has no normals. Sets res.orient_source.
OrientMode orient_mode(const StreamOptions& options, const XyzStream& in, const std::string& input,
                       StreamResult& res) {
  OrientMode mode = options.orient.mode;
  res.orient_source = "requested";
  if (mode == OrientMode::Auto) {
    const bool normals = in.columns() >= 6;
    res.orient_source =
        normals ? "input normals" : "no sensor in an XYZ file, and mst needs the whole cloud";
    return normals ? OrientMode::Keep : OrientMode::None;
  }
  if (mode == OrientMode::Keep && in.columns() < 6) {
    if (options.warn_keep_without_normals)
      res.warnings.push_back("orient keep: " + input +
                             " has no normals; output normals stay unoriented");
    mode = OrientMode::None;
  }
  return mode;
}

/// The output's points with their normals (and confidences: a last column, when asked), oriented
/// and written kChunk points at a time.
class OutputChunks {
 public:
  OutputChunks(io_detail::AtomicFile& file, const StreamOptions& options, OrientMode mode,
               ScalarType xyz_type, bool binary, StreamResult& res)
      : file_(file),
        columns_(options.estimate.confidence ? 7 : 6),
        options_(options),
        mode_(mode),
        keep_(mode == OrientMode::Keep),
        xyz_type_(xyz_type),
        binary_(binary),
        res_(res),
        cp_(Eigen::Index(kChunk), 3),
        cn_(Eigen::Index(kChunk), 3),
        ref_(keep_ ? Eigen::Index(kChunk) : 0, 3),
        conf_(Eigen::Index(kChunk)) {}

  /// Adds a point: its input row `v` (`columns` values) and its normal then confidence (null:
  /// NaN; the confidence is read only when written).
  void add(const double* v, size_t columns, const float* normal) {
    const Eigen::Index i = Eigen::Index(filled_);
    cp_.row(i) = Eigen::RowVector3d(v[0], v[1], v[2]);
    if (keep_) {
      if (columns >= 6)
        ref_.row(i) = Eigen::RowVector3d(v[3], v[4], v[5]);
      else
        ref_.row(i).setConstant(NAN);
    }
    if (normal)
      cn_.row(i) = Eigen::RowVector3d(normal[0], normal[1], normal[2]);
    else
      cn_.row(i).setConstant(NAN);
    conf_[i] = normal && columns_ == 7 ? normal[3] : NAN;
    if (++filled_ == kChunk) flush();
  }

  /// Orients and writes the points added since the last flush.
  void flush() {
    if (filled_ == 0) return;
    if (mode_ != OrientMode::None) orient();
    text_.clear();
    for (size_t i = 0; i < filled_; ++i) {
      for (int k = 0; k < columns_; ++k) {
        const double v = k < 3   ? cp_(Eigen::Index(i), k)
                         : k < 6 ? cn_(Eigen::Index(i), k - 3)
                                 : conf_[Eigen::Index(i)];
        const ScalarType type = k < 3 ? xyz_type_ : ScalarType::Float32;
        if (binary_) {
          io_detail::encode_scalar_le(v, type, text_);
        } else {
          if (k > 0) text_ += ' ';
          io_detail::append_number(v, type, text_);
        }
      }
      if (!binary_) text_ += '\n';
    }
    file_.write(text_);
    filled_ = 0;
  }

 private:
  static constexpr size_t kChunk = 65536;

  // Orients the chunk's normals (keep: towards the input's), counting into res.orient.
  void orient() {
    const Eigen::Index rows = Eigen::Index(filled_);
    Points p = cp_.topRows(rows);
    Normals n = cn_.topRows(rows);
    OrientOptions oo = options_.orient;
    oo.mode = mode_;
    oo.run = RunContext{options_.estimate.run.threads, {}};
    const OrientResult r =
        keep_ ? orient_normals(p, n, oo, ref_.topRows(rows)) : orient_normals(p, n, oo);
    cn_.topRows(rows) = n;
    res_.orient.flipped += r.flipped;
    res_.orient.unoriented += r.unoriented;
    res_.orient.invalid += r.invalid;
  }

  io_detail::AtomicFile& file_;
  int columns_;  // x y z nx ny nz, and the confidence when asked
  const StreamOptions& options_;
  OrientMode mode_;
  bool keep_;
  ScalarType xyz_type_;
  bool binary_;  // binary PLY; else text lines (ASCII PLY, XYZ)
  StreamResult& res_;
  Points cp_;
  Normals cn_, ref_;
  Eigen::VectorXd conf_;
  size_t filled_ = 0;
  std::string text_;
};

/// Pass 3: reads the input again and writes every point with its tile's normal (NaN for the
/// non-finite points) in the input's order; counts the failed points into `res`.
void write_output(const TileRun& tr, XyzStream& in, io_detail::AtomicFile& file,
                  const StreamOptions& options, bool ply, bool fits_float, StreamResult& res) {
  if (tr.run.progress) tr.top.stage("writing", 0.95, 1.0);
  const bool confidence = options.estimate.confidence;
  std::vector<Cursor> results;
  for (size_t t = 0; t < tr.plan.tiles(); ++t)
    results.emplace_back(tr.tiles.result_file(t), (confidence ? 4 : 3) * sizeof(float));
  if (ply) file.write(ply_header(options.ascii, fits_float, res.points, confidence));
  res.orient_mode = orient_mode(options, in, tr.input, res);
  OutputChunks chunks(file, options, res.orient_mode,
                      ply && fits_float ? ScalarType::Float32 : ScalarType::Float64,
                      ply && !options.ascii, res);
  int64_t failed = 0;
  in.for_each(
      [&](int64_t, const double* v, size_t columns) {
        if (!finite_xyz(v)) {
          ++failed;
          chunks.add(v, columns, nullptr);
          return;
        }
        float n[4];
        std::memcpy(n, results[size_t(tr.plan.route(tr.frame.to_frame(v)))].next(),
                    (confidence ? 4 : 3) * sizeof(float));
        failed += std::isfinite(n[0]) ? 0 : 1;
        chunks.add(v, columns, n);
      },
      [&](double f) { return tr.top.report(f); });
  tr.top.throw_if_cancelled();
  chunks.flush();
  res.failed = failed;
}

}  // namespace

StreamResult estimate_stream(const std::string& input, const std::string& output,
                             const StreamOptions& options) {
  const bool ply = check_stream(input, output, options);
  // The output's temporary file first: an unwritable folder fails before any work.
  io_detail::AtomicFile file(output);
  const EstimateOptions& eo = options.estimate;
  detail::start_threads(eo.run.threads);
  detail::Progress top(eo.run.progress);
  StreamResult res;
  // Passes 1 and 2: the plan on a sample, then every point into its tile's file.
  XyzStream in(input);
  Scan scan = scan_input(in, options, top, res);
  const Frame frame = frame_of(scan);
  const Plan plan = plan_tiles(scan, frame, eo.tiles.points);
  TempDir tmp(temp_parent(options, output));
  Tiles tiles(tmp, plan.tiles());
  bin_points(in, frame, plan, tiles, eo.run, top);
  // The whole cloud's decisions, then each tile's normals to its result file.
  const TileRun tr{input, frame, plan, tiles, eo.run, top};
  TileSetup setup = tile_setup(eo, noise_probe(tr, eo, scan.finite));
  if (eo.method != Method::Pca && !setup.decisions.cell_means)
    setup.decisions.variation_threshold =
        tiles_variation_threshold(tr, options, setup.decisions, scan.finite);
  const TileDecisions decisions = setup.decisions;
  estimate_tiles(tr, std::move(setup), res);
  // Pass 3: the output in input order, renamed over the target when complete.
  write_output(tr, in, file, options, ply, scan.fits_float, res);
  file.commit();
  res.tiles = int(plan.tiles());
  res.noise_ratio = decisions.noise_ratio;
  res.spacing = decisions.spacing / frame.scale;
  if (eo.run.progress) {
    top.stage("done", 1, 1);
    top.throw_if_cancelled();
  }
  return res;
}

}  // namespace nhnet
