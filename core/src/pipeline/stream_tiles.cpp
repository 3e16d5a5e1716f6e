// The tiles of the out-of-core run on disk (stream_tiles.hpp): the plan's kd-tree, the temporary
// folder and the tile point / result files.
#include "pipeline/stream_tiles.hpp"

#include "nhnet/errors.hpp"
#include "pipeline/estimator.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <random>

namespace nhnet::stream_detail {

int Plan::build(const Points& s, std::vector<int64_t>& order, int64_t begin, int64_t end,
                int64_t parts, Eigen::RowVector3d lo_cell, Eigen::RowVector3d hi_cell) {
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

TempDir::TempDir(const fs::path& parent) {
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

TempDir::~TempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

void Appender::flush() {
  if (buf_.empty()) return;
  std::FILE* f = std::fopen(path_.c_str(), "ab");
  const bool ok = f && std::fwrite(buf_.data(), 1, buf_.size(), f) == buf_.size();
  if (f && std::fclose(f) != 0) fail();
  if (!ok) fail();
  buf_.clear();
}

void Appender::fail() const {
  throw OutputError(path_.string() + ": cannot write a temporary tile file: " +
                    std::strerror(errno) + " (is the disk full? set the temporary folder)");
}

void Cursor::refill() {
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

namespace {

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

}  // namespace

Tiles::Tiles(const TempDir& dir, size_t count) : dir_(dir), boxes_(count), counts_(count, 0) {
  for (size_t t = 0; t < count; ++t) out_.emplace_back(point_file(t));
}

void Tiles::finish() {
  for (Appender& a : out_) a.flush();
  out_.clear();
}

TilePoints Tiles::load(size_t t, double halo) const {
  TilePoints tp;
  std::vector<Eigen::RowVector3d> p;
  append(tp, p, t, nullptr, 0);
  tp.own = tp.rows.size();
  if (halo > 0)
    for (size_t u = 0; u < size(); ++u)
      if (u != t && counts_[u] > 0 && boxes_[u].meets(boxes_[t], halo))
        append(tp, p, u, &boxes_[t], halo);
  tp.pts.resize(Eigen::Index(p.size()), 3);
  for (size_t i = 0; i < p.size(); ++i) tp.pts.row(Eigen::Index(i)) = p[i];
  return tp;
}

// Appends tile u's points (those within `halo` of `near` when given) to tp and p.
void Tiles::append(TilePoints& tp, std::vector<Eigen::RowVector3d>& p, size_t u, const Box* near,
                   double halo) const {
  const std::string bytes = slurp(point_file(u));
  const size_t n = bytes.size() / sizeof(PointRecord);
  for (size_t i = 0; i < n; ++i) {
    PointRecord r;
    std::memcpy(&r, bytes.data() + i * sizeof r, sizeof r);
    const Eigen::RowVector3d q(r.p[0], r.p[1], r.p[2]);
    if (near &&
        !(((q.array() >= near->lo.array() - halo) && (q.array() <= near->hi.array() + halo)).all()))
      continue;
    p.push_back(q);
    tp.rows.push_back(r.row);
  }
}

}  // namespace nhnet::stream_detail
