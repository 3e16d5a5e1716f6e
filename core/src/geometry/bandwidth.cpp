// Residual bandwidth (sigma_j of paper Eq. 1-4), following the authors' rule
// (docs/design/paper.md#residual-bandwidth-authors-rule) in gather form.
#include "nhnet/geometry/bandwidth.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/geometry/pca.hpp"
#include "util/parallel.hpp"
#include "util/spread.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace nhnet {

Eigen::VectorXd residual_bandwidth(const Points& points, const IndexMatrix& knn, double spacing,
                                   const BandwidthOptions& options, const RunContext& run,
                                   const PcaResult* planes) {
  const Eigen::Index n = points.rows();
  if (knn.rows() != n) throw InvalidOptions("residual_bandwidth: knn must have one row per point");
  if (options.max_patches != 0 && options.max_patches < 2)  // 1 or negative meant all, silently
    throw InvalidOptions("residual_bandwidth: max_patches must be 0 (all patches) or at least 2");
  const int kp = int(std::min<Eigen::Index>(std::max(3, options.k_patch), knn.cols()));
  const int ka = int(std::min<Eigen::Index>(std::max(1, options.k_average), knn.cols()));
  const int mp = detail::spread_count(kp, options.max_patches);

  // Pass 1: PCA plane (centroid, normal) and summed absolute residual E_i of every kp-NN patch.
  if (planes && (planes->k != kp || planes->centroid.rows() != n || planes->normals.rows() != n))
    planes = nullptr;  // another patch size: fitted here
  Points centroid(n, 3), normal(n, 3);
  Eigen::VectorXd esum(n), log_esum(n);
  detail::Progress progress(run.progress);
  if (run.progress) progress.stage("bandwidth", 0, 0.4);
  detail::parallel_for(n, run.threads, run.progress ? &progress : nullptr, [&](int64_t i) {
    Eigen::Vector3d c;
    Eigen::Vector3d nrm;
    if (planes) {
      c = planes->centroid.row(i).transpose();
      nrm = planes->normals.row(i).transpose();
    } else {
      nrm = fit_plane(points, &knn(i, 0), kp, &c);
    }
    if (!nrm.allFinite()) nrm = Eigen::Vector3d::UnitZ();  // degenerate: residuals along z
    double e = 1e-9;
    for (int j = 0; j < kp; ++j) e += std::abs((points.row(knn(i, j)).transpose() - c).dot(nrm));
    centroid.row(i) = c.transpose();
    normal.row(i) = nrm.transpose();
    esum[i] = e;
    log_esum[i] = std::log(e);
  });

  // Pass 2: every point j takes its residual from the best patch among those centred at its
  // own kp nearest neighbours (at most mp of them, spread), the patch of least E_i exp(q^2). A
  // patch whose score's logarithm exceeds the best one's by far more than rounding cannot win, and
  // is passed over without its exp (the same choice as scoring every patch, with a few exp calls a
  // point, not kp).
  Eigen::VectorXd err(n);
  if (run.progress) progress.stage("bandwidth", 0.4, 0.8);
  constexpr double kLogMargin = 1e-6;  // >> the relative rounding of exp, log and a product
  detail::parallel_for(n, run.threads, run.progress ? &progress : nullptr, [&](int64_t j) {
    const Eigen::Vector3d pj = points.row(j).transpose();
    double best = std::numeric_limits<double>::infinity(), res = 0;
    double log_best = best;
    for (int t = 0; t < mp; ++t) {
      const int32_t i = knn(j, detail::spread_rank(t, mp, kp));
      const Eigen::Vector3d ni = normal.row(i).transpose();
      const double mu = esum[i] / kp;
      const double o = std::abs((pj - points.row(i).transpose()).dot(ni));
      const double q = o / (2 * mu);
      const double q2 = std::min(q * q, 700.0);
      if (log_esum[i] + q2 > log_best + kLogMargin) continue;
      const double score = esum[i] * std::exp(q2);
      if (score < best) {
        best = score;
        log_best = std::log(best);
        res = std::abs((pj - centroid.row(i).transpose()).dot(ni));
      }
    }
    err[j] = res;
  });

  // Pass 3: average over the ka nearest neighbours.
  Eigen::VectorXd bw(n);
  const double floor_value = std::max(options.min_fraction_of_spacing * spacing, 1e-300);
  if (run.progress) progress.stage("bandwidth", 0.8, 1.0);
  detail::parallel_for(n, run.threads, run.progress ? &progress : nullptr, [&](int64_t i) {
    double s = 0;
    for (int t = 0; t < ka; ++t) s += err[knn(i, t)];
    bw[i] = std::max(s / ka, floor_value);
  });
  return bw;
}

}  // namespace nhnet
