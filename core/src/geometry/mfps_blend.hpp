// Internal to MFPS (mfps.cpp): the PCA blend (MfpsOptions::pca_blend). Not the paper's: a
// logistic weight, fitted by tools/fit_mfps_blend.py, of a quadratic form of features of the
// two-face selection; each candidate with a rival is rotated towards its PCA normal by that
// weight, which is large where the selection is likely wrong (see mfps.hpp,
// docs/design/decisions.md#mfps-pca-blend).
#pragma once

#include "nhnet/geometry/mfps.hpp"
#include "nhnet/types.hpp"

#include <array>
#include <cstdint>
#include <limits>
#include <vector>

namespace nhnet::detail {

/// The features listed at kMfpsBlendFeatures (mfps.hpp), of one candidate.
using BlendFeatures = std::array<double, kMfpsBlendFeatures>;

/// 1 - mean |n_i . n_j| over the first `k` neighbours of row i of `knn` (self included) whose
/// normal is finite; 0 when none is. Also a feature of NH-Net's candidate mix.
double inconsistency(const Normals& normals, const IndexMatrix& knn, Eigen::Index i, int k);

/// Rotates unit `a` towards unit `b` (sign-aligned) by fraction t of the angle between them.
/// Also the rotation of the two-face posterior (mfps.cpp).
Eigen::Vector3d slerp_towards(const Eigen::Vector3d& a, Eigen::Vector3d b, double t);

/// How a candidate with a rival was placed between its two faces (mfps.cpp).
struct TwoFaceChoice {
  /// Unit normal of the winning patch (argmax of Eq. 4).
  Eigen::Vector3d winner = Eigen::Vector3d::Zero();
  /// Unit normal of the best rival patch, sign-aligned with `winner`.
  Eigen::Vector3d rival = Eigen::Vector3d::Zero();
  /// `winner` rotated towards `rival` by `p`: the candidate's normal before the blend.
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  /// The winner's score D of Eq. 4.
  double score = 0;
  /// P(rival) from the score ratio alone.
  double p_score = 0;
  /// P(rival) from the edge geometry (-1: off, or the two planes nearly parallel).
  double p_edge = -1;
  /// Final P(rival).
  double p = 0;
  /// Distance from the candidate to the winner-rival edge line (infinite when not computed).
  double line_distance = std::numeric_limits<double>::infinity();
};

/// The candidates with a rival, in row order, and their blend features.
struct BlendCandidates {
  std::vector<int64_t> rows;
  std::vector<BlendFeatures> features;
};

/// The blend features of one candidate (`pca`: its PCA normal, `sigma`: its sigma_i), all but
/// the two neighbourhood ones (8, 9), which need every point's final normal first.
BlendFeatures blend_features(const TwoFaceChoice& choice, const Eigen::Vector3d& pca, double sigma);

/// Completes the features (8, 9) from the normals in `res` before any blending, records them
/// (options.record_blend_features) or keeps the weights alone (options.keep_blend_weights) and,
/// with options.pca_blend, rotates each candidate's normal towards its PCA normal
/// (`base_normals`) by the fitted weight.
void blend_towards_pca(BlendCandidates candidates, const IndexMatrix& knn,
                       const Normals& base_normals, const MfpsOptions& options, MfpsResult& res);

}  // namespace nhnet::detail
