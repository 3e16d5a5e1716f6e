// Candidate mix of --method nhnet (learned/candidate_mix.hpp; not the paper's): per point, a
// fixed two-layer tanh network of rotation-invariant features gives softmax weights over four
// candidate normals. The weights are in candidate_mix_weights.inc, written by
// tools/fit_candidate_mix.py (docs/design/decisions.md#candidate-mix).
#include "nhnet/learned/candidate_mix.hpp"

#include "geometry/mfps_blend.hpp"
#include "nhnet/errors.hpp"
#include "util/parallel.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace nhnet {

namespace {

#include "learned/candidate_mix_weights.inc"

using Features = std::array<double, kMixFeatures>;
using Candidates = std::array<Eigen::Vector3d, kMixCandidates>;

/// Unoriented angle between unit vectors, radians.
double line_angle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), std::abs(a.dot(b)));
}

/// Softmax weights of the candidates for standardised-by-the-fit features `f`.
std::array<double, kMixCandidates> mix_weights(const Features& f) {
  std::array<double, kMixHidden> h1{}, h2{};
  for (int j = 0; j < kMixHidden; ++j) {
    double z = kB1[size_t(j)];
    for (int q = 0; q < kMixFeatures; ++q)
      z += kW1[size_t(j)][size_t(q)] * (f[size_t(q)] - kMean[size_t(q)]) / kScale[size_t(q)];
    h1[size_t(j)] = std::tanh(z);
  }
  for (int j = 0; j < kMixHidden; ++j) {
    double z = kB2[size_t(j)];
    for (int q = 0; q < kMixHidden; ++q) z += kW2[size_t(j)][size_t(q)] * h1[size_t(q)];
    h2[size_t(j)] = std::tanh(z);
  }
  std::array<double, kMixCandidates> w{};
  double top = -std::numeric_limits<double>::infinity(), sum = 0;
  for (int c = 0; c < kMixCandidates; ++c) {
    double z = kB3[size_t(c)];
    for (int q = 0; q < kMixHidden; ++q) z += kW3[size_t(c)][size_t(q)] * h2[size_t(q)];
    w[size_t(c)] = z;
    top = std::max(top, z);
  }
  for (double& v : w) sum += (v = std::exp(v - top));
  for (double& v : w) v /= sum;
  return w;
}

/// The blended MFPS normals: each row rotated towards its PCA normal by its blend weight.
Normals blended(const CandidateMixInput& in) {
  Normals out = *in.mfps;
  for (Eigen::Index i = 0; i < out.rows(); ++i)
    if ((*in.blend_weight)[i] > 0 && in.pca->row(i).allFinite() && out.row(i).allFinite())
      out.row(i) = detail::slerp_towards(out.row(i).transpose(), in.pca->row(i).transpose(),
                                         (*in.blend_weight)[i])
                       .transpose();
  return out;
}

/// The mixed normal of row i, or its network normal when a candidate is missing.
Eigen::Vector3d mix_row(const CandidateMixInput& in, const Normals& bl, Eigen::Index i) {
  const Eigen::Vector3d net = in.net->row(i).transpose(), pca = in.pca->row(i).transpose();
  const Eigen::Vector3d un = in.mfps->row(i).transpose(), b = bl.row(i).transpose();
  if (!net.allFinite() || !pca.allFinite() || !un.allFinite() || !b.allFinite()) return net;
  const double w = (*in.blend_weight)[i];
  const Candidates cand{net, detail::slerp_towards(net, pca, w), pca, b};
  const Features f{line_angle(net, pca),
                   line_angle(net, b),
                   line_angle(pca, b),
                   line_angle(net, un),
                   w,
                   un == pca ? 0.0 : 1.0,
                   std::log(std::max(in.noise_ratio, 1e-4)),
                   std::sqrt(std::clamp((*in.variation)[i], 0.0, 1.0)),
                   detail::inconsistency(*in.pca, *in.knn, i, kMixNeighbours),
                   detail::inconsistency(bl, *in.knn, i, kMixNeighbours),
                   detail::inconsistency(*in.mfps, *in.knn, i, kMixNeighbours)};
  const auto weights = mix_weights(f);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int c = 0; c < kMixCandidates; ++c)
    sum += weights[size_t(c)] * (cand[size_t(c)].dot(net) < 0 ? -cand[size_t(c)] : cand[size_t(c)]);
  return sum.norm() > 1e-12 ? Eigen::Vector3d(sum.normalized()) : net;
}

}  // namespace

Normals mix_candidates(const CandidateMixInput& in, const RunContext& run) {
  if (!in.net || !in.mfps || !in.pca || !in.blend_weight || !in.variation || !in.knn)
    throw InvalidOptions("candidate mix: an input is missing");
  const Eigen::Index m = in.net->rows();
  if (in.mfps->rows() != m || in.pca->rows() != m || in.blend_weight->size() != m ||
      in.variation->size() != m || in.knn->rows() != m || in.knn->cols() < kMixNeighbours)
    throw InvalidOptions(
        "candidate mix: inputs differ in size or the neighbour table has fewer "
        "than " +
        std::to_string(kMixNeighbours) + " columns");
  const Normals bl = blended(in);
  Normals out(m, 3);
  detail::Progress progress(run.progress);
  if (run.progress) progress.stage("candidate mix", 0, 1);
  detail::parallel_for(m, run.threads, run.progress ? &progress : nullptr,
                       [&](int64_t i) { out.row(i) = mix_row(in, bl, i).transpose(); });
  return out;
}

}  // namespace nhnet
