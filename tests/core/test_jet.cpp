// Jet normals (geometry/jet.hpp) on analytic fixtures: exact on a paraboloid's apex (the height
// function there is the fitted quadric), much closer than PCA where a plane fit is tilted by the
// curvature, the same whatever the frame normal's sign, and NaN (not made up) where the
// neighbourhood cannot determine a quadric.
#include "fixtures.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/geometry/jet.hpp"
#include "nhnet/geometry/pca.hpp"

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include <cmath>

using namespace nhnet;

namespace {

/// A 41 x 41 grid of z = 0.5 (a x^2 + b y^2) over [-1, 1]^2 and its exact unit normals.
void paraboloid(double a, double b, Points& pts, Normals& normals) {
  const int side = 41;
  pts.resize(side * side, 3);
  normals.resize(side * side, 3);
  for (int r = 0; r < side; ++r)
    for (int c = 0; c < side; ++c) {
      const double x = -1 + 2.0 * c / (side - 1), y = -1 + 2.0 * r / (side - 1);
      pts.row(r * side + c) << x, y, 0.5 * (a * x * x + b * y * y);
      normals.row(r * side + c) = Eigen::RowVector3d(-a * x, -b * y, 1).normalized();
    }
}

using fixtures::line_angle;

}  // namespace

TEST(Jet, ExactAtTheApexOfAParaboloid) {
  Points pts;
  Normals truth;
  paraboloid(2.0, -1.0, pts, truth);
  const IndexMatrix knn = fixtures::knn_table(pts, 60);
  // Frame = the true normal at the apex (row 840 is (0, 0)); the height over it is the quadric.
  Normals frame = truth;
  const Normals jet = jet_normals(pts, knn, frame, JetOptions{60});
  // 1e-9 rad: a least-squares fit of an exact quadric, rounding only.
  EXPECT_LT(line_angle(jet.row(840).transpose(), truth.row(840).transpose()), 1e-9);
}

TEST(Jet, BeatsPcaWhereCurvatureTiltsThePlane) {
  Points pts;
  Normals truth;
  paraboloid(1.0, -1.0, pts, truth);  // a saddle
  const int k = 60;
  const IndexMatrix knn = fixtures::knn_table(pts, k);
  const PcaResult pca = pca_normals(pts, knn, PcaOptions{k});
  const Normals jet = jet_normals(pts, knn, pca.normals, JetOptions{k});
  double pca_sq = 0, jet_sq = 0;
  int inner = 0;
  for (Eigen::Index i = 0; i < pts.rows(); ++i) {
    if (pts.row(i).head<2>().cwiseAbs().maxCoeff() > 0.7) continue;  // away from the border
    const Eigen::Vector3d t = truth.row(i).transpose();
    pca_sq += std::pow(line_angle(pca.normals.row(i).transpose(), t), 2);
    jet_sq += std::pow(line_angle(jet.row(i).transpose(), t), 2);
    ++inner;
  }
  const double pca_rms = std::sqrt(pca_sq / inner) * 180 / M_PI;
  const double jet_rms = std::sqrt(jet_sq / inner) * 180 / M_PI;
  RecordProperty("pca_rms_deg", std::to_string(pca_rms));
  RecordProperty("jet_rms_deg", std::to_string(jet_rms));
  // Noise-free: the jet's error is the cubic remainder of the tilted frame, PCA's the curvature's
  // tilt of the plane (0.14 vs 0.53 deg with numpy's least squares on this grid): under half.
  EXPECT_LT(jet_rms, 0.5 * pca_rms) << "pca " << pca_rms << " deg, jet " << jet_rms << " deg";
}

TEST(Jet, FrameSignDoesNotMatter) {
  Points pts;
  Normals truth;
  paraboloid(1.0, 2.0, pts, truth);
  const IndexMatrix knn = fixtures::knn_table(pts, 30);
  const Normals a = jet_normals(pts, knn, truth, JetOptions{30});
  const Normals b = jet_normals(pts, knn, -truth, JetOptions{30});
  // 1e-9 rad: the same fit with u and h negated, rounding only.
  for (Eigen::Index i = 0; i < pts.rows(); ++i)
    EXPECT_LT(line_angle(a.row(i).transpose(), b.row(i).transpose()), 1e-9) << i;
}

TEST(Jet, CollinearNeighbourhoodGivesNaNAndSmallKIsRefused) {
  Points line(50, 3);
  for (int i = 0; i < 50; ++i) line.row(i) << 0.1 * i, 0.2 * i, 0;
  const IndexMatrix knn = fixtures::knn_table(line, 10);
  const Normals frame = Normals::Constant(50, 3, 0).rowwise() + Eigen::RowVector3d(0, 0, 1);
  const Normals jet = jet_normals(line, knn, frame, JetOptions{10});
  for (Eigen::Index i = 0; i < 50; ++i) EXPECT_FALSE(jet.row(i).allFinite()) << i;
  EXPECT_THROW(jet_normals(line, knn, frame, JetOptions{5}), InvalidOptions);
}
