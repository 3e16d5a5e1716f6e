// Per-point residual bandwidth sigma_j of paper Eq. 1-4 (the paper leaves it open; we follow the
// authors' code, see docs/design/paper.md#residual-bandwidth-authors-rule): every point takes the
// plane residual it has in the "best" small patch around it, and its bandwidth is the mean of those
// residuals over a larger neighbourhood. The kernel width of MFPS is then sigma_j = 2 *
// bandwidth(j).
#pragma once

#include "nhnet/geometry/pca.hpp"
#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

namespace nhnet {

struct BandwidthOptions {
  /// Patch size (self included) of the PCA planes whose residuals are measured (authors: 35).
  int k_patch = 35;
  /// Neighbourhood over which residuals are averaged (authors: 225 = 1.5 Kmax; clamped to the
  /// columns of knn).
  int k_average = 225;
  /// A point takes its residual from the best of at most this many of the k_patch patches
  /// around it, spread evenly over their distance ranks (0 = all, the authors' behaviour), so
  /// that the search's cost per point does not grow with the noise-driven k (issue 23); 1 or
  /// less than 0 is refused (InvalidOptions).
  int max_patches = 128;
  /// Lower bound of a bandwidth as a fraction of the point spacing, so that exactly planar data
  /// keeps a usable (non-zero) kernel.
  double min_fraction_of_spacing = 1e-3;
};

/// Residual bandwidth of every point of `points` (N x 3), in input units (N-vector).
/// `knn` is N x K (K >= k_patch), self first. For point j the residual is taken from the patch,
/// among the k_patch-NN patches centred at j's own k_patch nearest neighbours (the patches that
/// contain j when neighbourhoods are symmetric), that minimises E_i * exp((o_j / 2 mu_i)^2)
/// (E_i: sum of absolute residuals of patch i, mu_i their mean, o_j: offset of j from the plane
/// through the patch centre) -- the authors' rule, written as a gather so it runs in parallel.
/// `spacing` is the average point spacing (for the lower bound). `planes`: pca_normals() of the
/// same points and table; its planes are the patches' when its k is k_patch (then they are not
/// fitted again: same result, one PCA instead of two).
Eigen::VectorXd residual_bandwidth(const Points& points, const IndexMatrix& knn, double spacing,
                                   const BandwidthOptions& options = {}, const RunContext& run = {},
                                   const PcaResult* planes = nullptr);

}  // namespace nhnet
