// Multi-scale bilateral normal filtering (paper Sec. 5.1, Eq. 5): every point gets its input
// (MFPS) normal plus one filtered normal per (sigma_s, sigma_r) pair,
//   n_i' = normalise( sum_j W_s(|p_i - p_j|) W_r(|n_i - n_j|) n_j ),  W_s(x) = exp(-x^2/(2 s^2)),
// with s = sigma_s * l_i (l_i = the point's own average spacing) and W_r(x) = exp(-x^2/(2
// sigma_r^2)). The input normals are unoriented, so each n_j is first flipped to agree with n_i
// (then |n_i - n_j|^2 = 2 (1 - |n_i . n_j|)). One pass; every pair filters the input normals.
#pragma once

#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

#include <vector>

namespace nhnet {

/// N x (3 F) rows of F unit normals each, row-major ([n_1 | n_2 | ...]).
using FeatureNormals = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct BilateralFilterOptions {
  /// Spatial widths as multiples of the point's average spacing. Paper: {1, 2}.
  std::vector<double> sigma_s{1.0, 2.0};
  /// Normal-difference widths. Paper: {0.1, 0.2, 0.35, 0.5}.
  std::vector<double> sigma_r{0.1, 0.2, 0.35, 0.5};
  /// Nearest other points averaged for the per-point spacing l_i. Authors' code: 8.
  int spacing_k = 8;
};

/// Filters `normals` (N x 3, unoriented) over the first `k` columns of `knn` (M x K, self first;
/// row r lists the neighbours of point `first` + r, so a block of points can be done at a time).
/// Returns M x 3 (1 + |sigma_s| |sigma_r|): the input normal first, then for each sigma_s the
/// sigma_r in order; all on the input normal's side. Rows with a non-finite input normal are NaN.
FeatureNormals bilateral_filter(const Points& points, const Normals& normals,
                                const IndexMatrix& knn, int k,
                                const BilateralFilterOptions& options = {},
                                const RunContext& run = {}, Eigen::Index first = 0);

}  // namespace nhnet
