// Candidate detection (surface-variation histogram threshold) and the 1-D TV solver.
#include "nhnet/geometry/feature_detection.hpp"

#include <gtest/gtest.h>

#include <random>

using namespace nhnet;

TEST(TvDenoise, ConstantInputIsUnchanged) {
  const Eigen::VectorXd y = Eigen::VectorXd::Constant(20, 0.3);
  EXPECT_LT((tv_denoise_1d(y, 0.5) - y).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(TvDenoise, TwoLevelStepShrinksByLambdaOverSegmentLength) {
  // y = 1 on 10 samples then 0 on 10: the exact TV solution moves each plateau towards the other
  // by lambda / 10 (a closed form of 1-D TV for a single jump).
  Eigen::VectorXd y(20);
  y.head(10).setOnes();
  y.tail(10).setZero();
  const Eigen::VectorXd x = tv_denoise_1d(y, 0.5);
  EXPECT_NEAR(x[0], 0.95, 1e-6);
  EXPECT_NEAR(x[19], 0.05, 1e-6);
}

TEST(FeatureDetection, FlagsTheHighVariationTail) {
  // 9000 smooth points with small variations and 1000 feature points with large ones.
  std::mt19937 rng(3);
  std::normal_distribution<double> smooth(0.01, 0.003), feature(0.15, 0.03);
  Eigen::VectorXd v(10000);
  for (int i = 0; i < 9000; ++i) v[i] = std::abs(smooth(rng));
  for (int i = 9000; i < 10000; ++i) v[i] = std::abs(feature(rng));
  const FeatureDetection d = detect_feature_candidates(v);
  EXPECT_FALSE(d.used_fallback);
  int64_t smooth_flagged = 0, feature_flagged = 0;
  for (int i = 0; i < 9000; ++i) smooth_flagged += d.candidate[size_t(i)];
  for (int i = 9000; i < 10000; ++i) feature_flagged += d.candidate[size_t(i)];
  EXPECT_LT(smooth_flagged, 90);    // < 1 % of smooth points
  EXPECT_GT(feature_flagged, 950);  // > 95 % of feature points
}

TEST(FeatureDetection, PlanarCloudHasNoCandidates) {
  const FeatureDetection d = detect_feature_candidates(Eigen::VectorXd::Zero(100));
  EXPECT_EQ(d.count, 0);
}
