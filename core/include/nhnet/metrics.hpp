// Accuracy metrics for normals (benchmark protocol): unoriented angle error
// e = acos(min(1, |n_est . n_gt|)) in degrees, and its mean, RMS, PGP5, PGP10.
#pragma once

#include "nhnet/types.hpp"

#include <cstdint>

namespace nhnet {

/// Per-point unoriented angle error in degrees between two N x 3 normal arrays (rows need not be
/// unit length). A row where either normal is non-finite or zero gets NaN.
Eigen::VectorXd angle_errors_deg(const Normals& estimated, const Normals& ground_truth);

struct AngleStats {
  double mean = 0;     ///< mean angle error, degrees
  double rms = 0;      ///< root mean square angle error, degrees
  double pgp5 = 0;     ///< share of points with error < 5 degrees, in [0, 1]
  double pgp10 = 0;    ///< share of points with error < 10 degrees, in [0, 1]
  int64_t count = 0;   ///< points that entered the statistics
  int64_t invalid = 0; ///< points skipped because an error was NaN (failed / invalid normal)
};

/// Statistics of a vector of per-point errors in degrees; NaN entries are counted as invalid and
/// left out. Throws InvalidOptions when sizes differ (angle_stats(est, gt) overload).
AngleStats angle_stats(const Eigen::VectorXd& errors_deg);
AngleStats angle_stats(const Normals& estimated, const Normals& ground_truth);

}  // namespace nhnet
