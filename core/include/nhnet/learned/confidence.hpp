// Per-point confidence of a normal (not in the paper; issue 57, docs/design/decisions.md
// #confidence-of-each-normal): P(the normal is within 30 degrees of the true one), from how well
// the final normal agrees with its own neighbourhood. Eight rotation-invariant features of each
// point (its surface variation, the spread of its neighbours' normals, how far its neighbours lie
// off the plane of its normal, the angle to the plane fitted through them, the cloud's noise
// level) go through a small fixed network (one tanh layer of kConfidenceHidden, a logistic
// output), one set of weights per method, fitted by tools/fit_confidence.py on the training
// split only.
#pragma once

#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

namespace nhnet {

/// Features per point, in this order: 3 x the surface variation of its PCA neighbourhood
/// (EstimateResult::curvature); over its kConfidenceNeighbours - 1 nearest other points with a
/// normal: the mean, maximum and median of 1 - |n . n_j|; the mean distance of those points to
/// the plane of n over their mean distance; 1 - |n . m| with m the normal of the plane fitted
/// through them and 3 x that plane's surface variation; the log of the cloud's noise ratio.
constexpr int kConfidenceFeatures = 8;
/// Neighbours of a point (itself included) its features look at.
constexpr int kConfidenceNeighbours = 16;
/// Width of the network's hidden layer.
constexpr int kConfidenceHidden = 16;
/// Below this confidence a normal is more likely than not over 30 degrees off: the front ends
/// count such points in their reports (nhnet-cli's summary "N below confidence 0.5").
constexpr double kLowConfidence = 0.5;

/// How many of `confidence` are below kLowConfidence (NaN, a failed point, is not counted).
int64_t count_low_confidence(const Eigen::VectorXd& confidence);

/// Whose fitted weights: the method that made the normals.
enum class ConfidenceModel { Pca, Mfps, NhNet };

/// N x kConfidenceFeatures features of every point with a finite normal (NaN rows for the
/// others). `curvature` (N) and `noise_ratio` as EstimateResult gives them; points with a normal
/// must be finite. `neighbours` (optional; EstimateResult::neighbours): N x at least
/// kConfidenceNeighbours rows of each point's nearest points, itself first, used instead of a
/// search when every normal is finite. Cancellable through run.progress.
Eigen::MatrixXd confidence_features(const Points& points, const Normals& normals,
                                    const Eigen::VectorXd& curvature, double noise_ratio,
                                    const RunContext& run = {},
                                    const IndexMatrix* neighbours = nullptr);

/// Confidence in [0, 1] per row of `features` (confidence_features); NaN for NaN rows.
Eigen::VectorXd confidence_from_features(const Eigen::MatrixXd& features, ConfidenceModel model);

/// confidence_from_features(confidence_features(...), model), the same numbers, in one pass
/// without the N x kConfidenceFeatures matrix: what the estimate computes.
Eigen::VectorXd normal_confidence(const Points& points, const Normals& normals,
                                  const Eigen::VectorXd& curvature, double noise_ratio,
                                  ConfidenceModel model, const RunContext& run = {},
                                  const IndexMatrix* neighbours = nullptr);

}  // namespace nhnet
