// Scales that follow the noise. The paper picks K by hand per noise level (Sec. 6.2: K = {50,
// 100, 150}, doubled for its BigNoise category) and PCA for smooth points is only as good as its
// neighbourhood size. We measure the cloud's noise level and choose the smooth-point PCA
// neighbourhood and the MFPS scale set from it:
//   noise ratio rho = the noise part of the low quantile of the 75-NN PCA residual (RMS distance
//                     to the fitted plane) / point spacing; a low quantile reads the flattest
//                     parts of the cloud, and the noise part is what stays of it once the
//                     geometry's share is taken out: noise keeps the residual nearly flat in
//                     the neighbourhood size, curvature and features smaller than the
//                     neighbourhood make it grow ~ k (residual ~ r^2), so the low quantiles at
//                     20 and 75 neighbours split the two (estimate_noise);
//   k_smooth = interpolated (log-linear) in a table rho -> k fitted on the training models
//              (never on benchmark models), erring towards larger k since too small a k costs
//              far more than too large;
//   scales = {1, 2, 3} * k_smooth / 0.7 (the authors' ratio of PCA size to Kmin, 35 / 50),
//            capped at kMaxScale.
// The table and how it was measured are in scales.cpp and
// docs/design/decisions.md#noise-driven-neighbourhood-sizes.
#pragma once

#include "nhnet/types.hpp"

#include <cstdint>
#include <vector>

namespace nhnet {

/// Neighbourhood size of the noise probe (self included).
constexpr int kNoiseProbeK = 75;
/// The probe's second, smaller size (the first kNoiseProbeSmallK of the same neighbours).
constexpr int kNoiseProbeSmallK = 20;
/// Clouds with more points probe an evenly spaced subset of this many (estimate.cpp).
constexpr int64_t kProbeAllPoints = 200000;
/// Largest patch size the automatic rule picks (time and memory of the shared neighbour table;
/// 300 before 2026-12-05: on the training split's 30 noisiest clouds MFPS's RMS was 18.43 at
/// 250 against 18.42, docs/design/decisions.md#a-fixed-cost-per-point-at-high-noise).
constexpr int kMaxScale = 250;

struct NoiseEstimate {
  /// Point spacing: sqrt(pi / (K - 1)) * median distance to the K-th nearest point (K = the
  /// probe size); the grid step on a regular grid, blind to exact duplicates.
  double spacing = 0;
  /// Low quantile of the per-point PCA residuals at the probe size (input units).
  double residual = 0;
  /// The same quantile at kNoiseProbeSmallK neighbours (input units).
  double residual_small = 0;
  /// The noise part of `residual` (geometry's share taken out) / spacing: the noise level.
  double ratio = 0;
};

/// The probe's residuals, one row a probed point: at kNoiseProbeK and at kNoiseProbeSmallK.
using ProbeResiduals = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;

/// Plane-fit residual RMS over the first `count` neighbours of a point (`idx`, self first) and
/// over its first min(count, kNoiseProbeSmallK): one row of the probe's residuals.
Eigen::Vector2d probe_residuals(const Points& points, const int32_t* idx, int count);

/// Noise level from the probe: `sq_dist` (N x K) squared kNN distances and `residual_rms`
/// (N x 2) each point's probe_residuals over the same K neighbours.
NoiseEstimate estimate_noise(const DistanceMatrix& sq_dist, const ProbeResiduals& residual_rms);

struct ScaleChoice {
  /// PCA neighbourhood size (self included) for smooth points and --method pca.
  int k_smooth = 35;
  /// MFPS patch sizes, ascending.
  std::vector<int> scales{50, 100, 150};
};

/// The neighbourhood sizes for a noise ratio; never larger than `max_points` (the cloud size).
ScaleChoice choose_scales(double noise_ratio, Eigen::Index max_points);

}  // namespace nhnet
