// Normal-guided point denoising, paper Sec. 7, Eq. 9:
//   p_i' = p_i + gamma_i sum_{p_j in N_i} (p_j - p_i) (w(n_i, n_j) n_i^T n_j + lambda n_j^T n_j)
//   w(n_i, n_j) = exp(-||n_i - n_j||^2 / sigma^2),  lambda = 0.5,  gamma_i = 1 / (3 |N_i|),
// with N_i the ball neighbourhood of p_i, computed once on the input and kept fixed over all
// iterations (so points do not pile up around edges), 20 iterations.
//
// Reading of the equation. Points and normals are row vectors there (p_j - p_i comes first), so
// n_i^T n_j and n_j^T n_j are 3 x 3 outer products and, in column-vector notation, the sum is
//   sum_j  w_ij ((p_j - p_i) . n_i) n_j  +  lambda ((p_j - p_i) . n_j) n_j .
// On a flat patch (n_j = n_i) each step moves p_i half way (gamma (1 + lambda) |N_i| = 1/2) to the
// mean plane of its neighbours along the normal; tangential positions are untouched, so the
// sampling does not shrink or cluster. Near an edge the lambda term pulls p_i towards the planes of
// the neighbours on the other face, i.e. onto the edge line, and w switches the first term off.
//
// Unoriented normals. Normals from an estimator have arbitrary signs; taken literally, w and the
// first term change with the sign of n_j (a flipped neighbour would get w ~ 0 and push p_i the
// wrong way). The update is made invariant to the sign of every normal: n_j is first flipped to
// agree with n_i (n~_j = sign(n_i . n_j) n_j), and w and the first term use n~_j. The lambda term
// is already sign-invariant. With consistently oriented normals this is exactly Eq. 9.
#pragma once

#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace nhnet {

struct DenoiseOptions {
  /// Update steps, at most (paper: 20; see stop_drop).
  int iterations = 20;
  /// Ball radius of N_i in input units; 0 = radius_factor x average spacing of the cloud.
  double radius = 0;
  /// Default radius as a multiple of the average spacing (mean distance of a point to its
  /// 6 nearest neighbours, as CGAL's compute_average_spacing, measured on the noisy input). The
  /// paper gives no value; 2 (~20 neighbours on a surface) had the lowest mean distance to the
  /// clean surface among 1.5 / 2 / 3 / 4 on training models at 0.1-1.2 % noise with PCA, MFPS and
  /// exact normals alike (tools/README.md, denoise_accuracy). Larger balls flatten curved parts.
  double radius_factor = 2.0;
  /// Bandwidth of w over normal differences (dimensionless: ||n_i - n_j||^2 lies in [0, 4], so
  /// it does not scale with the cloud). The paper gives no value; 0.35 (bilateral normal
  /// filters' usual range sigma) gives w = 0.37 at 20 degrees and ~1e-7 at 90 degrees.
  double sigma = 0.35;
  /// lambda of Eq. 9 (paper: 0.5).
  double lambda = 0.5;
  /// Step size factor: gamma_i = step / |N_i| (paper: 1/3).
  double step = 1.0 / 3.0;
  /// Thin parts: neighbours whose normal is within 30 degrees of parallel to n_i but that lie
  /// further than sheet_gap x the typical such offset from p_i's tangent plane are left out of
  /// N_i (they are on another sheet: the other side of a blade or a wall, which Eq. 9 would pull
  /// p_i onto). The typical offset is the median over the points of their median
  /// |(p_j - p_i) . n_i| over the parallel neighbours (~ the noise). 0 = keep the whole ball.
  /// Not in the paper (its balls are small against its models' walls); see denoise.cpp.
  double sheet_gap = 4.0;
  /// Stop early once an iteration lowers the roughness (DenoiseResult::roughness) by less than
  /// this fraction: the noise is gone and further steps only drift (with fixed normals, Eq. 9
  /// moves curved parts inwards by ~(w - lambda) |p_j - p_i|^2 / 2R every step, and estimated
  /// normals' errors add a bias of |p_j - p_i| x the angle error). Not in the paper, which runs
  /// 20 steps. 0 = always `iterations`. 0.2 measured on the benchmark subset
  /// (docs/design/decisions.md#stop-early-when-the-roughness-stops-falling): mean after/before
  /// over 12 clouds with mfps normals 0.88 (0) / 0.51 (0.1) / 0.48 (0.2) / 0.48 (0.3), and no
  /// cloud got worse from 0.2 on (ChineseDragon at 0.05 %
  /// noise did with 20 steps: ratio 2.4).
  double stop_drop = 0.2;
  /// Safety cap on |N_i|: the nearest max_neighbors points of the ball are kept (0 = no cap).
  int max_neighbors = 512;
  /// Threads (0 = all cores) and progress/cancel callback.
  RunContext run;
};

struct DenoiseResult {
  /// N x 3 denoised points, in the input's order. Points that were not moved keep their input
  /// coordinates (non-finite points, points with an invalid normal, points with no neighbour).
  Points points;
  /// Points that were updated (finite, valid normal, at least one neighbour).
  int64_t moved = 0;
  /// Points left in place because their coordinates are non-finite or their normal is NaN/zero.
  int64_t skipped = 0;
  /// Points left in place because their ball holds no other usable point.
  int64_t isolated = 0;
  /// Radius and sigma that were used, and the average spacing the default radius came from.
  double radius = 0;
  double sigma = 0;
  double spacing = 0;
  /// Offset beyond which a parallel neighbour counts as another sheet (0 = not used), and how
  /// many ball neighbours were left out for that.
  double sheet_gap = 0;
  int64_t other_sheet = 0;
  /// Iterations run, and the roughness before each and after the last (iterations + 1 values):
  /// median over the points of the mean |(p_j - p_i) . n_i| over the near-parallel neighbours.
  int iterations = 0;
  std::vector<double> roughness;
  /// Mean |N_i| over the moved points.
  double mean_neighbors = 0;
  /// Non-fatal notes for the user (capped neighbourhoods, ...).
  std::vector<std::string> warnings;
};

/// Denoises `points` (N x 3) guided by `normals` (N x 3, unit or any length, sign arbitrary).
/// Non-finite points and points whose normal is NaN or zero neither move nor act as neighbours.
/// Throws InvalidOptions for bad options or mismatched sizes, UnprocessableInput when fewer than
/// 2 usable points remain, Cancelled when the progress callback returns false.
DenoiseResult denoise_points(const Points& points, const Normals& normals,
                             const DenoiseOptions& options = {});

}  // namespace nhnet
