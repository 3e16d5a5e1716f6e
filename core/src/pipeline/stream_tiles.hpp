// Internal: the tiles of the out-of-core run (stream.cpp) on disk. The plan (a kd-tree of split
// planes placed on a sample of the cloud), the temporary folder that holds one point file and
// one result file per tile, and the readers and writers of their fixed-size records.
#pragma once

#include "nhnet/types.hpp"

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

namespace nhnet::stream_detail {

namespace fs = std::filesystem;

/// The frame of the tiles: input coordinates re-centred and scaled by a power of two.
struct Frame {
  Eigen::RowVector3d centre = Eigen::RowVector3d::Zero();
  double scale = 1;  // frame length = scale x input length (a power of two)
  Eigen::RowVector3d to_frame(const double* p) const {
    return (Eigen::RowVector3d(p[0], p[1], p[2]) - centre) * scale;
  }
};

/// The tile plan: a kd-tree of split planes placed on a sample.
struct Plan {
  struct Node {
    int axis = -1;     // -1: leaf
    double value = 0;  // coordinate < value: left
    int left = -1, right = -1, leaf = -1;
  };
  std::vector<Node> nodes;
  // Leaf cells (frame units; +-inf where unbounded).
  std::vector<Eigen::RowVector3d> cell_lo, cell_hi;

  /// The tile (leaf) of a point in frame units.
  int route(const Eigen::RowVector3d& p) const {
    int n = 0;
    while (nodes[size_t(n)].axis >= 0)
      n = p[nodes[size_t(n)].axis] < nodes[size_t(n)].value ? nodes[size_t(n)].left
                                                            : nodes[size_t(n)].right;
    return nodes[size_t(n)].leaf;
  }

  /// Splits sample rows order[begin, end) into `parts` leaves (detail::split_range, the
  /// in-memory tiling's rule); points at a cut's value go right. Returns the subtree's node.
  int build(const Points& s, std::vector<int64_t>& order, int64_t begin, int64_t end, int64_t parts,
            Eigen::RowVector3d lo_cell, Eigen::RowVector3d hi_cell);

  size_t tiles() const { return cell_lo.size(); }
};

/// A fresh folder `<parent>/.nhnet-stream-<pid>-<random>`, removed with everything in it.
class TempDir {
 public:
  explicit TempDir(const fs::path& parent);
  ~TempDir();
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
  void flush();

 private:
  static constexpr size_t kBuffer = size_t(1) << 16;
  [[noreturn]] void fail() const;
  fs::path path_;
  std::string buf_;
};

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
  void refill();
  fs::path path_;
  size_t record_;
  std::string buf_;
  size_t pos_ = 0;
  uint64_t offset_ = 0;
};

/// One point of a tile file: its input row and its frame coordinates.
struct PointRecord {
  int64_t row;
  double p[3];
};

/// An axis-aligned box (frame units), empty until a point is added.
struct Box {
  Eigen::RowVector3d lo = Eigen::RowVector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::RowVector3d hi = Eigen::RowVector3d::Constant(-std::numeric_limits<double>::infinity());
  bool meets(const Box& o, double margin) const {
    return ((lo.array() - margin) <= o.hi.array()).all() &&
           ((hi.array() + margin) >= o.lo.array()).all();
  }
};

/// A tile's points: its own (first `own`, input order) then its halo.
struct TilePoints {
  Points pts;
  std::vector<int64_t> rows;
  size_t own = 0;
};

/// The tiles' point files (written while binning, then read tile by tile with halos), their
/// boxes and counts, and the names of their result files.
class Tiles {
 public:
  Tiles(const TempDir& dir, size_t count);
  /// Appends a point (frame units) of input row `row` to tile t.
  void add(int t, int64_t row, const Eigen::RowVector3d& p) {
    const PointRecord r{row, {p[0], p[1], p[2]}};
    out_[size_t(t)].add(&r, sizeof r);
    boxes_[size_t(t)].lo = boxes_[size_t(t)].lo.cwiseMin(p);
    boxes_[size_t(t)].hi = boxes_[size_t(t)].hi.cwiseMax(p);
    ++counts_[size_t(t)];
  }
  /// Flushes the point files (after the last add()).
  void finish();
  size_t size() const { return counts_.size(); }
  int64_t count(size_t t) const { return counts_[t]; }

  /// Tile t's own points and every point of the other tiles within `halo` of its box.
  TilePoints load(size_t t, double halo) const;

  fs::path result_file(size_t t) const { return dir_.file("result-" + std::to_string(t)); }

 private:
  fs::path point_file(size_t t) const { return dir_.file("tile-" + std::to_string(t)); }
  void append(TilePoints& tp, std::vector<Eigen::RowVector3d>& p, size_t u, const Box* near,
              double halo) const;

  const TempDir& dir_;
  std::vector<Box> boxes_;
  std::vector<int64_t> counts_;
  std::vector<Appender> out_;
};

}  // namespace nhnet::stream_detail
