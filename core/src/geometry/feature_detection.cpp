// Candidate detection near sharp features (paper Sec. 4, first paragraph): surface-variation
// threshold from a TV-smoothed histogram, as in the authors' code
// (docs/design/paper.md#candidate-detection-authors-rule).
#include "nhnet/geometry/feature_detection.hpp"

#include "nhnet/errors.hpp"
#include "util/stats.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace nhnet {

Eigen::VectorXd tv_denoise_1d(const Eigen::VectorXd& y, double lambda) {
  const Eigen::Index n = y.size();
  if (n < 2 || lambda <= 0) return y;
  // Dual: z in [-lambda, lambda]^(n-1), x = y - D^T z with (Dx)_i = x_i - x_{i+1}.
  Eigen::VectorXd z = Eigen::VectorXd::Zero(n - 1), x = y;
  const double step = 0.25;  // 1 / ||D D^T|| bound (eigenvalues of the path Laplacian < 4)
  for (int it = 0; it < 20000; ++it) {
    double change = 0;
    for (Eigen::Index i = 0; i < n - 1; ++i) {
      const double zi = std::clamp(z[i] + step * (x[i] - x[i + 1]), -lambda, lambda);
      change = std::max(change, std::abs(zi - z[i]));
      z[i] = zi;
    }
    for (Eigen::Index i = 0; i < n; ++i) {
      double dtz = 0;
      if (i < n - 1) dtz += z[i];
      if (i > 0) dtz -= z[i - 1];
      x[i] = y[i] - dtz;
    }
    if (change < 1e-12) break;
  }
  return x;
}

FeatureDetection detect_feature_candidates(const Eigen::VectorXd& variation,
                                           const FeatureDetectionOptions& options) {
  if (options.bins < 4) throw InvalidOptions("feature detection: bins must be >= 4");
  FeatureDetection out;
  const Eigen::Index n = variation.size();
  out.candidate.assign(size_t(n), 0);
  out.absolute_threshold = std::numeric_limits<double>::infinity();
  if (options.fixed_threshold >= 0) {
    out.absolute_threshold = options.fixed_threshold;
    out.threshold = std::numeric_limits<double>::quiet_NaN();
    for (Eigen::Index i = 0; i < n; ++i)
      if (std::isfinite(variation[i]) && variation[i] > options.fixed_threshold) {
        out.candidate[size_t(i)] = 1;
        ++out.count;
      }
    return out;
  }
  std::vector<double> v;
  v.reserve(size_t(n));
  for (Eigen::Index i = 0; i < n; ++i)
    if (std::isfinite(variation[i])) v.push_back(variation[i]);
  if (v.empty()) return out;
  const double scale = detail::quantile(v, options.normalising_quantile);
  if (!(scale > 0)) return out;  // all neighbourhoods exactly planar: no candidates

  const int nb = options.bins;
  Eigen::VectorXd hist = Eigen::VectorXd::Zero(nb);
  for (double s : v) {
    const double t = std::min(1.0, s / scale);
    hist[std::min(nb - 1, int(t * nb))] += 1;
  }
  Eigen::Index m = 0;
  hist.maxCoeff(&m);
  const Eigen::VectorXd x = tv_denoise_1d(hist / hist[m], options.tv_lambda);
  double threshold = -1;
  for (Eigen::Index i = m + 1; i + 1 < nb; ++i) {
    if (x[i - 1] - x[i + 1] < options.flat_tolerance && x[i] < x[m] - options.flat_tolerance) {
      threshold = double(i + 1) / nb;
      break;
    }
  }
  if (threshold < 0) {
    out.used_fallback = true;
    threshold = std::min(1.0, detail::quantile(v, options.fallback_quantile) / scale);
  }
  out.threshold = threshold;
  if (threshold < 1) out.absolute_threshold = threshold * scale;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (std::isfinite(variation[i]) && std::min(1.0, variation[i] / scale) > threshold) {
      out.candidate[size_t(i)] = 1;
      ++out.count;
    }
  }
  return out;
}

}  // namespace nhnet
