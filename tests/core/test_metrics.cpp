// Angle metrics on hand-computed cases.
#include "nhnet/metrics.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace nhnet;

TEST(Metrics, HandComputedAngles) {
  Normals est(4, 3), gt(4, 3);
  est << 1, 0, 0,   0, 1, 0,   -1, 0, 0,   1, 1, 0;
  gt << 1, 0, 0,    1, 0, 0,   1, 0, 0,    1, 0, 0;
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
}

TEST(Metrics, InvalidRowsAreCountedNotAveraged) {
  Normals est(3, 3), gt(3, 3);
  est << NAN, 0, 0,  0, 0, 0,  0, 0, 1;
  gt << 1, 0, 0,     1, 0, 0,  0, 0, 1;
  const AngleStats s = angle_stats(est, gt);
  EXPECT_EQ(s.count, 1);
  EXPECT_EQ(s.invalid, 2);
  EXPECT_NEAR(s.mean, 0.0, 1e-12);
}

TEST(Metrics, SizeMismatchThrows) {
  EXPECT_THROW(angle_errors_deg(Normals(2, 3), Normals(3, 3)), std::invalid_argument);
}
