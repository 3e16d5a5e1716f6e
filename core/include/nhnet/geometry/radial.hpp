// Radial normals (not the paper's): the point's offset from the centroid of its k nearest
// neighbours, without its part along their principal direction (the largest eigenvector of the
// covariance of Eq. 1's PCA). On a thin part (a limb, a rod, a thin edge) the neighbourhood wraps
// around the surface, PCA's smallest eigenvector is arbitrary, and the point sits off the local
// axis along its normal; on a broad flat patch the offset is noise. So it is a candidate of
// NH-Net's candidate mix (learned/candidate_mix.hpp), with the offset's length and the middle
// over the largest eigenvalue as the features that tell the two apart.
#pragma once

#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

#include <Eigen/Core>

namespace nhnet {

struct RadialOptions {
  /// Neighbourhood size, self included (0 = all columns of knn); at least 3.
  int k = 0;
};

struct RadialResult {
  /// N x 3 unit radial normals; NaN where the point is on the axis or the neighbours coincide.
  Normals normals;
  /// Per point, the offset's length over the neighbourhood's RMS spread (sqrt of the trace of
  /// the covariance); NaN with the normal.
  Eigen::VectorXd offset;
  /// Per point, the middle over the largest eigenvalue of the covariance (0 along a line, 1
  /// where the spread is round across the principal direction); NaN where all coincide.
  Eigen::VectorXd elongation;
};

/// Radial normals of `points` (N x 3) over the first options.k columns of `knn` (N x K, self
/// first).
RadialResult radial_normals(const Points& points, const IndexMatrix& knn,
                            const RadialOptions& options = {}, const RunContext& run = {});

}  // namespace nhnet
