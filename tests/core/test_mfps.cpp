// MFPS (paper Eq. 1-4) on a noisy sampled cube: near the edges it must clearly beat PCA at the
// same neighbourhood size, because PCA patches straddle the edge while MFPS picks a patch that
// lies on one face.
#include "fixtures.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/eval/metrics.hpp"
#include "nhnet/geometry/bandwidth.hpp"
#include "nhnet/geometry/feature_detection.hpp"
#include "nhnet/geometry/mfps.hpp"
#include "nhnet/geometry/pca.hpp"
#include "nhnet/pipeline/estimate.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

using namespace nhnet;

namespace {
// Distance of a point of the cube [-1,1]^3 surface to the nearest edge.
double edge_distance(const Eigen::Vector3d& p) {
  Eigen::Vector3d a = p.cwiseAbs();
  std::sort(a.data(), a.data() + 3);
  // On a face, the largest coordinate is ~1; the nearest edge is where the second largest is 1.
  return 1.0 - a[1];
}

double mean_error_near_edges(const Normals& est, const fixtures::Fixture& f, double within) {
  const Eigen::VectorXd e = angle_errors_deg(est, f.normals);
  double s = 0;
  int c = 0;
  for (Eigen::Index i = 0; i < f.points.rows(); ++i) {
    if (edge_distance(f.points.row(i).transpose()) < within) {
      s += e[i];
      ++c;
    }
  }
  return c ? s / c : NAN;
}
}  // namespace

TEST(Mfps, BeatsPcaNearCubeEdges) {
  // 60k points on the cube surface (area 24): spacing ~0.02; noise 0.1% of the diagonal (3.46),
  // i.e. sigma = 0.0035 ~ 0.17 spacings.
  const double noise = 0.001 * 2 * std::sqrt(3.0);
  const auto f = fixtures::cube(60000, noise, 5);
  const double spacing = std::sqrt(24.0 / 60000);

  EstimateOptions pca;
  pca.method = Method::Pca;
  pca.k = 100;
  const EstimateResult rp = estimate_normals(f.points, pca);

  EstimateOptions mfps;
  mfps.method = Method::Mfps;
  mfps.mfps.scales = {50, 100, 150};  // the paper's scales, so PCA k=100 is a like-for-like peer
  const EstimateResult rm = estimate_normals(f.points, mfps);
  EXPECT_EQ(rm.failed, 0);
  EXPECT_GT(rm.candidates, 0);

  const double within = 2 * spacing;
  const double e_pca = mean_error_near_edges(rp.normals, f, within);
  const double e_mfps = mean_error_near_edges(rm.normals, f, within);
  // PCA at k=100 averages the two faces over a ~0.2-wide patch: points within 2 spacings (0.04)
  // of an edge are tilted by ~30 degrees on average. MFPS puts them on one face; what remains is
  // the points whose noisy position is closer to the other face, undecidable from geometry: a
  // share of about E|noise| / 0.04 = 0.8 * 0.0035 / 0.04 = 7 %, at 90 degrees each, i.e. a floor
  // near 6-7 degrees (measured 8.3 vs PCA 33.8; noise-free MFPS is at 0.13). Assert MFPS under
  // 12 degrees (floor plus margin for sampling) and under half of PCA's error.
  EXPECT_LT(e_mfps, 12.0) << "mfps " << e_mfps << " vs pca " << e_pca;
  EXPECT_LT(e_mfps * 2, e_pca) << "mfps " << e_mfps << " vs pca " << e_pca;
  // Away from edges both must be accurate (plain plane fits): under 3 degrees on average.
  const Eigen::VectorXd em = angle_errors_deg(rm.normals, f.normals);
  double s = 0;
  int c = 0;
  for (Eigen::Index i = 0; i < f.points.rows(); ++i)
    if (edge_distance(f.points.row(i).transpose()) > 0.3) {
      s += em[i];
      ++c;
    }
  EXPECT_LT(s / c, 3.0);
}

TEST(Mfps, DeterministicAcrossThreadCounts) {
  const auto f = fixtures::cube(8000, 0.004, 3);
  EstimateOptions o;
  o.mfps.scales = {20, 40, 60};
  o.run.threads = 1;
  const EstimateResult a = estimate_normals(f.points, o);
  o.run.threads = 2;
  const EstimateResult b = estimate_normals(f.points, o);
  ASSERT_EQ(a.normals.rows(), b.normals.rows());
  EXPECT_EQ((a.normals - b.normals).cwiseAbs().maxCoeff(), 0.0);
}

TEST(Mfps, CandidatesOutsidePatchesKeepBaseNormals) {
  const auto f = fixtures::plane(500, 1);
  const IndexMatrix knn = fixtures::knn_table(f.points, 30);
  const PcaResult p = pca_normals(f.points, knn, PcaOptions{30});
  std::vector<uint8_t> cand(500, 0);
  MfpsOptions o;
  o.scales = {10, 20, 30};
  const MfpsResult r =
      mfps_normals(f.points, knn, Eigen::VectorXd::Constant(500, 0.01), cand, p.normals, o);
  EXPECT_EQ(r.patches, 0);
  EXPECT_EQ((r.normals - p.normals).cwiseAbs().maxCoeff(), 0.0);
}

TEST(Mfps, EdgePosteriorLowersErrorNearEdges) {
  // Cube with 0.6 % noise (sigma = 0.021, ~1 spacing at 20k points): within ~2 sigma of an edge
  // the face a point came from is not decidable, and the argmax puts ~1 in 4 of them on the
  // wrong face (90 degrees off). The score posterior and the edge-geometry posterior (mfps.hpp)
  // bend those normals towards the other face by the probability that it is the right one, which
  // minimises the expected squared error: each step must lower the RMS error near the edges.
  const double noise = 0.006 * 2 * std::sqrt(3.0);
  const auto f = fixtures::cube(20000, noise, 11);
  auto rms_near = [&](double beta, double geo) {
    EstimateOptions o;
    o.mfps.pca_blend = false;  // the posterior steps alone (the blend has its own test)
    o.mfps.posterior_beta = beta;
    o.mfps.edge_sigma_factor = geo;
    const EstimateResult r = estimate_normals(f.points, o);
    const Eigen::VectorXd e = angle_errors_deg(r.normals, f.normals);
    double s = 0;
    int c = 0;
    for (Eigen::Index i = 0; i < f.points.rows(); ++i)
      if (edge_distance(f.points.row(i).transpose()) < 3 * noise) {
        s += e[i] * e[i];
        ++c;
      }
    return std::sqrt(s / c);
  };
  const double argmax = rms_near(0, 0), score = rms_near(24, 0), both = rms_near(12, 1);
  RecordProperty("rms_argmax", std::to_string(argmax));
  RecordProperty("rms_score", std::to_string(score));
  RecordProperty("rms_score_edge", std::to_string(both));
  // Measured: argmax 41.8, score posterior 35.1, score + edge 33.6 degrees RMS. Margin 1 degree:
  // the fixture is deterministic (fixed seed) and the RMS of the ~3000 near-edge points moves by
  // a few tenths of a degree between fixture seeds.
  EXPECT_LT(score + 1.0, argmax) << argmax << " " << score << " " << both;
  EXPECT_LT(both + 1.0, score) << argmax << " " << score << " " << both;
}

namespace {
double rms_deg(const Normals& est, const Normals& truth) {
  const Eigen::VectorXd e = angle_errors_deg(est, truth);
  return std::sqrt(e.squaredNorm() / double(e.size()));
}
double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::min(1.0, std::abs(a.normalized().dot(b.normalized())))) * 180.0 / M_PI;
}
}  // namespace

TEST(Mfps, PcaBlendLowersRmsAtHighNoise) {
  // Cube with 2 % noise (sigma ~ 1.4 spacings at 20k points; the 0.6 % benchmark clouds of
  // 100k points have ~4.6). Within about one noise sigma of an edge the face a point came from
  // cannot be told; the blend (mfps.hpp, coefficients fitted on other models) moves such
  // candidates towards their PCA normal, whose large neighbourhood straddles the edge.
  const double noise = 0.02 * 2 * std::sqrt(3.0);
  const auto f = fixtures::cube(20000, noise, 11);
  EstimateOptions o;
  o.mfps.record_blend_features = true;
  const EstimateResult blended = estimate_normals(f.points, o);
  o.mfps.pca_blend = false;
  const EstimateResult plain = estimate_normals(f.points, o);
  o.method = Method::Pca;
  o.k = plain.k_used;
  const EstimateResult pca = estimate_normals(f.points, o);
  const double rb = rms_deg(blended.normals, f.normals), rp = rms_deg(plain.normals, f.normals),
               rpca = rms_deg(pca.normals, f.normals);
  RecordProperty("rms_blend", std::to_string(rb));
  RecordProperty("rms_mfps", std::to_string(rp));
  RecordProperty("rms_pca", std::to_string(rpca));
  // Measured (whole cloud, degrees): blend 21.33, without 21.66, PCA 21.94; fixture seeds 12 and
  // 13: gains of 0.29 / 0.20 over MFPS and 0.69 / 0.54 over PCA. Margins 0.15 and 0.4: the
  // fixture is deterministic, and the smallest gain seen over seeds keeps clear of them.
  EXPECT_LT(rb + 0.15, rp) << rb << " " << rp << " " << rpca;
  EXPECT_LT(rb + 0.4, rpca) << rb << " " << rp << " " << rpca;

  // The blend only rotates recorded candidates from their MFPS normal towards their PCA normal
  // (on the arc between them, within float rounding); every other normal is unchanged.
  ASSERT_FALSE(blended.mfps_blend_rows.empty());
  ASSERT_EQ(blended.mfps_blend_features.rows(), Eigen::Index(blended.mfps_blend_rows.size()));
  ASSERT_EQ(blended.mfps_blend_features.cols(), kMfpsBlendFeatures);
  std::vector<uint8_t> is_blended(size_t(f.points.rows()), 0);
  for (size_t t = 0; t < blended.mfps_blend_rows.size(); ++t) {
    const int64_t i = blended.mfps_blend_rows[t];
    is_blended[size_t(i)] = 1;
    EXPECT_EQ(blended.mfps_blend_features(Eigen::Index(t), 0), 1.0);
    const Eigen::Vector3d m = plain.normals.row(i).transpose(), p = pca.normals.row(i).transpose(),
                          b = blended.normals.row(i).transpose();
    EXPECT_NEAR(angle_deg(m, b) + angle_deg(b, p), angle_deg(m, p), 1e-3) << "row " << i;
    EXPECT_LT(angle_deg(blended.mfps_unblended.row(Eigen::Index(t)).transpose(), m), 1e-6);
  }
  int64_t moved = 0;
  for (Eigen::Index i = 0; i < f.points.rows(); ++i)
    if (!is_blended[size_t(i)])
      moved +=
          angle_deg(blended.normals.row(i).transpose(), plain.normals.row(i).transpose()) > 1e-9;
  EXPECT_EQ(moved, 0);
}

TEST(Mfps, KeepBlendWeightsKeepsTheWeightsAlone) {
  // NH-Net's candidate mix needs MFPS's blend weights, not the features or the N x 3 copy of the
  // unblended normals that record_blend_features adds (about 24 MB per million points).
  const double noise = 0.006 * 2 * std::sqrt(3.0);
  const auto f = fixtures::cube(6000, noise, 7);
  const IndexMatrix knn = fixtures::knn_table(f.points, 60);
  const PcaResult pca = pca_normals(f.points, knn, PcaOptions{30});
  const FeatureDetection fd = detect_feature_candidates(pca.variation);
  BandwidthOptions bo;
  bo.k_patch = 30;
  bo.k_average = 60;
  const Eigen::VectorXd sigma = 2.0 * residual_bandwidth(f.points, knn, std::sqrt(24.0 / 6000), bo);
  auto run = [&](bool pca_blend, bool record, bool keep) {
    MfpsOptions o;
    o.scales = {20, 40, 60};
    o.pca_blend = pca_blend;
    o.record_blend_features = record;
    o.keep_blend_weights = keep;
    return mfps_normals(f.points, knn, sigma, fd.candidate, pca.normals, o);
  };
  const MfpsResult recorded = run(true, true, false);
  ASSERT_FALSE(recorded.blend_rows.empty());
  ASSERT_EQ(recorded.unblended_normals.rows(), f.points.rows());
  for (const bool pca_blend : {true, false}) {
    const MfpsResult kept = run(pca_blend, false, true);
    const MfpsResult plain = run(pca_blend, false, false);
    // The same rows and weights as recorded (the weights come from the normals before the
    // blend, so whether it is applied does not change them) and nothing else kept.
    EXPECT_EQ(kept.blend_rows, recorded.blend_rows) << pca_blend;
    EXPECT_EQ(kept.blend_weights, recorded.blend_weights) << pca_blend;
    EXPECT_EQ(kept.unblended_normals.size(), 0) << pca_blend;
    EXPECT_EQ(kept.blend_features.size(), 0) << pca_blend;
    EXPECT_TRUE(plain.blend_rows.empty() && plain.blend_weights.empty()) << pca_blend;
    // Keeping the weights changes no normal.
    EXPECT_EQ((kept.normals - plain.normals).cwiseAbs().maxCoeff(), 0.0) << pca_blend;
  }
  for (const double w : recorded.blend_weights) {
    EXPECT_GE(w, 0.0);
    EXPECT_LE(w, 1.0);
  }
}

TEST(Bandwidth, TakesThePcaPlanesOfItsPatchSize) {
  // The pipeline's PCA fits the same k_patch planes the bandwidth's first pass fits: given
  // pca_normals() of that k the result is the same bit for bit; of another k they are ignored.
  const auto f = fixtures::cube(4000, 0.004, 9);
  const IndexMatrix knn = fixtures::knn_table(f.points, 60);
  BandwidthOptions bo;
  bo.k_patch = 30;
  bo.k_average = 60;
  const double spacing = std::sqrt(24.0 / 4000);
  const Eigen::VectorXd fitted = residual_bandwidth(f.points, knn, spacing, bo);
  const PcaResult same = pca_normals(f.points, knn, PcaOptions{30, true});
  EXPECT_TRUE(residual_bandwidth(f.points, knn, spacing, bo, {}, &same) == fitted);
  const PcaResult other = pca_normals(f.points, knn, PcaOptions{40, true});
  EXPECT_TRUE(residual_bandwidth(f.points, knn, spacing, bo, {}, &other) == fitted);
  // The planes are read, not refitted: tilting them all changes the result.
  PcaResult tilted = same;
  for (Eigen::Index i = 0; i < tilted.normals.rows(); ++i)
    tilted.normals.row(i) = Eigen::RowVector3d(0.6, 0.0, 0.8);
  EXPECT_FALSE(residual_bandwidth(f.points, knn, spacing, bo, {}, &tilted) == fitted);
  // Without centroids (PcaOptions::centroids off, the default) there are no planes to read.
  PcaResult bare = pca_normals(f.points, knn, PcaOptions{30});
  EXPECT_EQ(bare.centroid.rows(), 0);
  bare.normals = tilted.normals;
  EXPECT_TRUE(residual_bandwidth(f.points, knn, spacing, bo, {}, &bare) == fitted);
}

namespace {
/// RMS angle error (degrees) of the normals of an MFPS run on a noisy cube with large scales.
struct LargeScaleRun {
  double rms_all = 0, rms_near_edges = 0;
  int64_t patches = 0;
};
LargeScaleRun large_scale_mfps(const fixtures::Fixture& f, int fit_members, int bandwidth_patches) {
  const IndexMatrix knn = fixtures::knn_table(f.points, 300);
  const double spacing = std::sqrt(24.0 / double(f.points.rows()));
  BandwidthOptions bo;
  bo.k_patch = 200;
  bo.k_average = 300;
  bo.max_patches = bandwidth_patches;
  const PcaResult pca = pca_normals(f.points, knn, PcaOptions{200, true});
  const Eigen::VectorXd sigma = 2.0 * residual_bandwidth(f.points, knn, spacing, bo, {}, &pca);
  const std::vector<uint8_t> cand = detect_feature_candidates(pca.variation).candidate;
  MfpsOptions o;
  o.scales = {150, 300};
  o.fit_members = fit_members;
  const MfpsResult r = mfps_normals(f.points, knn, sigma, cand, pca.normals, o);
  const Eigen::VectorXd e = angle_errors_deg(r.normals, f.normals);
  LargeScaleRun out;
  out.patches = r.patches;
  double s = 0, se = 0;
  int ce = 0;
  for (Eigen::Index i = 0; i < e.size(); ++i) {
    s += e[i] * e[i];
    if (edge_distance(f.points.row(i).transpose()) < 0.15) {
      se += e[i] * e[i];
      ++ce;
    }
  }
  out.rms_all = std::sqrt(s / double(e.size()));
  out.rms_near_edges = std::sqrt(se / std::max(ce, 1));
  return out;
}
}  // namespace

TEST(Mfps, SpreadSubsetsOfLargePatchesKeepTheAccuracy) {
  // Patches of 150 and 300 members fit their planes to 128 spread members, and the bandwidth
  // picks among 128 of its 200 patches: same patches, and the error of all members within a
  // margin.
  // A plane fitted to m of K noisy members has a noise error ~ sqrt(K / m) times larger
  // (1.5x for 128 of 300), but at these sizes the error is the edges' (patches straddling two
  // faces), which the subset sees as well as all members; 0.5 degrees of RMS is about a tenth
  // of the error near the edges here.
  const auto f = fixtures::cube(20000, 0.006, 4);
  const LargeScaleRun all = large_scale_mfps(f, 0, 0);
  const LargeScaleRun sub = large_scale_mfps(f, 128, 128);
  EXPECT_EQ(sub.patches, all.patches);
  EXPECT_GT(all.patches, 0);
  EXPECT_NEAR(sub.rms_all, all.rms_all, 0.5) << "all members " << all.rms_all;
  EXPECT_NEAR(sub.rms_near_edges, all.rms_near_edges, 1.0) << "all members " << all.rms_near_edges;
}

TEST(Mfps, FitMembersBelowFourIsRefused) {
  const auto f = fixtures::plane(500, 1);
  const IndexMatrix knn = fixtures::knn_table(f.points, 30);
  const PcaResult p = pca_normals(f.points, knn, PcaOptions{30});
  MfpsOptions o;
  o.scales = {10, 20, 30};
  o.fit_members = 3;
  EXPECT_THROW(mfps_normals(f.points, knn, Eigen::VectorXd::Constant(500, 0.01),
                            std::vector<uint8_t>(500, 1), p.normals, o),
               InvalidOptions);
}

TEST(Bandwidth, SpreadSubsetEstimatesTheWholeNeighbourhood) {
  // Pass 2 picks each point's best patch among 128 of its 200, spread over their distance
  // ranks (passes 1 and 3 keep every member). The best of fewer candidates scores no better,
  // so its residual is the same or a little larger: measured +1.3 % on average, median
  // relative difference 1.1 % (with 64 members in all three passes, rejected: +7 % and 8 %).
  // Bounds: the mean ratio in [1, 1.12] and the median relative difference under 12 % (MFPS's
  // kernel then at most ~1/10 wider; the training split's MFPS RMS moved by under 0.01 deg,
  // docs/design/decisions.md#a-fixed-cost-per-point-at-high-noise).
  const auto f = fixtures::cube(8000, 0.01, 6);
  const IndexMatrix knn = fixtures::knn_table(f.points, 300);
  const double spacing = std::sqrt(24.0 / 8000);
  BandwidthOptions bo;
  bo.k_patch = 200;
  bo.k_average = 300;
  bo.max_patches = 0;
  const Eigen::VectorXd all = residual_bandwidth(f.points, knn, spacing, bo);
  bo.max_patches = 128;
  const Eigen::VectorXd sub = residual_bandwidth(f.points, knn, spacing, bo);
  std::vector<double> rel(size_t(all.size()));
  double ratio = 0;
  for (Eigen::Index i = 0; i < all.size(); ++i) {
    rel[size_t(i)] = std::abs(sub[i] / all[i] - 1);
    ratio += sub[i] / all[i] / double(all.size());
  }
  std::nth_element(rel.begin(), rel.begin() + long(rel.size() / 2), rel.end());
  EXPECT_LT(rel[rel.size() / 2], 0.12);
  EXPECT_GE(ratio, 1.0);
  EXPECT_LE(ratio, 1.12);
  EXPECT_FALSE(sub == all);  // the subset is in use
}

TEST(Bandwidth, RefusesAPatchCountThatSpreadsNothing) {
  // One patch or a negative count used to mean "all patches" without a word.
  const auto f = fixtures::cube(500, 0.01, 6);
  const IndexMatrix knn = fixtures::knn_table(f.points, 40);
  BandwidthOptions bo;
  for (const int bad : {1, -1, -128}) {
    bo.max_patches = bad;
    EXPECT_THROW(residual_bandwidth(f.points, knn, 0.1, bo), InvalidOptions) << bad;
  }
  bo.max_patches = 2;
  EXPECT_EQ(residual_bandwidth(f.points, knn, 0.1, bo).size(), 500);
}
