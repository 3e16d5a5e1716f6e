// Accuracy metrics (benchmark protocol). Normals: unoriented angle error
// e = acos(min(1, |n_est . n_gt|)) in degrees, and its mean, RMS, PGP5, PGP10 and the share over
// 30 degrees (the badly wrong normals that RMS weighs). Points (denoising):
// distance of each point to a densely sampled clean surface.
#pragma once

#include "nhnet/types.hpp"

#include <cstdint>

namespace nhnet {

/// Per-point unoriented angle error in degrees between two N x 3 normal arrays (rows need not be
/// unit length). A row where either normal is non-finite or zero gets NaN.
Eigen::VectorXd angle_errors_deg(const Normals& estimated, const Normals& ground_truth);

struct AngleStats {
  double mean = 0;      ///< mean angle error, degrees
  double rms = 0;       ///< root mean square angle error, degrees
  double pgp5 = 0;      ///< share of points with error < 5 degrees, in [0, 1]
  double pgp10 = 0;     ///< share of points with error < 10 degrees, in [0, 1]
  double over30 = 0;    ///< share of points with error > 30 degrees, in [0, 1]
  int64_t count = 0;    ///< points that entered the statistics
  int64_t invalid = 0;  ///< points skipped because an error was NaN (failed / invalid normal)
};

/// Statistics of a vector of per-point errors in degrees; NaN entries are counted as invalid and
/// left out. Throws InvalidOptions when sizes differ (angle_stats(est, gt) overload).
AngleStats angle_stats(const Eigen::VectorXd& errors_deg);
AngleStats angle_stats(const Normals& estimated, const Normals& ground_truth);

/// Distance of every row of `points` (N x 3) to the surface sampled by `reference` (M x 3, finite
/// rows): point-to-plane |(p - c) . n_c| to the nearest reference point c when
/// `reference_normals` (M x 3) is given, point-to-point |p - c| when it is empty (0 rows). NaN
/// for a non-finite point. The denoising metric of the benchmark (divide by the bbox diagonal).
Eigen::VectorXd surface_distances(const Points& points, const Points& reference,
                                  const Normals& reference_normals = Normals());

}  // namespace nhnet
