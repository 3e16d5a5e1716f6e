// Spatial tiling of the estimator (not a paper stage; issue 10: bounded memory for any cloud).
// A cloud with more than TileOptions::points finite points is cut into axis-aligned
// tiles by recursive splits of the longest axis at the point-count quantile (kd-tree style, so
// every tile holds about tile_points points whatever the density). Each tile runs the whole
// pipeline (PCA, MFPS, NH-Net) on its own points plus a halo: every point within
// TileOptions::halo x r_K of the tile's box, r_K the radius of the largest neighbourhood the stages
// use. The noise level and the spacing, hence every neighbourhood size, are measured once on the
// whole cloud (its noise probe, exactly the untiled run's) and handed to each tile, and MFPS's
// random draws depend only on a patch's own members, so a point whose neighbourhoods (and theirs)
// lie in its tile and halo gets the untiled normal up to floating-point rounding (each tile is
// re-centred). Peak memory: the canonical points and the result (~90 B/point) plus one tile's
// working set, instead of the whole cloud's (~1.4 kB/point for MFPS).
#include "pipeline/estimator.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/geometry/feature_detection.hpp"
#include "nhnet/learned/nhnet_model.hpp"
#include "util/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace nhnet::detail {

bool wants_tiles(const Points& points, const EstimateOptions& options) {
  if (options.tiles.points <= 0 || points.rows() <= options.tiles.points) return false;
  int64_t finite = 0;
  for (Eigen::Index i = 0; i < points.rows(); ++i) finite += points.row(i).allFinite() ? 1 : 0;
  return finite > options.tiles.points;
}

RangeCut split_range(const Points& pts, std::vector<int64_t>& order, int64_t begin, int64_t end,
                     int64_t parts) {
  Eigen::RowVector3d lo = pts.row(order[size_t(begin)]), hi = lo;
  for (int64_t i = begin; i < end; ++i) {
    lo = lo.cwiseMin(pts.row(order[size_t(i)]));
    hi = hi.cwiseMax(pts.row(order[size_t(i)]));
  }
  Eigen::Index axis;
  (hi - lo).maxCoeff(&axis);
  const int64_t mid = begin + (end - begin) * (parts / 2) / parts;
  // Ties by row: the split depends only on the points, not on the order they came in.
  std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                   [&](int64_t a, int64_t b) {
                     const double x = pts(a, axis), y = pts(b, axis);
                     return x < y || (x == y && a < b);
                   });
  return {int(axis), mid, pts(order[size_t(mid)], axis)};
}

double TileSizes::radius(int k) const {
  return far_radius * std::sqrt(std::max(1.0, double(k) / double(std::max(1, far_k))));
}

namespace {

/// Halo radii for a stage (TileSizes::estimate_halo). NH-Net's descriptors of MFPS normals reach
/// three radii, and MFPS's kernel widths (bandwidth.hpp) average residuals of patches up to about
/// four: they take the whole halo. A PCA normal depends on its own neighbourhood only: one radius
/// plus the margin NH-Net keeps over its three, halo - 2 (at least a third of halo).
double halo_radii(double halo, Method method) {
  return method == Method::Pca ? one_radius_halo(halo) : halo;
}

}  // namespace

double one_radius_halo(double halo) { return std::max(halo - 2.0, halo / 3.0); }

double TileSizes::estimate_halo(const EstimateOptions& options) const {
  return halo_radii(options.tiles.halo, options.method) * radius(kneed);
}

double TileSizes::variation_halo(const EstimateOptions& options) const {
  return halo_radii(options.tiles.halo, Method::Pca) * radius(choice.k_smooth);
}

TileSizes tile_sizes(const Probe& probe, const EstimateOptions& options, int64_t m) {
  TileSizes t;
  t.choice = choose_scales(probe.noise.ratio, Eigen::Index(m));
  if (options.k > 0) t.choice.k_smooth = options.k;
  if (!options.mfps.scales.empty()) t.choice.scales = options.mfps.scales;
  t.kneed = t.choice.k_smooth;
  if (options.method != Method::Pca)
    t.kneed = std::max(t.kneed, *std::max_element(t.choice.scales.begin(), t.choice.scales.end()));
  t.far_radius = probe.far_radius;
  t.far_k = probe.far_k;
  return t;
}

namespace {

struct Leaf {
  int64_t begin, end;  // range of `order`
};

// Splits order[begin, end) (rows of pts) into `parts` leaves of nearly equal size (split_range).
void split(const Points& pts, std::vector<int64_t>& order, int64_t begin, int64_t end,
           int64_t parts, std::vector<Leaf>& leaves) {
  if (parts <= 1 || end - begin < 2) {
    leaves.push_back({begin, end});
    return;
  }
  const RangeCut cut = split_range(pts, order, begin, end, parts);
  split(pts, order, begin, cut.mid, parts / 2, leaves);
  split(pts, order, cut.mid, end, parts - parts / 2, leaves);
}

// Bounding box of each leaf's points (one pass over the owners).
struct Box {
  Eigen::RowVector3d lo = Eigen::RowVector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::RowVector3d hi = Eigen::RowVector3d::Constant(-std::numeric_limits<double>::infinity());
};

std::vector<Box> leaf_boxes(const Points& pts, const std::vector<int32_t>& owner, size_t leaves) {
  std::vector<Box> boxes(leaves);
  for (Eigen::Index i = 0; i < pts.rows(); ++i) {
    Box& b = boxes[size_t(owner[size_t(i)])];
    b.lo = b.lo.cwiseMin(pts.row(i));
    b.hi = b.hi.cwiseMax(pts.row(i));
  }
  return boxes;
}

// Rows of pts (ascending) within `halo` of `box`.
std::vector<int64_t> tile_rows(const Points& pts, const Box& box, double halo) {
  const Eigen::RowVector3d lo = box.lo.array() - halo, hi = box.hi.array() + halo;
  std::vector<int64_t> rows;
  for (Eigen::Index i = 0; i < pts.rows(); ++i)
    if ((pts.row(i).array() >= lo.array()).all() && (pts.row(i).array() <= hi.array()).all())
      rows.push_back(i);
  return rows;
}

Points gather(const Points& pts, const std::vector<int64_t>& rows) {
  Points tile(Eigen::Index(rows.size()), 3);
  for (size_t r = 0; r < rows.size(); ++r) tile.row(Eigen::Index(r)) = pts.row(rows[r]);
  return tile;
}

/// The tiles of the canonical points: kd-tree leaves of about tiles.points points each, the
/// leaf that owns every point, and each leaf's bounding box.
struct Tiles {
  std::vector<Leaf> leaves;
  std::vector<int32_t> owner;
  std::vector<Box> boxes;
};

Tiles cut_tiles(const Points& pts, int64_t tile_points) {
  const Eigen::Index m = pts.rows();
  std::vector<int64_t> order(static_cast<size_t>(m));
  for (Eigen::Index i = 0; i < m; ++i) order[size_t(i)] = i;
  const int64_t parts = (int64_t(m) + tile_points - 1) / tile_points;
  Tiles t;
  split(pts, order, 0, int64_t(m), parts, t.leaves);
  t.owner.assign(static_cast<size_t>(m), -1);
  for (size_t l = 0; l < t.leaves.size(); ++l)
    for (int64_t i = t.leaves[l].begin; i < t.leaves[l].end; ++i)
      t.owner[size_t(order[size_t(i)])] = int32_t(l);
  t.boxes = leaf_boxes(pts, t.owner, t.leaves.size());
  return t;
}

/// Pass 1 (MFPS, NH-Net): the candidate threshold is chosen from the histogram of the whole
/// cloud's surface variations (feature_detection.hpp), so every point's variation is computed
/// first, tile by tile (PCA at the smooth size), and the whole cloud's threshold goes to the tiles.
double variation_threshold(const Points& pts, const Tiles& tiles, const TileSizes& sizes,
                           double halo, const RunContext& run) {
  const Eigen::Index m = pts.rows();
  Eigen::VectorXd variation =
      Eigen::VectorXd::Constant(m, std::numeric_limits<double>::quiet_NaN());
  const int k = int(std::min<Eigen::Index>(sizes.choice.k_smooth, m));
  const size_t count = tiles.leaves.size();
  for (size_t t = 0; t < count; ++t) {
    const std::vector<int64_t> rows = tile_rows(pts, tiles.boxes[t], halo);
    const Points tile = gather(pts, rows);
    const RunContext r = narrow(run, double(t) / double(count), double(t + 1) / double(count));
    const Eigen::VectorXd v = surface_variation(tile, k, r);
    for (size_t i = 0; i < rows.size(); ++i)
      if (tiles.owner[size_t(rows[i])] == int32_t(t)) variation[rows[i]] = v[Eigen::Index(i)];
  }
  return detect_feature_candidates(variation).absolute_threshold;
}

/// The owned rows of one tile's result into the whole cloud's; the first tile's sizes, and the
/// tile's warnings not seen yet (degenerate points are counted again for the whole cloud).
void merge_tile(const EstimateResult& tr, const std::vector<int64_t>& rows, int32_t t,
                const Tiles& tiles, const Canonical& canon, std::set<std::string>& seen,
                EstimateResult& res) {
  for (size_t r = 0; r < rows.size(); ++r) {
    const int64_t i = rows[r];
    if (tiles.owner[size_t(i)] != t) continue;
    const int64_t row = canon.rows[size_t(i)];
    res.normals.row(row) = tr.normals.row(Eigen::Index(r));
    res.valid[size_t(row)] = tr.valid[r];
    res.curvature[row] = tr.curvature[Eigen::Index(r)];
    if (!tr.candidate.empty()) res.candidate[size_t(row)] = tr.candidate[r];
  }
  if (t == 0) {
    res.k_used = tr.k_used;
    res.scales_used = tr.scales_used;
    res.device_used = tr.device_used;
    res.precision_used = tr.precision_used;
    res.descriptor_k = tr.descriptor_k;
  }
  for (const std::string& w : tr.warnings)
    if (w.find("degenerate neighbourhood") == std::string::npos && seen.insert(w).second)
      res.warnings.push_back(w);
}

/// The untiled estimate after the tiling's probe (whose noise and spacing it takes, in input
/// units: the same sizes as its own probe would choose).
EstimateResult in_one_piece(const Points& points, const EstimateOptions& options, TileOverrides ov,
                            Prepared& prepared) {
  ov.spacing *= prepared.canon.unit;
  ov.prepared = &prepared;  // its canonical points and tree serve the run
  EstimateOptions o = options;
  o.run = narrow(options.run, 0.04, 1.0);
  return estimate_cloud(points, o, ov);
}

/// `prepared` for `points` as a step before left it, or built here: the canonical points, their
/// tree and the whole cloud's probe (the untiled run's: same canonical points, same frame).
Prepared& prepare(const Points& points, Prepared* given, Prepared& own, const RunContext& run) {
  if (given && given->source == points.data() && given->probed && given->tree) return *given;
  prepare_points(points, own, narrow(run, 0.01, 0.04));
  return own;
}

// untiled_bytes() per point: a fixed part and a part per column of the deepest neighbour table
// (4 for the int32 table itself; NH-Net's descriptors take more), set to cover the peak resident
// size of `nhnet-cli estimate --orient none` on 1M-point clouds, clean (k 12, table 51) and at
// 0.6 % noise (k 250, table 300) (docs/design/decisions.md#tiles-only-beyond-a-memory-budget).
struct PointBytes {
  double fixed, per_column;
};
constexpr PointBytes kPcaBytes{392, 4}, kMfpsBytes{557, 4}, kNhNetBytes{912, 7};

}  // namespace

int64_t untiled_bytes(int64_t m, int kneed, Method method) {
  const PointBytes b = method == Method::NhNet  ? kNhNetBytes
                       : method == Method::Mfps ? kMfpsBytes
                                                : kPcaBytes;
  return int64_t(double(m) * (b.fixed + b.per_column * double(kneed)));
}

EstimateResult estimate_tiled(const Points& points, const EstimateOptions& options,
                              Prepared* prepared) {
  start_threads(options.run.threads);
  const RunContext& run = options.run;
  Progress top(run.progress);
  if (run.progress) top.stage("tiling", 0, 0.01);
  Prepared own;
  Prepared& prep = prepare(points, prepared, own, run);
  const Canonical& canon = prep.canon;
  const Points& pts = canon.pts;
  const bool need_probe =
      options.k == 0 || (options.method != Method::Pca && options.mfps.scales.empty());
  const Probe probe = prep.probe;
  top.throw_if_cancelled();
  const TileSizes sizes = tile_sizes(probe, options, int64_t(pts.rows()));
  TileOverrides ov;
  if (need_probe) {
    ov.noise_ratio = probe.noise.ratio;
    ov.spacing = probe.noise.spacing;  // tiles are given normalised coordinates
  }
  // In one piece the table returned for the orientation (EstimateOptions::neighbours) counts too.
  const int kbytes = sizes.kneed + std::max(0, options.neighbours);
  if (options.tiles.memory > 0 &&
      untiled_bytes(int64_t(pts.rows()), kbytes, options.method) <= options.tiles.memory)
    return in_one_piece(points, options, ov, prep);
  prep.tree.reset();  // each tile builds its own
  EstimateResult res = empty_result(points.rows());
  res.warnings = std::move(prep.warnings);
  if (options.method != Method::Pca) res.candidate.assign(size_t(points.rows()), 0);
  const double halo = sizes.estimate_halo(options);
  const Tiles tiles = cut_tiles(pts, options.tiles.points);

  EstimateOptions o = options;
  o.neighbours = 0;                     // a tile's table is not the cloud's
  if (options.method == Method::NhNet)  // loaded once for all tiles
    o.model.loaded = model_for(options.model, options.run.threads);
  const double span1 = options.method == Method::Pca ? 0.0 : 0.15;
  if (options.method != Method::Pca)
    ov.variation_threshold = variation_threshold(pts, tiles, sizes, sizes.variation_halo(options),
                                                 narrow(run, 0.04, 0.04 + span1));

  std::set<std::string> seen(res.warnings.begin(), res.warnings.end());
  const double begin = 0.04 + span1, span = (0.99 - begin) / double(tiles.leaves.size());
  for (size_t t = 0; t < tiles.leaves.size(); ++t) {
    // The tile: its own points and every point within `halo` of their bounding box, in
    // canonical order.
    const std::vector<int64_t> rows = tile_rows(pts, tiles.boxes[t], halo);
    o.run = narrow(run, begin + span * double(t), begin + span * double(t + 1));
    merge_tile(estimate_cloud(gather(pts, rows), o, ov), rows, int32_t(t), tiles, canon, seen, res);
  }
  res.tiles = int(tiles.leaves.size());
  res.noise_ratio = need_probe ? probe.noise.ratio : 0;
  res.spacing = need_probe ? probe.noise.spacing * canon.unit : 0;
  finish_result(res, canon.copies, canon.finite_count);
  if (!res.candidate.empty())
    for (const int64_t row : canon.rows) res.candidates += res.candidate[size_t(row)];
  if (run.progress) {
    top.stage("done", 1, 1);
    top.throw_if_cancelled();
  }
  return res;
}

}  // namespace nhnet::detail
