// Multi-scale fitting patch selection, paper Sec. 4.1-4.2:
//   Eq. 1-2  every K-NN patch Q_j gets the plane theta* maximising
//            E_Qj(theta) = 1/|Q_j| sum_k exp(-r_k^2 / sigma_j^2)
//   Eq. 3-4  every candidate point p_i takes the normal of the patch, among all patches of all
//            scales that contain it, maximising E_Qj(theta*) * exp(-r_i^2 / sigma_i^2) * eta(K),
//            eta(K) = alpha + (1 - alpha) (K - Kmin) / (Kmax - Kmin), alpha = 0.9.
// How theta* is found is left open by the paper; the authors take the best of 150 random planes
// through the centre and 3 other members. We take the best of `samples` such planes, scored on a
// random subset of the patch (preemptive scoring), re-score the best few on the whole patch, and
// refine the winner by a few iteratively reweighted least-squares steps, which climb E itself
// (each step is the weighted-PCA fixed point of the Gaussian objective). Same E, fewer samples,
// a maximiser that is not limited to 4-point planes: see the note on issue 2 for the numbers.
// Selection is the paper's argmax by default; an optional soft selection (soft_gamma) trades a
// little mean error for a lower RMS where two faces are equally likely.
#pragma once

#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

#include <cstdint>
#include <vector>

namespace nhnet {

struct MfpsOptions {
  /// Patch sizes K (self included), ascending. Paper: {50, 100, 150}.
  std::vector<int> scales{50, 100, 150};
  /// alpha of eta(K) (paper: 0.9).
  double alpha = 0.9;
  /// Random 4-point planes per patch (authors: 150).
  int samples = 150;
  /// Patch members each sample is scored on before the full re-scoring (0 = all members, i.e.
  /// the authors' exhaustive scoring).
  int score_subset = 0;
  /// Best samples re-scored on the whole patch.
  int rescore = 1;
  /// IRLS refinement steps of the winning plane (0 = authors' behaviour).
  int refine_iterations = 0;
  /// Patch selection (Eq. 3-4). 0 = the paper's argmax over S_i. gamma > 0 = soft selection:
  /// the normal is the principal direction of sum_Q (D_Q / D_max)^gamma n_Q n_Q^T over S_i, which
  /// equals the argmax when one patch dominates and splits the difference when two faces score
  /// alike (there the argmax is a coin flip between 0 and 90 degrees, the worst case for RMS).
  double soft_gamma = 0;
  /// Seed of the random samples; results do not depend on the thread count.
  uint64_t seed = 1;
};

struct MfpsResult {
  /// N x 3 normals: selected-plane normals for candidates, `base_normals` elsewhere.
  Normals normals;
  /// N: patch size K of the selected patch for candidates, 0 elsewhere.
  std::vector<int> chosen_scale;
  /// Patches whose every sample was rejected (centre residual above sigma_j); they fall back to
  /// the PCA plane of the patch.
  int64_t fallback_patches = 0;
  /// Patches whose plane was computed.
  int64_t patches = 0;
};

/// Runs MFPS on `points` (N x 3). `knn` (N x K, K >= max scale, self first) is the shared
/// neighbour table; `sigma` (N) the kernel widths sigma_j = 2 * residual bandwidth;
/// `candidate` (N flags) the points near sharp features; `base_normals` (N x 3) the normals of
/// all other points (PCA).
MfpsResult mfps_normals(const Points& points, const IndexMatrix& knn, const Eigen::VectorXd& sigma,
                        const std::vector<uint8_t>& candidate, const Normals& base_normals,
                        const MfpsOptions& options = {}, const RunContext& run = {});

}  // namespace nhnet
