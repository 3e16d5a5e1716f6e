// The learned weighted jet fit (learned/learned_fit.hpp): on an exact plane any positive weights
// give the plane's normal, so a correct start stays and a tilted one moves towards the truth; a
// missing normal stays missing, a degenerate neighbourhood keeps its normal, bad inputs are
// refused; in the pipeline it lowers the default's error on the bundled noisy CAD sample, costs
// little on a noisy sphere (where the network's denoising is best), a tiny cloud skips it, and it
// reports progress and can be cancelled.
#include "fixtures.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/io/io.hpp"
#include "nhnet/learned/learned_fit.hpp"
#include "nhnet/pipeline/estimate.hpp"

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include <cmath>
#include <limits>
#include <random>
#include <string>

using namespace nhnet;
using fixtures::line_angle;
using fixtures::with_noise;

namespace {

constexpr double kDeg = M_PI / 180;

/// Members of every point: the 64 nearest (a clean fixture's k is below 64: learned_fit_k).
IndexMatrix members_of(const Points& pts) { return fixtures::knn_table(pts, kFitMembers); }

/// Every row set to unit normal n.
Normals all_rows(Eigen::Index m, const Eigen::Vector3d& n) {
  Normals out(m, 3);
  for (Eigen::Index i = 0; i < m; ++i) out.row(i) = n.normalized().transpose();
  return out;
}

Normals run_fit(const Points& pts, const Normals& normals, const IndexMatrix& members,
                double noise_ratio = 0) {
  LearnedFitInput in;
  in.points = &pts;
  in.normals = &normals;
  in.members = &members;
  in.noise_ratio = noise_ratio;
  return learned_fit(in);
}

}  // namespace

TEST(LearnedFit, KeepsAPlanesNormal) {
  const fixtures::Fixture f = fixtures::plane(2000, 1);
  const Normals out = run_fit(f.points, f.normals, members_of(f.points));
  // Every member's height is 0, so the fit's slopes are 0 and the normal is the input's:
  // rounding only.
  for (Eigen::Index i = 0; i < out.rows(); ++i)
    EXPECT_LT(line_angle(out.row(i).transpose(), Eigen::Vector3d::UnitZ()), 1e-9) << i;
}

TEST(LearnedFit, MovesATiltedNormalTowardsThePlanes) {
  const fixtures::Fixture f = fixtures::plane(2000, 2);
  const Eigen::Vector3d tilted(std::sin(10 * kDeg), 0, std::cos(10 * kDeg));
  const Normals out = run_fit(f.points, all_rows(2000, tilted), members_of(f.points), 0.1);
  // On an exact plane the weighted jet is the plane whatever the weights, up to the ridge (1e-3
  // of the weight, on every coefficient), so the result lies on the arc from the start (10 deg
  // off) to the truth at the learned gate's fraction: closer than the start by at least a tenth
  // of the way, never beyond it, and off the arc by at most 0.05 deg (the ridge's share: 0.012
  // deg measured, at the square's border where the members are one-sided).
  for (Eigen::Index i = 0; i < out.rows(); ++i) {
    const Eigen::Vector3d o = out.row(i).transpose();
    EXPECT_LT(line_angle(o, Eigen::Vector3d::UnitZ()), 9 * kDeg) << i;
    EXPECT_LT(line_angle(o, tilted) + line_angle(o, Eigen::Vector3d::UnitZ()), 10.05 * kDeg) << i;
  }
}

TEST(LearnedFit, MissingNormalStaysMissing) {
  const fixtures::Fixture f = fixtures::sphere(500, 3);
  Normals normals = f.normals;
  for (Eigen::Index i = 0; i < 500; i += 7)
    normals.row(i).setConstant(std::numeric_limits<double>::quiet_NaN());
  const Normals out = run_fit(f.points, normals, members_of(f.points));
  for (Eigen::Index i = 0; i < 500; ++i) {
    EXPECT_EQ(out.row(i).allFinite(), i % 7 != 0) << i;
    if (i % 7 != 0) {
      EXPECT_NEAR(out.row(i).norm(), 1.0, 1e-12) << i;
    }
  }
}

TEST(LearnedFit, CoincidentMembersKeepTheNormal) {
  Points pts = Points::Zero(100, 3);  // every member on the point: no radius, no fit
  const Eigen::Vector3d n(0.6, 0.0, 0.8);
  const Normals out = run_fit(pts, all_rows(100, n), members_of(pts));
  for (Eigen::Index i = 0; i < 100; ++i) EXPECT_EQ(out.row(i), n.transpose()) << i;
}

TEST(LearnedFit, RefusesInputsOfDifferentSizes) {
  const fixtures::Fixture f = fixtures::sphere(300, 4);
  const IndexMatrix members = members_of(f.points);
  EXPECT_THROW(run_fit(f.points, f.normals.topRows(299), members), InvalidOptions);
  EXPECT_THROW(run_fit(f.points, f.normals, members.leftCols(kFitMembers - 1).eval()),
               InvalidOptions);
  EXPECT_THROW(learned_fit(LearnedFitInput{}), InvalidOptions);
}

namespace {

/// RMS angle error (degrees) of the default method with the learned fit on or off.
double default_rms(const Points& pts, const Normals& truth, bool fit) {
  EstimateOptions o;
  o.method = Method::NhNet;
  o.model.device = "cpu";
  o.model.learned_fit = fit;
  const EstimateResult r = estimate_normals(pts, o);
  EXPECT_EQ(r.failed, 0);
  double sum = 0;
  for (Eigen::Index i = 0; i < r.normals.rows(); ++i) {
    const double a = line_angle(r.normals.row(i).transpose(), truth.row(i).transpose());
    sum += a * a;
  }
  const double rms = std::sqrt(sum / double(r.normals.rows())) / kDeg;
  ::testing::Test::RecordProperty(fit ? "rms_with_fit" : "rms_without_fit", std::to_string(rms));
  return rms;
}

}  // namespace

/// Mean angle error (degrees) of `normals` against `truth`.
double mean_error(const Normals& normals, const Normals& truth) {
  double sum = 0;
  for (Eigen::Index i = 0; i < normals.rows(); ++i)
    sum += line_angle(normals.row(i).transpose(), truth.row(i).transpose());
  return sum / double(normals.rows()) / kDeg;
}

TEST(LearnedFit, LowersTheDefaultsErrorOnTheBundledSample) {
  if (!nhnet_available()) GTEST_FAIL() << "this build has no libtorch: the default method needs it";
  // data/sample: fandisk (CAD, never in training), 20k points, 0.6 % noise, true normals.
  const std::string base = std::string(NHNET_SOURCE_DIR) + "/data/sample/fandisk_noise0.6";
  const Cloud gt = read_cloud(base + ".gt.xyzn");
  const double without = default_rms(gt.points, gt.normals, false);
  const double with = default_rms(gt.points, gt.normals, true);
  // Deterministic runs (fixed seed; the model's float32 outputs move by < 1e-4 deg between
  // machines). Measured RMS 19.34 -> 19.08 deg (-1.4 %): assert -0.7 %, far outside rounding.
  EXPECT_LT(with, 0.993 * without) << "without " << without << " deg, with " << with << " deg";
  EstimateOptions o;
  o.method = Method::NhNet;
  o.model.device = "cpu";
  const double mean_with = mean_error(estimate_normals(gt.points, o).normals, gt.normals);
  o.model.learned_fit = false;
  const double mean_without = mean_error(estimate_normals(gt.points, o).normals, gt.normals);
  // Measured mean 10.60 -> 10.09 deg (-4.8 %): assert -2.5 %.
  EXPECT_LT(mean_with, 0.975 * mean_without) << mean_without << " -> " << mean_with << " deg";
}

TEST(LearnedFit, CostsLittleOnANoisySphere) {
  if (!nhnet_available()) GTEST_FAIL() << "this build has no libtorch: the default method needs it";
  const fixtures::Fixture f = fixtures::sphere(20000, 5);
  const Points noisy = with_noise(f.points, 0.021, 5);  // 0.6 % of the diagonal
  const double without = default_rms(noisy, f.normals, false);
  const double with = default_rms(noisy, f.normals, true);
  // A broad smooth surface is where the network's denoising beats every fit, so the fit's gate
  // must keep the mixed normal: it loses 3.3 % here (1.81 -> 1.87 deg), its one known cost
  // (docs/design/decisions.md#learned-weighted-jet-fit-issue-23). 6 % fails a gate that trusts
  // the fit as on the organic test shapes.
  EXPECT_LT(with, 1.06 * without) << "without " << without << " deg, with " << with << " deg";
}

TEST(LearnedFit, TinyCloudKeepsTheMixsNormals) {
  if (!nhnet_available()) GTEST_FAIL() << "this build has no libtorch: the default method needs it";
  const Points pts = fixtures::sphere(kFitMembers - 4, 6).points;  // fewer than the members
  EstimateOptions o;
  o.method = Method::NhNet;
  o.model.device = "cpu";
  const EstimateResult with = estimate_normals(pts, o);
  o.model.learned_fit = false;
  const EstimateResult without = estimate_normals(pts, o);
  EXPECT_EQ(with.failed, 0);
  EXPECT_EQ(with.normals, without.normals);
}

TEST(LearnedFit, ReportsProgressAndCanBeCancelled) {
  if (!nhnet_available()) GTEST_FAIL() << "this build has no libtorch: the default method needs it";
  const Points noisy = with_noise(fixtures::sphere(3000, 7).points, 0.021, 7);
  EstimateOptions o;
  o.method = Method::NhNet;
  o.model.device = "cpu";
  int calls = 0;
  o.run.progress = [&](double, const std::string& stage) {
    return !(calls += stage == "learned fit");
  };
  EXPECT_THROW(estimate_normals(noisy, o), Cancelled);
  EXPECT_EQ(calls, 1);
}
