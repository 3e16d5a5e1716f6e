// The candidate mix (learned/candidate_mix.hpp): a convex combination of sign-aligned candidates,
// so identical candidates give that normal, the result never leaves the candidates' cone, a
// missing candidate keeps the network's normal; in the pipeline it lowers NH-Net's RMS on a noisy
// cube, keeps the network's gain on a noisy sphere, and the moved mode runs fewer blocks.
#include "fixtures.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/learned/candidate_mix.hpp"
#include "nhnet/pipeline/estimate.hpp"

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <limits>
#include <random>

using namespace nhnet;

namespace {

struct MixData {
  Normals net, mfps, pca, jet, half;
  Eigen::VectorXd weight, variation, half_variation;
  RadialResult radial, radial_half;
  IndexMatrix knn;
  CandidateMixInput input() const {
    CandidateMixInput in;
    in.net = &net;
    in.mfps = &mfps;
    in.pca = &pca;
    in.jet = &jet;
    in.half = &half;
    in.blend_weight = &weight;
    in.variation = &variation;
    in.half_variation = &half_variation;
    in.radial = &radial;
    in.radial_half = &radial_half;
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
  for (RadialResult* r : {&d.radial, &d.radial_half}) {
    r->normals.resize(n, 3);
    r->offset = Eigen::VectorXd::Constant(n, 0.5);
    r->elongation = Eigen::VectorXd::Constant(n, 0.8);
  }
  const auto every = [&d] {
    return std::array<Normals*, 7>{
        &d.net, &d.mfps, &d.pca, &d.jet, &d.half, &d.radial.normals, &d.radial_half.normals};
  };
  for (Normals* c : every()) c->resize(n, 3);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Normals* c : every()) c->row(i) = tilt(i);
  d.weight = Eigen::VectorXd::Constant(n, 0.4);
  d.variation = Eigen::VectorXd::Constant(n, 0.01);
  d.half_variation = Eigen::VectorXd::Constant(n, 0.02);
  d.knn = fixtures::knn_table(f.points, kMixNeighbours);
  return d;
}

using fixtures::line_angle;
using fixtures::with_noise;

}  // namespace

TEST(CandidateMix, IdenticalCandidatesGiveThatNormal) {
  MixData d = make_data(500, 0.3, 1);
  d.mfps = d.net;
  d.jet = d.net;
  d.half = -d.net;
  d.radial.normals = d.net;
  d.radial_half.normals = -d.net;
  d.pca = -d.net;  // a candidate's sign does not matter
  const Normals out = mix_candidates(d.input());
  // 1e-9 rad: the weighted sum of eight equal unit vectors, normalised (rounding only).
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
    // on the arcs between net, MFPS and PCA, so these with the jet, half-scale PCA and radial
    // normals bound it.
    double widest = 0;
    for (const Normals* c :
         {&d.mfps, &d.pca, &d.jet, &d.half, &d.radial.normals, &d.radial_half.normals})
      widest = std::max(widest, line_angle(net, c->row(i).transpose()));
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
  d = make_data(100, 0.1, 4);
  d.radial_half.normals.resize(99, 3);
  EXPECT_THROW(mix_candidates(d.input()), InvalidOptions);
}

/// RMS angle error (degrees) of `method` on `pts` against `truth`; NH-Net with or without the mix.
double rms_of(const Points& pts, const Normals& truth, Method method, bool mix) {
  EstimateOptions o;
  o.method = method;
  o.model.device = "cpu";
  o.model.candidate_mix = mix;
  o.model.learned_fit = false;  // the mix alone (test_learned_fit.cpp: the fit after it)
  const EstimateResult r = estimate_normals(pts, o);
  double sum = 0;
  for (Eigen::Index i = 0; i < r.normals.rows(); ++i) {
    const double a = line_angle(r.normals.row(i).transpose(), truth.row(i).transpose());
    sum += a * a;
  }
  return std::sqrt(sum / double(r.normals.rows())) * 180 / M_PI;
}

/// NH-Net's RMS without and with the mix, and PCA's, on one cloud; recorded in the test's XML.
struct ThreeRms {
  double without, with, pca;
};
ThreeRms three_rms(const Points& pts, const Normals& truth) {
  const ThreeRms r{rms_of(pts, truth, Method::NhNet, false),
                   rms_of(pts, truth, Method::NhNet, true), rms_of(pts, truth, Method::Pca, false)};
  ::testing::Test::RecordProperty("rms_without_mix", std::to_string(r.without));
  ::testing::Test::RecordProperty("rms_with_mix", std::to_string(r.with));
  ::testing::Test::RecordProperty("rms_pca", std::to_string(r.pca));
  return r;
}

TEST(CandidateMix, LowersNhNetRmsOnANoisyCube) {
  if (!nhnet_available()) GTEST_FAIL() << "this build has no libtorch: the default method needs it";
  const fixtures::Fixture f = fixtures::cube(6000, 0.02, 5);  // 0.6 % of the diagonal (2 sqrt 3)
  const auto [without, with, pca] = three_rms(f.points, f.normals);
  // Deterministic runs (fixed seed, results independent of the thread count; the model's float32
  // outputs move by < 1e-4 deg between machines), so 2 % is far outside run-to-run change. Sharp
  // edges at high noise: the mix gains 5 % on the network here (12.72 -> 12.13 deg), 23 % on PCA.
  EXPECT_LT(with, 0.98 * without) << "without " << without << " deg, with " << with << " deg";
  EXPECT_LT(with, 0.98 * pca) << "pca " << pca << " deg, with " << with << " deg";
}

TEST(CandidateMix, KeepsTheNetworksGainOnANoisySphere) {
  if (!nhnet_available()) GTEST_FAIL() << "this build has no libtorch: the default method needs it";
  // 20 000 points: the density of the clouds the mix was fitted on (the test split's).
  const fixtures::Fixture f = fixtures::sphere(20000, 5);
  // 0.6 % of the bbox diagonal (2 sqrt 3)
  const auto [without, with, pca] = three_rms(with_noise(f.points, 0.021, 5), f.normals);
  // A broad smooth surface is where the network's denoising beats every fit (1.91 vs PCA's 3.02
  // deg), so the mix must trust it: it gives up 4 % of it here (1.99 deg when fitted); 6 % and
  // 0.8 x PCA fail a mix that drifts towards the fits (deterministic runs, see above).
  EXPECT_LT(with, 1.06 * without) << "without " << without << " deg, with " << with << " deg";
  EXPECT_LT(with, 0.8 * pca) << "pca " << pca << " deg, with " << with << " deg";
}

namespace {

/// The default method's normals of `points` with `refine`, and how many "nhnet" progress calls
/// it made: every block of 64 points the network runs ends with one (refine.cpp).
std::pair<EstimateResult, int> refined(const Points& points, Refine refine, int stride = 0) {
  EstimateOptions o;
  o.method = Method::NhNet;
  o.model.device = "cpu";
  o.model.batch = 64;
  o.model.refine = refine;
  o.model.network_stride = stride;
  int calls = 0;
  o.run.progress = [&](double, const std::string& stage) {
    calls += stage == "nhnet";
    return true;
  };
  EstimateResult r = estimate_normals(points, o);
  EXPECT_EQ(r.failed, 0);
  return {std::move(r), calls};
}

}  // namespace

TEST(CandidateMix, MovedModeRunsTheNetworkOnFewerPoints) {
  if (!nhnet_available()) GTEST_FAIL() << "this build has no libtorch: the default method needs it";
  const Points noisy = with_noise(fixtures::sphere(4000, 6).points, 0.021, 6);
  const int all = refined(noisy, Refine::All).second, moved = refined(noisy, Refine::Moved).second;
  // 4000 points in blocks of 64: at least 63 calls; on a smooth sphere MFPS moves few normals
  // (about 7 % at this noise), so the moved mode runs well under half the blocks.
  EXPECT_GE(all, 63);
  EXPECT_LT(moved, all / 2) << "all " << all << ", moved " << moved;
}

TEST(CandidateMix, AutoRunsTheNetworkEverywhereOnlyOnANoisyCloud) {
  if (!nhnet_available()) GTEST_FAIL() << "this build has no libtorch: the default method needs it";
  EXPECT_EQ(EstimateOptions{}.model.refine, Refine::Auto);
  // 0.6 % noise: the noise ratio is far above auto_noise_ratio, so auto is all, bit for bit.
  const Points noisy = with_noise(fixtures::sphere(4000, 6).points, 0.021, 6);
  const auto [noisy_auto, noisy_calls] = refined(noisy, Refine::Auto);
  const auto [noisy_all, all_calls] = refined(noisy, Refine::All);
  EXPECT_GE(noisy_auto.noise_ratio, EstimateOptions{}.model.auto_noise_ratio);
  EXPECT_TRUE(noisy_auto.normals == noisy_all.normals);
  EXPECT_EQ(noisy_calls, all_calls);
  // Exact samples of a cube (flat faces, noise ratio 0): auto is moved, bit for bit, and runs
  // the network on fewer blocks than all.
  const Points clean = fixtures::cube(4000, 0.0, 7).points;
  const auto [clean_auto, clean_calls] = refined(clean, Refine::Auto);
  const auto [clean_moved, moved_calls] = refined(clean, Refine::Moved);
  EXPECT_LT(clean_auto.noise_ratio, EstimateOptions{}.model.auto_noise_ratio);
  EXPECT_TRUE(clean_auto.normals == clean_moved.normals);
  EXPECT_EQ(clean_calls, moved_calls);
  EXPECT_LT(clean_calls, refined(clean, Refine::All).second);
}

// A noisy sphere dense enough for neighbourhoods of many points (k_used >= 32): the automatic
// network stride describes a fraction of the points and hands the rest their nearest described
// neighbour's network normal. A smooth surface's network normals agree over a few spacings, so
// the RMS stays within 2 % of the network on every point (deterministic runs: 2 % is far outside
// run-to-run change), for under 60 % of its blocks; stride 1 is every point.
TEST(CandidateMix, NetworkStrideDescribesFewerPointsOfADenseNoisyCloud) {
  if (!nhnet_available()) GTEST_FAIL() << "this build has no libtorch: the default method needs it";
  const fixtures::Fixture f = fixtures::sphere(20000, 8);
  const Points noisy = with_noise(f.points, 0.021, 8);
  const auto [every, every_calls] = refined(noisy, Refine::All, 1);
  const auto [strided, strided_calls] = refined(noisy, Refine::All, 0);
  ASSERT_GE(every.k_used, 32) << "the fixture must be dense for the stride to apply";
  EXPECT_LT(strided_calls, 0.6 * every_calls) << strided_calls << " of " << every_calls;
  auto rms = [&](const Normals& n) {
    double sum = 0;
    for (Eigen::Index i = 0; i < n.rows(); ++i) {
      const double a = line_angle(n.row(i).transpose(), f.normals.row(i).transpose());
      sum += a * a;
    }
    return std::sqrt(sum / double(n.rows())) * 180 / M_PI;
  };
  const double r_every = rms(every.normals), r_strided = rms(strided.normals);
  ::testing::Test::RecordProperty("rms_every_point", std::to_string(r_every));
  ::testing::Test::RecordProperty("rms_strided", std::to_string(r_strided));
  EXPECT_LT(r_strided, 1.02 * r_every) << "every point " << r_every << ", strided " << r_strided;
  EstimateOptions bad;
  bad.method = Method::NhNet;
  bad.model.network_stride = -1;
  EXPECT_THROW(estimate_normals(noisy, bad), InvalidOptions);
}

TEST(CandidateMix, OneNeighbourSearchGivesTheNormalsOfTwo) {
  // The descriptors take the geometry stage's neighbour table (refine.cpp, SharedTable); a cloud
  // with a non-finite row cannot share it (the table's rows would not be the input's) and
  // searches anew over the same finite points. Both ways must give the same normals, in the
  // moved mode (described points first, table rows renumbered) and in the all mode (the table
  // moved as it is). 1e-3 degrees: the two searches run on differently scaled coordinates, so a
  // near-tie may order two neighbours differently, which changes float sums in the last bits;
  // another neighbour or a wrong renumbering moves normals by degrees.
  if (!nhnet_available()) GTEST_FAIL() << "this build has no libtorch: the default method needs it";
  const Points clean = fixtures::cube(3000, 0.0, 7).points;
  const Points noisy = with_noise(fixtures::sphere(3000, 6).points, 0.021, 6);
  for (const auto& [points, refine] : {std::pair{clean, Refine::Moved}, {noisy, Refine::All}}) {
    Points with_nan(points.rows() + 1, 3);
    with_nan << points, Eigen::RowVector3d::Constant(std::numeric_limits<double>::quiet_NaN());
    EstimateOptions o;
    o.method = Method::NhNet;
    o.model.device = "cpu";
    o.model.refine = refine;
    const EstimateResult shared = estimate_normals(points, o);
    const EstimateResult searched = estimate_normals(with_nan, o);
    EXPECT_EQ(shared.failed, 0);
    EXPECT_EQ(searched.failed, 1);  // the NaN row
    double worst = 0;
    for (Eigen::Index i = 0; i < points.rows(); ++i) {
      const double c = std::abs(shared.normals.row(i).dot(searched.normals.row(i)));
      worst = std::max(worst, std::acos(std::min(1.0, c)) * 180 / M_PI);
    }
    EXPECT_LT(worst, 1e-3) << (refine == Refine::Moved ? "moved" : "all");
  }
}
