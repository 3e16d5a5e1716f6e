// Candidate mix (not the paper's; docs/design/decisions.md#candidate-mix): the last step of
// --method nhnet. Each point has eight candidate normals: NH-Net's refined MFPS normal (Sec. 5),
// the same rotated towards the PCA normal by MFPS's blend weight, the PCA normal, the blended
// MFPS normal, the jet normal (geometry/jet.hpp), the PCA normal at half the scale and the
// radial normals (geometry/radial.hpp) at both scales. With
// ModelOptions::refine Moved (or Auto on a clean cloud) NH-Net runs only where MFPS moved the PCA
// normal (near features; elsewhere its candidate is the MFPS normal, there PCA's), a faster mode
// with its own fitted weights. A small fixed network (two tanh layers of kMixHidden) maps
// rotation-invariant features of the point to softmax weights over the candidates; the normal is
// the normalised weighted sum of the sign-aligned candidates. The candidates disagree most where
// the paper's network is weakest (organic surfaces at high noise, where the large PCA neighbourhood
// wins); the mix learns whom to trust there. Weights fitted by tools/fit_candidate_mix.py on the
// training split only, minimising each training cloud's mean squared angle error (RMS, not the
// mean).
#pragma once

#include "nhnet/geometry/radial.hpp"
#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

#include <cstdint>
#include <vector>

namespace nhnet {

/// Features of a point, in this order: angles (radians) net-PCA, net-blended MFPS, PCA-blended
/// MFPS, net-unblended MFPS; MFPS's blend weight; candidate flag (MFPS normal != PCA normal);
/// log of the cloud's noise ratio; sqrt of the surface variation; 1 - mean |n_i . n_j| over the
/// kMixNeighbours nearest points of the PCA, blended MFPS and unblended MFPS normals; angles
/// jet-net, jet-PCA, half-scale PCA-net, half-scale PCA-PCA; sqrt of the half-scale surface
/// variation; angles radial-net, radial-PCA, half-scale radial-net, half-scale radial-PCA; the
/// radial offsets at both scales, the elongations at both scales (0 where missing).
constexpr int kMixFeatures = 24;
/// Candidates, in this order: net, net blended towards PCA, PCA, blended MFPS, jet, half-scale
/// PCA, radial, half-scale radial.
constexpr int kMixCandidates = 8;
/// Width of the mix's two hidden layers.
constexpr int kMixHidden = 32;
/// Neighbours (self included) of the inconsistency features.
constexpr int kMixNeighbours = 16;

/// Neighbourhood of the half-scale PCA candidate for a PCA neighbourhood of k points.
constexpr int mix_half_k(int k) { return k / 2 > 6 ? k / 2 : 6; }

/// What the mix reads, all of the same M points (rows of `knn`, whose columns index them too,
/// self first, at least kMixNeighbours deep).
struct CandidateMixInput {
  /// NH-Net's normals (M x 3; a NaN row or one equal to `mfps` where the model gave none).
  const Normals* net = nullptr;
  /// MFPS normals before its PCA blend (M x 3): what NH-Net refined.
  const Normals* mfps = nullptr;
  /// PCA normals (M x 3; NaN where PCA failed).
  const Normals* pca = nullptr;
  /// Jet normals (M x 3; NaN where the fit failed: PCA's stands in).
  const Normals* jet = nullptr;
  /// PCA normals at mix_half_k(k) (M x 3; NaN where PCA failed: PCA's stands in).
  const Normals* half = nullptr;
  /// Radial normals, offsets and elongations at PCA's k and at mix_half_k(k) (M rows; NaN
  /// where none: PCA's normal stands in).
  const RadialResult* radial = nullptr;
  const RadialResult* radial_half = nullptr;
  /// MFPS's blend weights (M; 0 where no rival).
  const Eigen::VectorXd* blend_weight = nullptr;
  /// Surface variations (M), at PCA's k and at mix_half_k(k).
  const Eigen::VectorXd* variation = nullptr;
  const Eigen::VectorXd* half_variation = nullptr;
  /// Neighbour table (M x K, K >= kMixNeighbours).
  const IndexMatrix* knn = nullptr;
  /// The cloud's noise ratio (EstimateResult::noise_ratio).
  double noise_ratio = 0;
  /// Whether `net` is the network's output at every point (network_everywhere(), estimate.hpp) or
  /// only where MFPS moved the PCA normal (elsewhere it is the MFPS normal): each has its fitted
  /// mix.
  bool network_everywhere = true;
};

/// The mixed normals (M x 3, unit). A point whose PCA normal or network normal is missing keeps
/// its network normal (or its MFPS normal when both are). Cancellable through `run`.
Normals mix_candidates(const CandidateMixInput& in, const RunContext& run = {});

}  // namespace nhnet
