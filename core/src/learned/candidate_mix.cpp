// Candidate mix of --method nhnet (learned/candidate_mix.hpp; not the paper's): per point, a
// fixed two-layer tanh network of rotation-invariant features gives softmax weights over eight
// candidate normals. The weights are in candidate_mix_weights.inc, written by
// tools/fit_candidate_mix.py (docs/design/decisions.md#candidate-mix).
#include "nhnet/learned/candidate_mix.hpp"

#include "geometry/mfps_blend.hpp"
#include "nhnet/errors.hpp"
#include "util/fast_math.hpp"
#include "util/parallel.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace nhnet {

namespace {

/// One fitted mix: feature standardisation and the three layers.
struct MixWeights {
  std::array<double, kMixFeatures> mean, scale;
  std::array<std::array<double, kMixFeatures>, kMixHidden> w1;
  std::array<double, kMixHidden> b1;
  std::array<std::array<double, kMixHidden>, kMixHidden> w2;
  std::array<double, kMixHidden> b2;
  std::array<std::array<double, kMixHidden>, kMixCandidates> w3;
  std::array<double, kMixCandidates> b3;
};

namespace every_point {  // fitted with the network's normal at every point
#include "learned/candidate_mix_weights.inc"
constexpr MixWeights kWeights{kMean, kScale, kW1, kB1, kW2, kB2, kW3, kB3};
}  // namespace every_point

namespace moved_only {  // fitted with the network only where MFPS moved the PCA normal
#include "learned/candidate_mix_weights_moved.inc"
constexpr MixWeights kWeights{kMean, kScale, kW1, kB1, kW2, kB2, kW3, kB3};
}  // namespace moved_only

using Features = std::array<double, kMixFeatures>;
using Candidates = std::array<Eigen::Vector3d, kMixCandidates>;

/// Unoriented angle between unit vectors, radians.
double line_angle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), std::abs(a.dot(b)));
}

/// Softmax weights of the candidates for features `f` under the fitted mix `m`.
std::array<double, kMixCandidates> mix_weights(const Features& f, const MixWeights& m) {
  std::array<double, kMixHidden> z1{}, h1{}, z2{}, h2{};
  Features standard;  // once, not once per hidden unit
  for (size_t q = 0; q < kMixFeatures; ++q) standard[q] = (f[q] - m.mean[q]) / m.scale[q];
  for (size_t j = 0; j < kMixHidden; ++j) {
    double z = m.b1[j];
    for (size_t q = 0; q < kMixFeatures; ++q) z += m.w1[j][q] * standard[q];
    z1[j] = z;
  }
  detail::tanh_batch(z1.data(), h1.data(), kMixHidden);
  for (size_t j = 0; j < kMixHidden; ++j) {
    double z = m.b2[j];
    for (size_t q = 0; q < kMixHidden; ++q) z += m.w2[j][q] * h1[q];
    z2[j] = z;
  }
  detail::tanh_batch(z2.data(), h2.data(), kMixHidden);
  std::array<double, kMixCandidates> w{};
  double top = -std::numeric_limits<double>::infinity(), sum = 0;
  for (size_t c = 0; c < kMixCandidates; ++c) {
    double z = m.b3[c];
    for (size_t q = 0; q < kMixHidden; ++q) z += m.w3[c][q] * h2[q];
    w[c] = z;
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

/// Row i of a radial result: its normal (PCA's where missing), offset and elongation (0 where
/// missing).
struct RadialRow {
  Eigen::Vector3d normal;
  double offset, elongation;
};
RadialRow radial_row(const RadialResult& r, Eigen::Index i, const Eigen::Vector3d& pca) {
  const bool ok = r.normals.row(i).allFinite();
  const auto finite_or_zero = [](double v) { return std::isfinite(v) ? v : 0.0; };
  return {ok ? Eigen::Vector3d(r.normals.row(i).transpose()) : pca, finite_or_zero(r.offset[i]),
          finite_or_zero(r.elongation[i])};
}

/// The mixed normal of row i, or its network normal when a candidate is missing.
Eigen::Vector3d mix_row(const CandidateMixInput& in, const Normals& bl, Eigen::Index i) {
  const Eigen::Vector3d net = in.net->row(i).transpose(), pca = in.pca->row(i).transpose();
  const Eigen::Vector3d un = in.mfps->row(i).transpose(), b = bl.row(i).transpose();
  if (!net.allFinite() || !pca.allFinite() || !un.allFinite() || !b.allFinite()) return net;
  const Eigen::Vector3d jet = in.jet->row(i).allFinite() ? in.jet->row(i).transpose() : pca;
  const bool has_half = in.half->row(i).allFinite();
  const Eigen::Vector3d half = has_half ? in.half->row(i).transpose() : pca;
  const double half_variation = has_half ? (*in.half_variation)[i] : (*in.variation)[i];
  const double w = (*in.blend_weight)[i];
  const RadialRow rk = radial_row(*in.radial, i, pca), rh = radial_row(*in.radial_half, i, pca);
  const Eigen::Vector3d toward_pca = detail::slerp_towards(net, pca, w);
  const Candidates cand{net, toward_pca, pca, b, jet, half, rk.normal, rh.normal};
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
                   detail::inconsistency(*in.mfps, *in.knn, i, kMixNeighbours),
                   line_angle(jet, net),
                   line_angle(jet, pca),
                   line_angle(half, net),
                   line_angle(half, pca),
                   std::sqrt(std::clamp(half_variation, 0.0, 1.0)),
                   line_angle(rk.normal, net),
                   line_angle(rk.normal, pca),
                   line_angle(rh.normal, net),
                   line_angle(rh.normal, pca),
                   rk.offset,
                   rh.offset,
                   rk.elongation,
                   rh.elongation};
  const auto weights =
      mix_weights(f, in.network_everywhere ? every_point::kWeights : moved_only::kWeights);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int c = 0; c < kMixCandidates; ++c)
    sum += weights[size_t(c)] * (cand[size_t(c)].dot(net) < 0 ? -cand[size_t(c)] : cand[size_t(c)]);
  return sum.norm() > 1e-12 ? Eigen::Vector3d(sum.normalized()) : net;
}

}  // namespace

Normals mix_candidates(const CandidateMixInput& in, const RunContext& run) {
  if (!in.net || !in.mfps || !in.pca || !in.jet || !in.half || !in.blend_weight || !in.variation ||
      !in.half_variation || !in.radial || !in.radial_half || !in.knn)
    throw InvalidOptions("candidate mix: an input is missing");
  const Eigen::Index m = in.net->rows();
  if (in.mfps->rows() != m || in.pca->rows() != m || in.jet->rows() != m || in.half->rows() != m ||
      in.blend_weight->size() != m || in.variation->size() != m || in.half_variation->size() != m ||
      in.radial->normals.rows() != m || in.radial_half->normals.rows() != m ||
      in.knn->rows() != m || in.knn->cols() < kMixNeighbours)
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
