// Angle metrics on hand-computed cases.
#include "nhnet/errors.hpp"
#include "nhnet/eval/metrics.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace nhnet;

TEST(Metrics, HandComputedAngles) {
  Normals est(4, 3), gt(4, 3);
  est << 1, 0, 0, 0, 1, 0, -1, 0, 0, 1, 1, 0;
  gt << 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0;
  const Eigen::VectorXd e = angle_errors_deg(est, gt);
  EXPECT_NEAR(e[0], 0.0, 1e-12);
  EXPECT_NEAR(e[1], 90.0, 1e-12);
  EXPECT_NEAR(e[2], 0.0, 1e-12);  // unoriented: a flipped normal is correct
  EXPECT_NEAR(e[3], 45.0, 1e-9);  // rows need not be unit length
  const AngleStats s = angle_stats(e);
  EXPECT_EQ(s.count, 4);
  EXPECT_NEAR(s.mean, (0 + 90 + 0 + 45) / 4.0, 1e-9);
  EXPECT_NEAR(s.rms, std::sqrt((90.0 * 90 + 45.0 * 45) / 4.0), 1e-9);
  EXPECT_NEAR(s.pgp5, 0.5, 1e-12);
  EXPECT_NEAR(s.pgp10, 0.5, 1e-12);
  EXPECT_NEAR(s.over30, 0.5, 1e-12);  // 90 and 45 degrees
}

TEST(Metrics, ShareOverThirtyDegreesIsStrict) {
  Eigen::VectorXd e(4);
  e << 29.9, 30.0, 30.1, NAN;
  const AngleStats s = angle_stats(e);
  EXPECT_EQ(s.count, 3);
  EXPECT_NEAR(s.over30, 1.0 / 3.0, 1e-12);  // only 30.1; the NaN row is left out
}

TEST(Metrics, InvalidRowsAreCountedNotAveraged) {
  Normals est(3, 3), gt(3, 3);
  est << NAN, 0, 0, 0, 0, 0, 0, 0, 1;
  gt << 1, 0, 0, 1, 0, 0, 0, 0, 1;
  const AngleStats s = angle_stats(est, gt);
  EXPECT_EQ(s.count, 1);
  EXPECT_EQ(s.invalid, 2);
  EXPECT_NEAR(s.mean, 0.0, 1e-12);
}

TEST(Metrics, SizeMismatchThrows) {
  EXPECT_THROW(angle_errors_deg(Normals(2, 3), Normals(3, 3)), std::invalid_argument);
}

TEST(Metrics, SurfaceDistancesPointToPlaneAndPointToPoint) {
  nhnet::Points ref(2, 3), pts(3, 3);
  ref << 0, 0, 0, 1, 0, 0;
  nhnet::Normals rn(2, 3);
  rn << 0, 0, 2, 0, 0, 1;  // any length: normalised
  pts << 0.1, 0.05, 0.3, 0.9, 0, -0.2, NAN, 0, 0;
  const Eigen::VectorXd d = nhnet::surface_distances(pts, ref, rn);
  EXPECT_NEAR(d[0], 0.3, 1e-12);
  EXPECT_NEAR(d[1], 0.2, 1e-12);
  EXPECT_TRUE(std::isnan(d[2]));
  const Eigen::VectorXd e = nhnet::surface_distances(pts.topRows(1), ref);
  EXPECT_NEAR(e[0], std::sqrt(0.01 + 0.0025 + 0.09), 1e-12);
  EXPECT_THROW(nhnet::surface_distances(pts, ref, rn.topRows(1)), nhnet::InvalidOptions);
}
