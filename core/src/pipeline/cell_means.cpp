// Dense noisy clouds through cell means (not in the paper; CellMeanOptions in estimate.hpp):
//   1. the noise probe of the whole cloud (the one its own estimate would run);
//   2. where noise ratio >= CellMeanOptions::noise_ratio, one point per cube of `edge` noise
//      deviations, replaced by the mean of the points within `edge` of it (each averages its
//      points' noise, as a larger neighbourhood would; a ball around a point, not the cube
//      itself, so the means do not follow the cube grid's steps);
//   3. the estimate of the means (any method, tiled when they are many);
//   4. every point takes the normal of its three nearest means, weighted by inverse distance
//      (signs of the nearest), and the nearest's candidate flag.
#include "pipeline/cell_means.hpp"

#include "nhnet/neighbors/neighbors.hpp"
#include "util/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

namespace nhnet::detail {

namespace {

constexpr int kAxisBits = 21;  // cells per axis below 2^21: three fit one 64-bit key

/// One point of `pts` (M x 3) per cube of `edge` on a grid anchored at their minimum: the
/// lowest row in each cube, in the order of the cubes' keys. Empty when the grid would need more
/// than 2^21 cubes along an axis.
std::vector<int64_t> one_per_cell(const Points& pts, double edge) {
  const Eigen::RowVector3d low = pts.colwise().minCoeff();
  const Eigen::RowVector3d cells = ((pts.colwise().maxCoeff() - low) / edge).array().floor();
  if (!(cells.maxCoeff() < double(1 << kAxisBits) - 1)) return {};
  std::vector<std::pair<uint64_t, int64_t>> keyed(size_t(pts.rows()));
  for (Eigen::Index i = 0; i < pts.rows(); ++i) {
    uint64_t key = 0;
    for (int a = 0; a < 3; ++a)
      key = (key << kAxisBits) | uint64_t(std::floor((pts(i, a) - low[a]) / edge));
    keyed[size_t(i)] = {key, int64_t(i)};
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<int64_t> rows;
  for (size_t s = 0; s < keyed.size(); ++s)
    if (s == 0 || keyed[s].first != keyed[s - 1].first) rows.push_back(keyed[s].second);
  return rows;
}

/// The mean of the points of `tree` (over `pts`) within `radius` of each point `rows`.
Points ball_means(const Points& pts, const Neighbors& tree, const std::vector<int64_t>& rows,
                  double radius, const RunContext& run) {
  Points means(Eigen::Index(rows.size()), 3);
  Progress progress(run.progress);
  if (run.progress) progress.stage("cell means", 0, 1);
  parallel_for(int64_t(rows.size()), run.threads, run.progress ? &progress : nullptr,
               [&](int64_t r) {
                 thread_local std::vector<std::pair<int32_t, float>> ball;
                 tree.radius(pts.row(rows[size_t(r)]).transpose(), radius, ball);
                 Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
                 for (const auto& [j, d2] : ball) sum += pts.row(j);
                 means.row(Eigen::Index(r)) = sum / double(ball.size());  // the point itself is in
               });
  progress.throw_if_cancelled();
  return means;
}

/// For every canonical point its kNearest nearest means (rows) and their inverse distances.
struct NearestMeans {
  static constexpr int kNearest = 3;
  std::vector<int32_t> rows;   // kNearest per point, nearest first
  std::vector<float> weights;  // 0: no such mean (fewer means than kNearest)

  /// The nearest of point c's means with a normal (the side its blend takes); -1 if none.
  int32_t nearest_valid(size_t c, const EstimateResult& of_means) const {
    for (int j = 0; j < kNearest; ++j) {
      const int32_t m = rows[c * kNearest + size_t(j)];
      if (weights[c * kNearest + size_t(j)] > 0 && of_means.valid[size_t(m)]) return m;
    }
    return -1;
  }
};

NearestMeans nearest_means(const Points& pts, const Points& means, const RunContext& run) {
  const Neighbors tree(means);
  constexpr int kn = NearestMeans::kNearest;
  NearestMeans out;
  out.rows.assign(size_t(pts.rows()) * kn, 0);
  out.weights.assign(size_t(pts.rows()) * kn, 0.f);
  const int k = int(std::min<Eigen::Index>(kn, means.rows()));
  Progress progress(run.progress);
  if (run.progress) progress.stage("nearest cell mean", 0, 1);
  parallel_for(pts.rows(), run.threads, run.progress ? &progress : nullptr, [&](int64_t i) {
    thread_local std::vector<int32_t> idx;
    thread_local std::vector<float> d2;
    tree.knn(pts.row(i).transpose(), k, idx, d2);
    for (int j = 0; j < k; ++j) {
      out.rows[size_t(i) * kn + size_t(j)] = idx[size_t(j)];
      out.weights[size_t(i) * kn + size_t(j)] = 1.f / std::max(std::sqrt(d2[size_t(j)]), 1e-12f);
    }
  });
  progress.throw_if_cancelled();
  return out;
}

/// Point c's normal, curvature and (when the means have one) confidence from its nearest means'
/// valid ones (inverse-distance weights, each normal turned to the side of the nearest valid
/// one); returns that mean's row, or -1 (nothing written) when none is valid.
int32_t blend_means(const NearestMeans& near, size_t c, const EstimateResult& of_means,
                    Eigen::RowVector3d& normal, double& curvature, double& confidence) {
  constexpr int kn = NearestMeans::kNearest;
  const int32_t side = near.nearest_valid(c, of_means);
  if (side < 0) return -1;
  const Eigen::RowVector3d first = of_means.normals.row(side);
  Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
  const bool scored = of_means.confidence.size() == of_means.normals.rows();
  double wsum = 0, csum = 0, qsum = 0;
  for (int j = 0; j < kn; ++j) {
    const int32_t m = near.rows[c * kn + size_t(j)];
    const double w = near.weights[c * kn + size_t(j)];
    if (!(w > 0) || !of_means.valid[size_t(m)]) continue;
    const Eigen::RowVector3d n = of_means.normals.row(m);
    sum += (n.dot(first) < 0 ? -w : w) * n;
    csum += w * of_means.curvature[m];
    if (scored) qsum += w * of_means.confidence[m];
    wsum += w;
  }
  normal = sum.normalized();  // the side's own normal has weight > 0: the sum is not zero
  curvature = csum / wsum;
  if (scored) confidence = qsum / wsum;
  return side;
}

/// The result of the input rows from the means' result: each canonical point's nearest mean's.
/// `sides` receives each canonical point's nearest valid mean (blend_means; -1: none).
EstimateResult from_means(const Points& points, const Canonical& canon, const NearestMeans& nearest,
                          EstimateResult&& of_means, std::vector<int32_t>& sides) {
  EstimateResult res = empty_result(points.rows());
  if (!of_means.candidate.empty()) res.candidate.assign(size_t(points.rows()), 0);
  if (of_means.confidence.size() != 0)
    res.confidence.setConstant(points.rows(), std::numeric_limits<double>::quiet_NaN());
  double unscored = 0;  // the confidence's place when the means have none
  sides.assign(canon.rows.size(), -1);
  for (size_t c = 0; c < canon.rows.size(); ++c) {
    const Eigen::Index row = Eigen::Index(canon.rows[c]);
    Eigen::RowVector3d normal;
    double& confidence = res.confidence.size() != 0 ? res.confidence[row] : unscored;
    const int32_t side = blend_means(nearest, c, of_means, normal, res.curvature[row], confidence);
    sides[c] = side;
    if (side < 0) continue;
    res.normals.row(row) = normal;
    res.valid[size_t(row)] = 1;
    if (!res.candidate.empty()) res.candidate[size_t(row)] = of_means.candidate[size_t(side)];
  }
  res.tiles = of_means.tiles;
  res.cell_means = of_means.normals.rows();
  res.k_used = of_means.k_used;
  res.scales_used = std::move(of_means.scales_used);
  res.device_used = std::move(of_means.device_used);
  res.precision_used = std::move(of_means.precision_used);
  res.descriptor_k = of_means.descriptor_k;
  return res;
}

/// The means, their normals and each input row's mean (`sides`, from_means's; -1: none).
void keep_means(const Canonical& canon, const std::vector<int32_t>& sides, Normals&& normals,
                Points&& means, MeansRun& keep) {
  keep.mean_of_row.assign(canon.copies.size(), -1);
  for (size_t c = 0; c < canon.rows.size(); ++c) keep.mean_of_row[size_t(canon.rows[c])] = sides[c];
  for (size_t i = 0; i < canon.copies.size(); ++i)
    if (canon.copies[i] >= 0 && canon.copies[i] != int64_t(i))
      keep.mean_of_row[i] = keep.mean_of_row[size_t(canon.copies[i])];
  keep.means = std::move(means);
  keep.normals = std::move(normals);
  keep.unit = canon.unit;
}

}  // namespace

OrientResult orient_through_means(MeansRun& run, EstimateResult& res, const OrientOptions& orient) {
  OrientResult r = orient_normals(run.means, run.normals, orient);
  r.voxel *= run.unit;
  r.flipped = 0;
  r.invalid = 0;
  for (size_t i = 0; i < run.mean_of_row.size(); ++i) {
    const int32_t m = run.mean_of_row[i];
    if (m < 0) {
      ++r.invalid;
      continue;
    }
    if (run.normals.row(m).dot(res.normals.row(Eigen::Index(i))) < 0) {
      res.normals.row(Eigen::Index(i)) *= -1;
      ++r.flipped;
    }
  }
  return r;
}

bool cell_means_apply(const EstimateOptions& options, int64_t finite) {
  const CellMeanOptions& cm = options.cell_means;
  return cm.noise_ratio > 0 && options.k == 0 && options.mfps.scales.empty() &&
         finite >= cm.min_points;
}

namespace {

/// Steps 2-4 on the canonical points of `prepared` (tree built, the noise measured: `ratio` and
/// `spacing` in canonical units); false when the cubes give fewer than 3 means.
bool estimate_means(const Points& points, Prepared& prepared, double ratio, double spacing,
                    const EstimateOptions& options, EstimateResult& out, MeansRun* keep) {
  const Canonical& canon = prepared.canon;
  const RunContext& run = options.run;
  const double edge = options.cell_means.edge * ratio * spacing;
  const std::vector<int64_t> centres = one_per_cell(canon.pts, edge);
  if (centres.size() < 3) return false;
  Points means = ball_means(canon.pts, *prepared.tree, centres, edge, narrow(run, 0.04, 0.06));
  prepared.tree.reset();  // the points' tree is not needed below
  std::vector<std::string> warnings = std::move(prepared.warnings);
  EstimateOptions o = options;
  o.cell_means.noise_ratio = 0;
  o.neighbours = 0;  // the means' table is not the points'
  o.run = narrow(run, 0.06, 0.93);
  EstimateResult of_means = estimate_points(means, o, TileOverrides{});
  o.run = narrow(run, 0.93, 0.95);
  add_confidence(means, o, of_means);  // the points take their means' blend of it
  for (const std::string& w : of_means.warnings) warnings.push_back("cell means: " + w);
  const NearestMeans nearest = nearest_means(canon.pts, means, narrow(run, 0.95, 1));
  Normals mean_normals = keep ? of_means.normals : Normals();
  std::vector<int32_t> sides;
  out = from_means(points, canon, nearest, std::move(of_means), sides);
  if (keep) keep_means(canon, sides, std::move(mean_normals), std::move(means), *keep);
  out.noise_ratio = ratio;
  out.spacing = spacing * canon.unit;  // input units
  out.warnings = std::move(warnings);
  finish_result(out, canon.copies, canon.finite_count);
  if (!out.candidate.empty())
    for (const int64_t row : canon.rows) out.candidates += out.candidate[size_t(row)];
  return true;
}

}  // namespace

bool through_cell_means(const Points& points, const EstimateOptions& options, EstimateResult& out,
                        TileOverrides& measured, Prepared& prepared, MeansRun* keep) {
  if (!cell_means_apply(options, points.rows())) return false;
  start_threads(options.run.threads);
  // Built for the estimate either way: it takes them over when the means do not apply.
  prepare_points(points, prepared, narrow(options.run, 0, 0.04));
  const Canonical& canon = prepared.canon;
  const Probe& probe = prepared.probe;
  measured.noise_ratio = probe.noise.ratio;
  measured.spacing = probe.noise.spacing * canon.unit;  // input units, as estimate_cloud takes
  if (!cell_means_apply(options, int64_t(canon.finite_count)) ||
      probe.noise.ratio < options.cell_means.noise_ratio)
    return false;
  return estimate_means(points, prepared, probe.noise.ratio, probe.noise.spacing, options, out,
                        keep);
}

bool tile_through_cell_means(const Points& points, const EstimateOptions& options,
                             double noise_ratio, double spacing, EstimateResult& out) {
  start_threads(options.run.threads);
  Prepared prepared;  // no probe: the whole cloud's noise is given
  index_points(points, prepared);
  return estimate_means(points, prepared, noise_ratio, spacing / prepared.canon.unit, options, out,
                        nullptr);
}

}  // namespace nhnet::detail
