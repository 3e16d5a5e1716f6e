// Candidate mix (not the paper's; docs/design/decisions.md#candidate-mix): the last step of
// --method nhnet. Each point has four candidate normals: NH-Net's refined MFPS normal (Sec. 5),
// the same rotated towards the PCA normal by MFPS's blend weight, the PCA normal and the blended
// MFPS normal. A small fixed network (two tanh layers of kMixHidden) maps rotation-invariant
// features of the point to softmax weights over the candidates; the normal is the normalised
// weighted sum of the sign-aligned candidates. The candidates disagree most where the paper's
// network is weakest (organic surfaces at high noise, where the large PCA neighbourhood wins); the
// mix learns whom to trust there. Weights fitted by tools/fit_candidate_mix.py on the training
// split only, minimising each training cloud's mean squared angle error (RMS, not the mean).
#pragma once

#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

#include <cstdint>
#include <vector>

namespace nhnet {

/// Features of a point, in this order: angles (radians) net-PCA, net-blended MFPS, PCA-blended
/// MFPS, net-unblended MFPS; MFPS's blend weight; candidate flag (MFPS normal != PCA normal);
/// log of the cloud's noise ratio; sqrt of the surface variation; 1 - mean |n_i . n_j| over the
/// kMixNeighbours nearest points of the PCA, blended MFPS and unblended MFPS normals.
constexpr int kMixFeatures = 11;
/// Candidates, in this order: net, net blended towards PCA, PCA, blended MFPS.
constexpr int kMixCandidates = 4;
/// Width of the mix's two hidden layers.
constexpr int kMixHidden = 32;
/// Neighbours (self included) of the inconsistency features.
constexpr int kMixNeighbours = 16;

/// What the mix reads, all of the same M points (rows of `knn`, whose columns index them too,
/// self first, at least kMixNeighbours deep).
struct CandidateMixInput {
  /// NH-Net's normals (M x 3; a NaN row or one equal to `mfps` where the model gave none).
  const Normals* net = nullptr;
  /// MFPS normals before its PCA blend (M x 3): what NH-Net refined.
  const Normals* mfps = nullptr;
  /// PCA normals (M x 3; NaN where PCA failed).
  const Normals* pca = nullptr;
  /// MFPS's blend weights (M; 0 where no rival).
  const Eigen::VectorXd* blend_weight = nullptr;
  /// Surface variations (M).
  const Eigen::VectorXd* variation = nullptr;
  /// Neighbour table (M x K, K >= kMixNeighbours).
  const IndexMatrix* knn = nullptr;
  /// The cloud's noise ratio (EstimateResult::noise_ratio).
  double noise_ratio = 0;
};

/// The mixed normals (M x 3, unit). A point whose PCA normal or network normal is missing keeps
/// its network normal (or its MFPS normal when both are). Cancellable through `run`.
Normals mix_candidates(const CandidateMixInput& in, const RunContext& run = {});

}  // namespace nhnet
