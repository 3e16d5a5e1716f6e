// PCA normals (Hoppe et al.; paper Sec. 4, first paragraph): the normal of point i is the
// eigenvector of the smallest eigenvalue of the covariance of its k nearest neighbours, and the
// surface variation lambda_min / (lambda_1 + lambda_2 + lambda_3) measures how far the
// neighbourhood is from a plane (used to find candidate points near sharp features).
#pragma once

#include "nhnet/geometry/radial.hpp"
#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

namespace nhnet {

struct PcaOptions {
  /// Neighbourhood size, self included (authors' code: 35 = 0.7 * Kmin; 0 = all columns of knn).
  int k = 35;
  /// Keep each neighbourhood's centroid in PcaResult::centroid (24 bytes a point; the residual
  /// bandwidth reuses these planes instead of fitting them again).
  bool centroids = false;
  /// Also the radial candidates of the same neighbourhoods (geometry/radial.hpp) in
  /// PcaResult::radial: one covariance for both, as radial_normals at the same k gives them.
  bool radial = false;
};

struct PcaResult {
  /// N x 3 unit normals (unoriented); NaN rows where the neighbourhood is degenerate.
  Normals normals;
  /// N surface variations lambda_min / sum(lambda), in [0, 1/3].
  Eigen::VectorXd variation;
  /// N root-mean-square distances of the neighbourhood to its least-squares plane.
  Eigen::VectorXd residual_rms;
  /// N x 3 centroids of the neighbourhoods (the planes pass through them); empty unless
  /// PcaOptions::centroids.
  Points centroid;
  /// The radial candidates of the same neighbourhoods; empty unless PcaOptions::radial.
  RadialResult radial;
  /// Neighbours per point that were used.
  int k = 0;
};

/// PCA over the first `options.k` columns of `knn` (N x K, K >= k, from Neighbors::knn_all) of
/// `points` (N x 3).
PcaResult pca_normals(const Points& points, const IndexMatrix& knn, const PcaOptions& options = {},
                      const RunContext& run = {});

/// Least-squares plane through the rows `idx[0..count)` of `points`: returns the unit normal and
/// writes the centroid, the covariance's eigenvalues (ascending) and its principal direction
/// (the eigenvector of the largest) when asked. Degenerate input gives NaN.
Eigen::Vector3d fit_plane(const Points& points, const int32_t* idx, int count,
                          Eigen::Vector3d* centroid = nullptr,
                          Eigen::Vector3d* eigenvalues = nullptr,
                          Eigen::Vector3d* principal = nullptr);

}  // namespace nhnet
