// Dense noisy clouds through cell means (not in the paper; CellMeanOptions in estimate.hpp):
//   1. the noise probe of the whole cloud (the one its own estimate would run);
//   2. where noise ratio >= CellMeanOptions::noise_ratio, the means of the points in cubes of
//      `edge` noise deviations (each averages its points' noise, as a larger neighbourhood would);
//   3. the estimate of the means (any method, tiled when they are many);
//   4. every point takes its nearest mean's normal, curvature and candidate flag.
#include "pipeline/cell_means.hpp"

#include "nhnet/neighbors/neighbors.hpp"
#include "util/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

namespace nhnet::detail {

namespace {

constexpr int kAxisBits = 21;  // cells per axis below 2^21: three fit one 64-bit key

/// Means of the points `pts` (M x 3) in cubes of `edge` on a grid anchored at their minimum, in
/// the order of the cubes' keys; each mean sums its points in row order. Empty when the grid
/// would need more than 2^21 cubes along an axis.
Points means_of_cells(const Points& pts, double edge) {
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
  std::vector<Eigen::RowVector3d> sums;
  for (size_t s = 0; s < keyed.size();) {
    size_t e = s;
    Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
    for (; e < keyed.size() && keyed[e].first == keyed[s].first; ++e)
      sum += pts.row(keyed[e].second);
    sums.push_back(sum / double(e - s));
    s = e;
  }
  Points means(Eigen::Index(sums.size()), 3);
  for (size_t c = 0; c < sums.size(); ++c) means.row(Eigen::Index(c)) = sums[c];
  return means;
}

/// For every canonical point, the row of its nearest mean.
std::vector<int32_t> nearest_means(const Points& pts, const Points& means, const RunContext& run) {
  const Neighbors tree(means);
  std::vector<int32_t> nearest(size_t(pts.rows()));
  Progress progress(run.progress);
  if (run.progress) progress.stage("nearest cell mean", 0, 1);
  parallel_for(pts.rows(), run.threads, run.progress ? &progress : nullptr, [&](int64_t i) {
    thread_local std::vector<int32_t> idx;
    thread_local std::vector<float> d2;
    tree.knn(pts.row(i).transpose(), 1, idx, d2);
    nearest[size_t(i)] = idx[0];
  });
  progress.throw_if_cancelled();
  return nearest;
}

/// The result of the input rows from the means' result: each canonical point's nearest mean's.
EstimateResult from_means(const Points& points, const Canonical& canon,
                          const std::vector<int32_t>& nearest, EstimateResult&& of_means) {
  EstimateResult res = empty_result(points.rows());
  if (!of_means.candidate.empty()) res.candidate.assign(size_t(points.rows()), 0);
  for (size_t c = 0; c < canon.rows.size(); ++c) {
    const Eigen::Index row = Eigen::Index(canon.rows[c]), from = nearest[c];
    if (!of_means.valid[size_t(from)]) continue;
    res.normals.row(row) = of_means.normals.row(from);
    res.curvature[row] = of_means.curvature[from];
    res.valid[size_t(row)] = 1;
    if (!res.candidate.empty()) res.candidate[size_t(row)] = of_means.candidate[size_t(from)];
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

/// The means, their normals and each input row's mean (rows without a valid mean: -1).
void keep_means(const Canonical& canon, const std::vector<int32_t>& nearest,
                const EstimateResult& of_means, Points&& means, MeansRun& keep) {
  keep.mean_of_row.assign(canon.copies.size(), -1);
  for (size_t c = 0; c < canon.rows.size(); ++c)
    if (of_means.valid[size_t(nearest[c])]) keep.mean_of_row[size_t(canon.rows[c])] = nearest[c];
  for (size_t i = 0; i < canon.copies.size(); ++i)
    if (canon.copies[i] >= 0 && canon.copies[i] != int64_t(i))
      keep.mean_of_row[i] = keep.mean_of_row[size_t(canon.copies[i])];
  keep.means = std::move(means);
  keep.normals = of_means.normals;
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
    const Eigen::RowVector3d n = run.normals.row(m);
    if (n.dot(res.normals.row(Eigen::Index(i))) < 0) ++r.flipped;
    res.normals.row(Eigen::Index(i)) = n;
  }
  return r;
}

bool through_cell_means(const Points& points, const EstimateOptions& options, EstimateResult& out,
                        TileOverrides& measured, Prepared& prepared, MeansRun* keep) {
  const CellMeanOptions& cm = options.cell_means;
  if (!(cm.noise_ratio > 0) || options.k != 0 || !options.mfps.scales.empty() ||
      points.rows() < cm.min_points)
    return false;
  start_threads(options.run.threads);
  prepared.source = points.data();
  prepared.canon = canonical_points(points, prepared.warnings);
  const Canonical& canon = prepared.canon;
  if (int64_t(canon.finite_count) < cm.min_points) return false;
  const RunContext& run = options.run;
  prepared.tree = std::make_unique<Neighbors>(canon.pts);
  const Probe probe = probe_noise(canon.pts, *prepared.tree, narrow(run, 0, 0.04), nullptr);
  measured.noise_ratio = probe.noise.ratio;
  measured.spacing = probe.noise.spacing * canon.unit;  // input units, as estimate_cloud takes
  if (probe.noise.ratio < cm.noise_ratio) return false;

  Progress top(run.progress);
  if (run.progress) top.stage("cell means", 0.04, 0.06);
  Points means = means_of_cells(canon.pts, cm.edge * probe.noise.ratio * probe.noise.spacing);
  top.throw_if_cancelled();
  if (means.rows() < 3) return false;
  prepared.tree.reset();  // the points' tree is not needed below
  std::vector<std::string> warnings = std::move(prepared.warnings);
  EstimateOptions o = options;
  o.cell_means.noise_ratio = 0;
  o.neighbours = 0;  // the means' table is not the points'
  o.run = narrow(run, 0.06, 0.95);
  EstimateResult of_means = estimate_points(means, o, TileOverrides{});
  for (const std::string& w : of_means.warnings) warnings.push_back("cell means: " + w);
  const std::vector<int32_t> nearest = nearest_means(canon.pts, means, narrow(run, 0.95, 1));
  if (keep) keep_means(canon, nearest, of_means, std::move(means), *keep);
  out = from_means(points, canon, nearest, std::move(of_means));
  out.noise_ratio = probe.noise.ratio;
  out.spacing = measured.spacing;
  out.warnings = std::move(warnings);
  finish_result(out, canon.copies, canon.finite_count);
  if (!out.candidate.empty())
    for (const int64_t row : canon.rows) out.candidates += out.candidate[size_t(row)];
  return true;
}

}  // namespace nhnet::detail
