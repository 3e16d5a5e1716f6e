// Candidate points near sharp features (paper Sec. 4, first paragraph: local covariance
// analysis of [32], Sec. 4.2): a point is a candidate when its surface variation
// lambda_min / sum(lambda) exceeds a threshold chosen per cloud from the histogram of variations
// (the authors' rule, docs/design/paper.md#candidate-detection-authors-rule): 50-bin histogram, 1-D
// total-variation smoothing, threshold where the smoothed histogram has flattened after its peak.
#pragma once

#include "nhnet/types.hpp"

#include <cstdint>
#include <vector>

namespace nhnet {

struct FeatureDetectionOptions {
  /// Histogram bins over the normalised variation [0, 1] (authors: 50).
  int bins = 50;
  /// Weight of the total-variation term of the histogram smoothing (authors: 0.5).
  double tv_lambda = 0.5;
  /// Flatness tolerance of the smoothed histogram after its peak (authors: 0.05).
  double flat_tolerance = 0.05;
  /// Variations are divided by this quantile of all variations (authors: the maximum, 1.0; a
  /// quantile keeps one outlier from squeezing the histogram), then clamped to 1.
  double normalising_quantile = 0.999;
  /// Used when the histogram never flattens: candidates are the points above this quantile.
  double fallback_quantile = 0.9;
  /// Not the paper's: when >= 0, candidates are the points whose (absolute) variation exceeds
  /// this, instead of the histogram rule (the tiling applies the whole cloud's threshold to
  /// every tile).
  double fixed_threshold = -1;
};

struct FeatureDetection {
  /// N flags, 1 = candidate point near a sharp feature.
  std::vector<uint8_t> candidate;
  /// Threshold on the normalised variation that was applied (NaN with fixed_threshold, which
  /// applies no normalisation).
  double threshold = 0;
  /// The same threshold on the variation itself (threshold x the normalising quantile; +inf
  /// when nothing can be a candidate): what fixed_threshold takes.
  double absolute_threshold = 0;
  /// True when the histogram rule found no threshold and the fallback quantile was used.
  bool used_fallback = false;
  /// Number of candidates.
  int64_t count = 0;
};

/// Classifies points from their surface variations (N-vector, e.g. PcaResult::variation).
FeatureDetection detect_feature_candidates(const Eigen::VectorXd& variation,
                                           const FeatureDetectionOptions& options = {});

/// Exact 1-D total-variation denoising: argmin_x 0.5 |y - x|^2 + lambda sum |x_i - x_{i+1}|
/// (solved by projected gradient on the dual; sizes here are tiny). Returns x (same size as y).
Eigen::VectorXd tv_denoise_1d(const Eigen::VectorXd& y, double lambda);

}  // namespace nhnet
