// The tiled run's steps one at a time (not a paper stage; tiles.hpp): the out-of-core run
// (stream.cpp) and the distributed one (python nhnet.distributed) call the same functions, so
// their tiles, probe and decisions agree.
#include "nhnet/pipeline/tiles.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/geometry/feature_detection.hpp"
#include "nhnet/geometry/pca.hpp"
#include "nhnet/geometry/scales.hpp"
#include "nhnet/neighbors/neighbors.hpp"
#include "pipeline/cell_means.hpp"
#include "pipeline/estimator.hpp"
#include "pipeline/stream_tiles.hpp"
#include "util/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace nhnet {

TileFrame tile_frame(const Eigen::RowVector3d& lo, const Eigen::RowVector3d& hi) {
  TileFrame frame;
  frame.centre = (lo + hi) / 2;
  const double half = ((hi - lo) / 2).maxCoeff();
  if (half > 0 && std::isfinite(half)) frame.scale = std::ldexp(1.0, -std::ilogb(half));
  return frame;
}

TilePlan plan_tiles(const Points& sample, int64_t finite, int64_t tile_points) {
  if (tile_points < 1) throw InvalidOptions("tile points must be >= 1");
  const double inf = std::numeric_limits<double>::infinity();
  stream_detail::Plan plan;
  std::vector<int64_t> order(size_t(sample.rows()));
  for (size_t i = 0; i < order.size(); ++i) order[i] = int64_t(i);
  const int64_t parts = std::max<int64_t>(1, (finite + tile_points - 1) / tile_points);
  plan.build(sample, order, 0, int64_t(order.size()), parts, Eigen::RowVector3d::Constant(-inf),
             Eigen::RowVector3d::Constant(inf));
  TilePlan out;
  for (const stream_detail::Plan::Node& n : plan.nodes) {
    out.axis.push_back(n.axis);
    out.value.push_back(n.value);
    out.left.push_back(n.left);
    out.right.push_back(n.right);
    out.leaf.push_back(n.leaf);
  }
  out.cell_lo.resize(Eigen::Index(plan.tiles()), 3);
  out.cell_hi.resize(Eigen::Index(plan.tiles()), 3);
  for (size_t t = 0; t < plan.tiles(); ++t) {
    out.cell_lo.row(Eigen::Index(t)) = plan.cell_lo[t];
    out.cell_hi.row(Eigen::Index(t)) = plan.cell_hi[t];
  }
  return out;
}

std::vector<int32_t> route_tiles(const TilePlan& plan, const Points& points) {
  const size_t nodes = plan.axis.size();
  if (nodes == 0 || plan.value.size() != nodes || plan.left.size() != nodes ||
      plan.right.size() != nodes || plan.leaf.size() != nodes)
    throw InvalidOptions("tile plan: node arrays of different lengths");
  std::vector<int32_t> tile(size_t(points.rows()));
  for (Eigen::Index i = 0; i < points.rows(); ++i) {
    size_t n = 0;
    for (size_t depth = 0; plan.axis[n] >= 0; ++depth) {
      const int a = plan.axis[n];
      const int next = points(i, std::min(a, 2)) < plan.value[n] ? plan.left[n] : plan.right[n];
      if (next < 0 || size_t(next) >= nodes || depth > nodes)
        throw InvalidOptions("tile plan: broken tree");
      n = size_t(next);
    }
    tile[size_t(i)] = int32_t(plan.leaf[n]);
  }
  return tile;
}

int64_t probe_step(int64_t finite, bool rough) {
  return std::max<int64_t>(1, finite / (rough ? int64_t(20000) : kProbeAllPoints));
}

TileProbeRows probe_tile(const Points& pts, int64_t own, int64_t step, double halo,
                         const Eigen::RowVector3d& cell_lo, const Eigen::RowVector3d& cell_hi,
                         int threads) {
  TileProbeRows out;
  if (own < 3) return out;
  std::vector<std::string> ignored;
  const detail::Canonical canon = detail::canonical_points(pts, ignored);
  const int k = int(std::min<Eigen::Index>(kNoiseProbeK, canon.pts.rows()));
  if (k < 4) return out;
  std::vector<int64_t> rows;
  int64_t seen = 0;
  for (Eigen::Index i = 0; i < canon.pts.rows(); ++i)
    if (canon.rows[size_t(i)] < own && seen++ % std::max<int64_t>(1, step) == 0) rows.push_back(i);
  const Neighbors tree(canon.pts);
  IndexMatrix idx;
  DistanceMatrix d2;
  tree.knn_rows(k, rows, idx, &d2, RunContext{threads, {}});
  std::vector<Eigen::Index> kept;
  std::vector<Eigen::Vector2d> residual;
  for (size_t r = 0; r < rows.size(); ++r) {
    if (halo == 0) {
      const Eigen::RowVector3d p = pts.row(canon.rows[size_t(rows[r])]);
      const double room = std::min((p - cell_lo).minCoeff(), (cell_hi - p).minCoeff());
      const double reach = std::sqrt(double(d2(Eigen::Index(r), k - 1))) * canon.unit;
      if (!(reach < room)) continue;  // the neighbourhood may cross into the next tile
    }
    residual.push_back(probe_residuals(canon.pts, &idx(Eigen::Index(r), 0), k) * canon.unit);
    kept.push_back(Eigen::Index(r));
  }
  out.d2.resize(Eigen::Index(kept.size()), k);
  for (size_t r = 0; r < kept.size(); ++r)
    out.d2.row(Eigen::Index(r)) =
        (d2.row(kept[r]).cast<double>() * canon.unit * canon.unit).cast<float>();
  out.residual.resize(Eigen::Index(residual.size()), 2);
  for (size_t r = 0; r < residual.size(); ++r) out.residual.row(Eigen::Index(r)) = residual[r];
  return out;
}

namespace {

/// The halo of a tile through cell means: halo - 2 radii (at least a third of halo, as the
/// in-memory tiling gives PCA) of the means' largest neighbourhood, kMaxScale means (their own
/// probe chooses their sizes in the tile): each own mean's neighbourhood and its neighbours',
/// whose normals its descriptors read. The normals are not the in-memory run's anyway (other
/// cubes), so the two more radii that make the points' tiles exact would buy nothing: on 3M
/// fandisk points at 0.6 % noise in 3 tiles, RMS 19.42 against 19.49 with them and 19.41 in
/// memory, 1.65 instead of 2.25 times the means. A cube is `edge` = CellMeanOptions::edge noise
/// deviations wide whatever the noise, so the surface area per mean is a fixed share of edge^2:
/// 0.40 on the 1M-point fandisk at 0.6 and 1.2 % noise (noise ratios 1.19 and 1.21: 5.1 and 5.2
/// points per mean; kMeanArea keeps a margin over it), and k means cover the area of k x
/// kMeanArea x (edge / spacing)^2 points.
constexpr double kMeanArea = 0.5;

double means_halo(const detail::TileSizes& sizes, double ratio, const EstimateOptions& options) {
  const double edge = options.cell_means.edge * ratio;  // in spacings
  return detail::one_radius_halo(options.tiles.halo) * sizes.radius(kMaxScale) *
         std::max(1.0, edge * std::sqrt(kMeanArea));
}

}  // namespace

TileDecisions decide_tiles(const std::vector<TileProbeRows>& rows, const EstimateOptions& options,
                           int64_t finite) {
  Eigen::Index count = 0, k = std::numeric_limits<Eigen::Index>::max();
  for (const TileProbeRows& r : rows)
    if (r.d2.rows() > 0) {
      count += r.d2.rows();
      k = std::min(k, r.d2.cols());
    }
  if (count == 0) throw UnprocessableInput("no point has a complete noise-probe neighbourhood");
  DistanceMatrix d2(count, k);
  ProbeResiduals residual(count, 2);
  Eigen::Index at = 0;
  for (const TileProbeRows& r : rows) {
    if (r.d2.rows() == 0) continue;
    d2.middleRows(at, r.d2.rows()) = r.d2.leftCols(k);
    residual.middleRows(at, r.d2.rows()) = r.residual;
    at += r.d2.rows();
  }
  const detail::Probe probe = detail::probe_from_rows(d2, residual);
  const detail::TileSizes sizes = detail::tile_sizes(probe, options, finite);
  TileDecisions d;
  d.noise_ratio = probe.noise.ratio;
  d.spacing = probe.noise.spacing;
  d.far_radius = probe.far_radius;
  d.far_k = probe.far_k;
  d.k_smooth = sizes.choice.k_smooth;
  d.scales = sizes.choice.scales;
  d.halo = options.tiles.halo * sizes.radius(sizes.kneed);
  d.variation_halo = options.tiles.halo * sizes.radius(sizes.choice.k_smooth);
  d.cell_means = detail::cell_means_apply(options, finite) &&
                 probe.noise.ratio >= options.cell_means.noise_ratio;
  if (d.cell_means) d.halo = std::max(d.halo, means_halo(sizes, probe.noise.ratio, options));
  return d;
}

Eigen::VectorXd detail::surface_variation(const Points& pts, int k, const RunContext& run) {
  IndexMatrix knn;
  Neighbors(pts).knn_all(k, knn, nullptr, detail::narrow(run, 0, 0.7));
  return pca_normals(pts, knn, PcaOptions{k}, detail::narrow(run, 0.7, 1)).variation;
}

Eigen::VectorXd tile_variation(const Points& pts, int64_t own, int k_smooth, int64_t step,
                               int threads) {
  std::vector<std::string> ignored;
  const detail::Canonical canon = detail::canonical_points(pts, ignored);
  const int k = int(std::min<Eigen::Index>(k_smooth, canon.pts.rows()));
  const Eigen::VectorXd variation =
      detail::surface_variation(canon.pts, k, RunContext{threads, {}});
  // Own points only, one value per distinct position (the in-memory run's canonical points).
  std::vector<double> kept;
  int64_t seen = 0;
  for (Eigen::Index c = 0; c < canon.pts.rows(); ++c)
    if (canon.rows[size_t(c)] < own && seen++ % std::max<int64_t>(1, step) == 0)
      kept.push_back(variation[c]);
  return Eigen::Map<const Eigen::VectorXd>(kept.data(), Eigen::Index(kept.size()));
}

int64_t variation_step(int64_t finite, int64_t sample) {
  return std::max<int64_t>(1, (finite + sample - 1) / std::max<int64_t>(1, sample));
}

double variation_threshold(const Eigen::VectorXd& variation) {
  return detect_feature_candidates(variation).absolute_threshold;
}

EstimateResult estimate_tile(const Points& pts, const EstimateOptions& options,
                             const TileDecisions& decisions) {
  detail::check_options(options);
  detail::TileOverrides ov;
  ov.noise_ratio = decisions.noise_ratio;
  ov.spacing = decisions.spacing;
  ov.variation_threshold = decisions.variation_threshold;
  EstimateResult res;
  if (!decisions.cell_means ||
      !detail::tile_through_cell_means(pts, options, decisions.noise_ratio, decisions.spacing, res))
    res = detail::estimate_cloud(pts, options, ov);
  detail::add_confidence(pts, options, res);  // over the halo too: the own points' neighbours
  return res;
}

}  // namespace nhnet
