// estimate_oriented (pipeline/estimate_oriented.hpp): the front ends' one call gives what the
// two calls give, hands the MST the estimator's table, and reports progress once, in order.
#include "fixtures.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/pipeline/estimate_oriented.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

using namespace nhnet;

TEST(EstimateOriented, GivesTheTwoCallsResultWithOneProgress) {
  const auto f = fixtures::cube(20000, 0.002, 44);
  const OrientOptions mst;
  EstimateOptions eo;
  eo.run.threads = 2;
  // The two calls, the orientation searching on its own.
  EstimateResult alone = estimate_normals(f.points, eo);
  const OrientResult ra = orient_normals(f.points, alone.normals, mst);
  // The one call: same normals and signs, exactly (the cube's 50-NN sets are the same either
  // way: Orient.MstOnTheEstimatorsNeighbourTableOrientsAsItsOwnSearch), the table handed on.
  std::vector<double> seen;
  const RunContext run{2, [&](double done, const std::string&) {
                         seen.push_back(done);
                         return true;
                       }};
  const OrientedResult both = estimate_oriented(f.points, eo, mst, run);
  EXPECT_TRUE(both.estimate.normals == alone.normals);
  EXPECT_EQ(both.estimate.neighbours.size(), 0);  // moved into the orientation
  EXPECT_EQ(both.orient.flipped, ra.flipped);
  EXPECT_EQ(both.orient.components, ra.components);
  // One progress in [0, 1], never going back: the estimation's part up to the share, then the
  // orientation's (which stops short of 1 when it ends with no stage left to report).
  EXPECT_DOUBLE_EQ(estimation_share(mst), 0.85);
  ASSERT_FALSE(seen.empty());
  for (size_t i = 1; i < seen.size(); ++i) EXPECT_GE(seen[i], seen[i - 1] - 1e-12) << i;
  EXPECT_LE(seen.front(), 0.85);
  EXPECT_GT(seen.back(), 0.9);
  EXPECT_LE(seen.back(), 1.0);
}

TEST(EstimateOriented, WithoutOrientationOrWithAViewpointEstimatesOnly) {
  const auto f = fixtures::cube(3000, 0.002, 46);
  EstimateOptions eo;
  const EstimateResult plain = estimate_normals(f.points, eo);
  OrientOptions none;
  none.mode = OrientMode::None;
  EXPECT_DOUBLE_EQ(estimation_share(none), 1.0);
  const OrientedResult n = estimate_oriented(f.points, eo, none, RunContext{});
  EXPECT_TRUE(n.estimate.normals == plain.normals);
  EXPECT_EQ(n.orient.flipped, 0);
  // A viewpoint far above: every normal faces +z or is a side's, none flipped back.
  OrientOptions view;
  view.mode = OrientMode::Viewpoint;
  view.viewpoint = Eigen::Vector3d(0, 0, 100);
  EXPECT_DOUBLE_EQ(estimation_share(view), 1.0);
  const OrientedResult v = estimate_oriented(f.points, eo, view, RunContext{});
  for (Eigen::Index i = 0; i < f.points.rows(); ++i) {
    const Eigen::Vector3d to_view = Eigen::Vector3d(0, 0, 100) - f.points.row(i).transpose();
    ASSERT_GE(v.estimate.normals.row(i).dot(to_view), 0.0) << "row " << i;
  }
  EXPECT_GT(v.orient.flipped, 0);
}

TEST(EstimateOriented, CancelledDuringTheOrientationThrows) {
  const auto f = fixtures::cube(3000, 0.002, 47);
  // Every report of the estimation is <= 0.85 (its share); the orientation's are above.
  const RunContext run{1, [](double done, const std::string&) { return done <= 0.85; }};
  EXPECT_THROW(estimate_oriented(f.points, EstimateOptions{}, OrientOptions{}, run), Cancelled);
}
