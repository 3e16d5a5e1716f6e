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
// a maximiser that is not limited to 4-point planes: see
// docs/design/decisions.md#mfps-plane-search. Selection is the paper's argmax by default; an
// optional two-face posterior (posterior_beta) trades a little mean error for a lower RMS where two
// faces are about equally likely, and an optional PCA blend (pca_blend) moves a candidate towards
// its PCA normal where the selection is likely wrong (not the paper's; see
// docs/design/decisions.md#mfps-pca-blend).
#pragma once

#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

#include <cstdint>
#include <vector>

namespace nhnet {

/// Features of the PCA blend (MfpsOptions::pca_blend), per candidate with a rival:
/// 0 intercept (1), 1 4P(1-P) of the final posterior, 2 winner-rival angle, 3 PCA-final angle,
/// 4 distance to the winner-rival edge line / (5 bandwidths), capped at 1, 5 4P(1-P) of the
/// score posterior, 6 |2 P_edge - 1|, 7 how far the PCA normal is off the winner-rival arc,
/// 8 / 9 1 - mean |n_i . n_j| over the kBlendNeighbours nearest (MFPS / PCA normals),
/// 10 log of the winner's score D of Eq. 4, 11 PCA-winner angle (angles in radians).
constexpr int kMfpsBlendFeatures = 12;
constexpr int kBlendNeighbours = 16;

/// The defaults below are nhnet's (measured on the training split, tools/README.md); paper()
/// gives the authors' values. EstimateOptions::mfps holds these for the whole pipeline, so every
/// front end gets its MFPS defaults from here.
struct MfpsOptions {
  /// Patch sizes K (self included), ascending. Empty = chosen from the cloud's noise level by the
  /// pipeline (scales.hpp); mfps_normals() itself needs them given. Paper: {50, 100, 150}.
  std::vector<int> scales;
  /// alpha of eta(K) (paper: 0.9).
  double alpha = 0.9;
  /// Random 4-point planes per patch (authors: 150).
  int samples = 40;
  /// Patch members each sample is scored on before the full re-scoring (0 = all members, i.e.
  /// the authors' exhaustive scoring).
  int score_subset = 48;
  /// Best samples re-scored on the whole patch (authors: 1).
  int rescore = 3;
  /// IRLS refinement steps of the winning plane (0 = authors' behaviour).
  int refine_iterations = 3;
  /// A patch of more members fits its plane (Eq. 1-2) to this many of them, the centre and
  /// members at evenly spaced distance ranks (0 = all members, the authors' behaviour): E is a
  /// mean, so the subset estimates it without bias, and the cost per patch stops growing with
  /// the noise-driven K.
  int fit_members = 128;
  /// Width of the point term exp(-r_i^2 / (f sigma_i)^2) of Eq. 4, as a multiple f of sigma_i
  /// (paper: 1). A wider term stops a point that noise pushed off its own face from preferring
  /// a plane bent across the edge.
  double point_sigma_factor = 4;
  /// Two-face posterior (0 = the paper's argmax). With beta > 0, the winner's score D1 and the
  /// best score D2 among patches whose plane differs from the winner's by more than
  /// `rival_angle_deg` give P(rival) = 1 / (1 + (D1/D2)^beta); the normal is the winner's rotated
  /// towards the rival's by P(rival) times the angle between them, which minimises the expected
  /// squared angle error where the two faces are about equally likely (there the argmax is a
  /// coin flip between 0 and the dihedral angle, the worst case for RMS).
  double posterior_beta = 12;
  /// Planes closer than this to the winner's (degrees) are the same face, not a rival.
  double rival_angle_deg = 20;
  /// Edge-geometry posterior (0 = off): the winner's and the rival's planes meet in an edge line;
  /// each face is the half-plane on its patch's side of it. A point's likelihood under a face is
  /// exp(-r^2 / 2 s^2) Phi(t / s) (r: distance to the plane, t: signed distance along the face
  /// from the edge, s = this factor x sigma_i), i.e. the Gaussian noise model integrated over the
  /// half-plane; it multiplies the score prior (D2/D1)^beta.
  double edge_sigma_factor = 1;
  /// PCA blend (not the paper's; false = off): each candidate with a rival is rotated towards
  /// its PCA normal (`base_normals`) by a weight w, logistic in a quadratic form of the features
  /// above (each feature and every pairwise product; the 78 coefficients in mfps_blend.cpp were
  /// fitted on the training split with tools/fit_mfps_blend.py). Within about one noise sigma
  /// of an edge the face a point came from cannot be told, the large-k PCA plane (close to the
  /// bisector) is then the lower-RMS answer; w learns where.
  bool pca_blend = true;
  /// Keep the blend features and the normals before the blend in the result (for fitting).
  bool record_blend_features = false;
  /// Keep only each candidate's blend weight and row (blend_weights, blend_rows), without the
  /// features and the N x 3 copy of the normals that record_blend_features also keeps.
  bool keep_blend_weights = false;
  /// Seed of the random samples; results do not depend on the thread count.
  uint64_t seed = 1;

  /// The authors' settings: scales {50, 100, 150}, 150 samples scored exhaustively, no
  /// refinement, the argmax of Eq. 4 with sigma_i's own width, no posterior, no blend.
  static MfpsOptions paper() {
    MfpsOptions o;
    o.scales = {50, 100, 150};
    o.samples = 150;
    o.score_subset = 0;
    o.rescore = 1;
    o.refine_iterations = 0;
    o.fit_members = 0;
    o.point_sigma_factor = 1;
    o.posterior_beta = 0;
    o.edge_sigma_factor = 0;
    o.pca_blend = false;
    return o;
  }
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
  /// With record_blend_features: the rows (of `points`) that have blend features, their
  /// features (rows x kMfpsBlendFeatures), every point's normal before the blend (N x 3) and
  /// each row's blend weight (the fraction of the way to its PCA normal; applied only with
  /// pca_blend). With keep_blend_weights alone: the rows and weights only (the others empty).
  std::vector<int64_t> blend_rows;
  Eigen::MatrixXd blend_features;
  Normals unblended_normals;
  std::vector<double> blend_weights;
};

/// Runs MFPS on `points` (N x 3). `knn` (N x K, K >= max scale, self first) is the shared
/// neighbour table; `sigma` (N) the kernel widths sigma_j = 2 * residual bandwidth;
/// `candidate` (N flags) the points near sharp features; `base_normals` (N x 3) the normals of
/// all other points (PCA).
MfpsResult mfps_normals(const Points& points, const IndexMatrix& knn, const Eigen::VectorXd& sigma,
                        const std::vector<uint8_t>& candidate, const Normals& base_normals,
                        const MfpsOptions& options = {}, const RunContext& run = {});

}  // namespace nhnet
