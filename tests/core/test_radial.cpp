// Radial normals (geometry/radial.hpp) on analytic fixtures: on a thin rod, where the k nearest
// wrap around it and PCA's smallest eigenvector is arbitrary, the radial normal is the rod's
// normal; NaN (not made up) for a point at its neighbours' centroid; the elongation is 0 along a
// line and clearly above 0 on a rod's band.
#include "fixtures.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/geometry/pca.hpp"
#include "nhnet/geometry/radial.hpp"

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include <cmath>

using namespace nhnet;

namespace {

/// A rod of radius 0.01 along x: rings of 16 points 0.0039 apart (the arc spacing), 256 rings,
/// and its exact unit normals.
void rod(Points& pts, Normals& normals) {
  const int around = 16, rings = 256;
  const double radius = 0.01, pi = std::acos(-1.0), step = 2 * pi * radius / around;
  pts.resize(around * rings, 3);
  normals.resize(around * rings, 3);
  for (int r = 0; r < rings; ++r)
    for (int a = 0; a < around; ++a) {
      const double t = 2 * pi * (a + 0.5 * (r % 2)) / around;
      pts.row(r * around + a) << r * step, radius * std::cos(t), radius * std::sin(t);
      normals.row(r * around + a) << 0, std::cos(t), std::sin(t);
    }
}

double degrees(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return fixtures::line_angle(a, b) * 180 / std::acos(-1.0);
}

}  // namespace

TEST(Radial, IsTheNormalOfAThinRodWherePcaIsNot) {
  Points pts;
  Normals truth;
  rod(pts, truth);
  const int k = 200;  // about 12 rings: the neighbourhood is longer (~0.05) than wide (0.02)
  const IndexMatrix knn = fixtures::knn_table(pts, k);
  const RadialResult r = radial_normals(pts, knn, RadialOptions{k});
  const Normals pca = pca_normals(pts, knn, PcaOptions{k}).normals;
  double radial_sq = 0, pca_sq = 0;
  int counted = 0;
  for (Eigen::Index i = 16 * 20; i < pts.rows() - 16 * 20; ++i) {  // away from the rod's ends
    ASSERT_TRUE(r.normals.row(i).allFinite()) << i;
    radial_sq += std::pow(degrees(r.normals.row(i).transpose(), truth.row(i).transpose()), 2);
    pca_sq += std::pow(degrees(pca.row(i).transpose(), truth.row(i).transpose()), 2);
    EXPECT_GT(r.elongation[i], 0.05) << i;  // a rod's band, not a line
    ++counted;
  }
  // The k nearest are whole rings but for the farthest one, whose partial ring pulls the
  // centroid off the axis by a fraction of the radius: a few degrees at most. PCA's normal is
  // any direction across the rod (its two small eigenvalues are equal): tens of degrees.
  EXPECT_LT(std::sqrt(radial_sq / counted), 5.0);
  EXPECT_GT(std::sqrt(pca_sq / counted), 20.0);
}

TEST(Radial, PcasOwnPlanesGiveTheSameCandidates) {
  Points pts;
  Normals truth;
  rod(pts, truth);
  for (int k : {7, 200}) {  // the candidate mix's half scale and a rod-wrapping one
    const IndexMatrix knn = fixtures::knn_table(pts, k);
    const RadialResult alone = radial_normals(pts, knn, RadialOptions{k});
    const PcaResult pca = pca_normals(pts, knn, PcaOptions{k, false, true});
    ASSERT_EQ(pca.radial.normals.rows(), pts.rows());
    EXPECT_EQ(pca.normals, pca_normals(pts, knn, PcaOptions{k}).normals);  // PCA unchanged
    // Bit for bit, NaN where NaN: the same covariance, the same arithmetic.
    for (Eigen::Index i = 0; i < pts.rows(); ++i) {
      for (int c = 0; c < 3; ++c) {
        const double x = alone.normals(i, c), y = pca.radial.normals(i, c);
        EXPECT_TRUE(x == y || (std::isnan(x) && std::isnan(y))) << k << " " << i;
      }
      EXPECT_TRUE(alone.offset[i] == pca.radial.offset[i] ||
                  (std::isnan(alone.offset[i]) && std::isnan(pca.radial.offset[i])));
      EXPECT_EQ(alone.elongation[i], pca.radial.elongation[i]);
    }
  }
  EXPECT_EQ(pca_normals(pts, fixtures::knn_table(pts, 7), PcaOptions{7}).radial.normals.rows(), 0);
}

TEST(Radial, NanAtTheCentroidAndZeroElongationOnALine) {
  Points pts(5, 3);
  pts << 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0;  // a cross: point 0 is the centroid
  IndexMatrix knn(5, 5);
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j) knn(i, j) = (i + j) % 5;  // self first, all five
  const RadialResult r = radial_normals(pts, knn, RadialOptions{5});
  EXPECT_FALSE(r.normals.row(0).allFinite());
  EXPECT_TRUE(std::isnan(r.offset[0]));

  Points line(4, 3);
  line << 0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3;
  IndexMatrix lk(4, 4);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) lk(i, j) = (i + j) % 4;
  const RadialResult l = radial_normals(line, lk, RadialOptions{4});
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(l.elongation[i], 0.0, 1e-12) << i;
    EXPECT_FALSE(l.normals.row(i).allFinite()) << i;  // on the axis: no offset across it
  }
}

TEST(Radial, RefusesATooSmallNeighbourhood) {
  Points pts = Points::Random(10, 3);
  EXPECT_THROW(radial_normals(pts, fixtures::knn_table(pts, 2), RadialOptions{2}), InvalidOptions);
}
