// Learned weighted jet fit (not the paper's; the DeepFit/AdaFit family, issue 23 point 2,
// docs/design/decisions.md#learned-weighted-jet-fit-issue-23): the last step of --method nhnet,
// after the candidate mix. Each point's neighbourhood (kFitMembers members spread over its max(k,
// 64) nearest, util/spread.hpp) is seen in the frame of its mixed normal n; a small network weighs
// every member from rotation-invariant features (tangent distance, height, residual from the
// mean height, agreement of the member's normal with n, distance rank, the cloud's noise level)
// and from their max-pool over the neighbourhood, and a degree-2 height fit with those weights
// (the jet of geometry/jet.hpp, weighted, with a small ridge) gives a normal n'. A learned gate g
// of the pooled features keeps part of n: the result is n + g (n' - n), normalised. The mix
// chooses among fits of fixed weights; this fit reweighs the raw neighbourhood, so it can leave
// out the members across a crease or outside the noise band, which no candidate does. Weights
// fitted by tools/fit_learned_fit.py on the training split only, minimising the squared angle
// error (RMS).
#pragma once

#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

namespace nhnet {

/// Members of a point's neighbourhood that the fit weighs.
constexpr int kFitMembers = 64;

/// Neighbourhood (nearest points, self included) over which the kFitMembers members are spread,
/// for a cloud whose PCA neighbourhood is k points: max(k, kFitMembers).
constexpr int learned_fit_k(int k) { return k > kFitMembers ? k : kFitMembers; }

/// What the fit reads, all of the same M points.
struct LearnedFitInput {
  /// Points (M x 3).
  const Points* points = nullptr;
  /// Normals to refit (M x 3, unit; a NaN row is kept as it is): the candidate mix's.
  const Normals* normals = nullptr;
  /// Members of each point (M x kFitMembers row indices, self first, ordered by distance):
  /// spread over the point's learned_fit_k(k) nearest.
  const IndexMatrix* members = nullptr;
  /// The cloud's noise ratio (EstimateResult::noise_ratio).
  double noise_ratio = 0;
};

/// The refitted normals (M x 3, unit; NaN where the input normal is). A point whose fit is
/// degenerate (all weights zero, a singular system) keeps its input normal. Cancellable through
/// `run`.
Normals learned_fit(const LearnedFitInput& in, const RunContext& run = {});

}  // namespace nhnet
