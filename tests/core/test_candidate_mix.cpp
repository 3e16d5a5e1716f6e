// The candidate mix (learned/candidate_mix.hpp): a convex combination of sign-aligned candidates,
// so identical candidates give that normal, the result never leaves the candidates' cone, a
// missing candidate keeps the network's normal; and in the pipeline, on a noisy analytic sphere
// (a smooth organic surface at high noise, where the paper's network trails the large-k PCA), it
// lowers NH-Net's RMS error.
#include "fixtures.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/learned/candidate_mix.hpp"
#include "nhnet/pipeline/estimate.hpp"

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include <cmath>
#include <limits>
#include <random>

using namespace nhnet;

namespace {

struct MixData {
  Normals net, mfps, pca;
  Eigen::VectorXd weight, variation;
  IndexMatrix knn;
  CandidateMixInput input() const {
    CandidateMixInput in;
    in.net = &net;
    in.mfps = &mfps;
    in.pca = &pca;
    in.blend_weight = &weight;
    in.variation = &variation;
    in.knn = &knn;
    in.noise_ratio = 0.3;
    return in;
  }
};

/// n points of a sphere; every candidate is the true normal tilted by up to `spread` radians
/// (random, independently per candidate), signs random.
MixData make_data(int n, double spread, unsigned seed) {
  const fixtures::Fixture f = fixtures::sphere(n, seed);
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  auto tilt = [&](Eigen::Index i) {
    const Eigen::Vector3d nrm = f.normals.row(i).transpose();
    Eigen::Vector3d axis = nrm.cross(Eigen::Vector3d(g(rng), g(rng), g(rng))).normalized();
    const double a = spread * u(rng);
    const Eigen::Vector3d t = std::cos(a) * nrm + std::sin(a) * axis.cross(nrm);
    return Eigen::RowVector3d((u(rng) < 0.5 ? -t : t).transpose());
  };
  MixData d;
  d.net.resize(n, 3);
  d.mfps.resize(n, 3);
  d.pca.resize(n, 3);
  for (Eigen::Index i = 0; i < n; ++i) {
    d.net.row(i) = tilt(i);
    d.mfps.row(i) = tilt(i);
    d.pca.row(i) = tilt(i);
  }
  d.weight = Eigen::VectorXd::Constant(n, 0.4);
  d.variation = Eigen::VectorXd::Constant(n, 0.01);
  d.knn = fixtures::knn_table(f.points, kMixNeighbours);
  return d;
}

double line_angle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), std::abs(a.dot(b)));
}

}  // namespace

TEST(CandidateMix, IdenticalCandidatesGiveThatNormal) {
  MixData d = make_data(500, 0.3, 1);
  d.mfps = d.net;
  d.pca = -d.net;  // a candidate's sign does not matter
  const Normals out = mix_candidates(d.input());
  // 1e-9 rad: the weighted sum of four equal unit vectors, normalised (rounding only).
  for (Eigen::Index i = 0; i < out.rows(); ++i)
    EXPECT_LT(line_angle(out.row(i).transpose(), d.net.row(i).transpose()), 1e-9) << i;
}

TEST(CandidateMix, StaysInsideTheCandidatesCone) {
  const MixData d = make_data(2000, 0.5, 2);
  const Normals out = mix_candidates(d.input());
  for (Eigen::Index i = 0; i < out.rows(); ++i) {
    const Eigen::Vector3d net = d.net.row(i).transpose(), o = out.row(i).transpose();
    EXPECT_NEAR(o.norm(), 1.0, 1e-12);
    // A convex combination of sign-aligned unit vectors, normalised, is no farther from any
    // one of them than the farthest candidate (1e-9 rad: rounding). The blended candidates lie
    // on the arcs between net, MFPS and PCA, so these three bound the cone.
    const double widest = std::max(line_angle(net, d.mfps.row(i).transpose()),
                                   line_angle(net, d.pca.row(i).transpose()));
    EXPECT_LE(line_angle(o, net), widest + 1e-9) << i;
  }
}

TEST(CandidateMix, MissingPcaNormalKeepsTheNetworkNormal) {
  MixData d = make_data(300, 0.3, 3);
  for (Eigen::Index i = 0; i < 300; i += 3)
    d.pca.row(i).setConstant(std::numeric_limits<double>::quiet_NaN());
  const Normals out = mix_candidates(d.input());
  for (Eigen::Index i = 0; i < 300; i += 3) EXPECT_EQ(out.row(i), d.net.row(i)) << i;
}

TEST(CandidateMix, RefusesInputsOfDifferentSizes) {
  MixData d = make_data(100, 0.1, 4);
  d.weight.resize(99);
  EXPECT_THROW(mix_candidates(d.input()), InvalidOptions);
  d = make_data(100, 0.1, 4);
  d.knn = d.knn.leftCols(kMixNeighbours - 1).eval();
  EXPECT_THROW(mix_candidates(d.input()), InvalidOptions);
}

TEST(CandidateMix, LowersNhNetRmsOnANoisySphere) {
  if (!nhnet_available()) GTEST_FAIL() << "this build has no libtorch: the default method needs it";
  const fixtures::Fixture f = fixtures::sphere(4000, 5);
  Points noisy = f.points;
  std::mt19937 rng(5);
  std::normal_distribution<double> g(0.0, 0.021);  // 0.6 % of the bbox diagonal (2 sqrt 3)
  for (Eigen::Index i = 0; i < noisy.rows(); ++i)
    noisy.row(i) += Eigen::RowVector3d(g(rng), g(rng), g(rng));
  auto rms = [&](bool mix) {
    EstimateOptions o;
    o.method = Method::NhNet;
    o.model.device = "cpu";
    o.model.candidate_mix = mix;
    const EstimateResult r = estimate_normals(noisy, o);
    double sum = 0;
    for (Eigen::Index i = 0; i < r.normals.rows(); ++i) {
      const double a = line_angle(r.normals.row(i).transpose(), f.normals.row(i).transpose());
      sum += a * a;
    }
    return std::sqrt(sum / double(r.normals.rows())) * 180 / M_PI;
  };
  const double without = rms(false), with = rms(true);
  RecordProperty("rms_without_mix", std::to_string(without));
  RecordProperty("rms_with_mix", std::to_string(with));
  // Deterministic runs (fixed seed, results independent of the thread count; the model's float32
  // outputs move by < 1e-4 deg between machines), so 2 % is far outside run-to-run change; the
  // fit gains 5 % here (2.78 -> 2.64 deg) and 7 % over the test split's clouds at 0.6 % noise.
  EXPECT_LT(with, 0.98 * without) << "without " << without << " deg, with " << with << " deg";
}
