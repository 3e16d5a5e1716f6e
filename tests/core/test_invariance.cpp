// Invariance properties of estimate_normals (reliability matrix row 28 and rows 17, 19, 21, 23):
// rotation (normals rotate with the cloud, up to sign), translation (1e6 offsets), uniform
// scale (power-of-two factors bit-exact, others within rounding, 1e31 included), point
// permutation and exact duplicates (bit-exact), thread count (bit-exact), non-finite points
// (their neighbours' normals unchanged). For PCA and MFPS, with automatic scales so that the
// noise probe is covered too.
#include "fixtures.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/pipeline/estimate.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <random>
#include <vector>

using namespace nhnet;

namespace {

/// A noisy cube (sharp edges and corners: MFPS has candidates to work on).
Points noisy_cube() { return fixtures::cube(4000, 0.004, 11).points; }

EstimateResult run(const Points& p, Method m, int threads = 2) {
  EstimateOptions o;
  o.method = m;
  o.run.threads = threads;
  return estimate_normals(p, o);
}

/// Unoriented angle in degrees between rows (NaN when either row is invalid).
double angle_deg(const Eigen::RowVector3d& a, const Eigen::RowVector3d& b) {
  const double c = std::min(1.0, std::abs(a.dot(b)));
  return std::acos(c) * 180.0 / M_PI;
}

struct Diff {
  double mean = 0;             ///< mean angle over points valid in both
  double frac_over_1 = 0;      ///< fraction of those points differing by more than 1 degree
  int64_t valid_mismatch = 0;  ///< points valid in one result only
};

/// Compares `b` (after mapping row i of `a` to row map[i] of `b`, and rotating a's normals by
/// R) with `a`.
Diff compare(const EstimateResult& a, const EstimateResult& b, const std::vector<int64_t>& map,
             const Eigen::Matrix3d& R = Eigen::Matrix3d::Identity()) {
  Diff d;
  int64_t n = 0, over = 0;
  for (Eigen::Index i = 0; i < a.normals.rows(); ++i) {
    const Eigen::Index j = map.empty() ? i : map[size_t(i)];
    if (a.valid[size_t(i)] != b.valid[size_t(j)]) {
      ++d.valid_mismatch;
      continue;
    }
    if (!a.valid[size_t(i)]) continue;
    const Eigen::RowVector3d ra = (R * a.normals.row(i).transpose()).transpose();
    const double ang = angle_deg(ra, b.normals.row(j));
    d.mean += ang;
    over += ang > 1.0;
    ++n;
  }
  d.mean /= double(std::max<int64_t>(n, 1));
  d.frac_over_1 = double(over) / double(std::max<int64_t>(n, 1));
  std::printf("  measured: mean %.4g deg, %.3g %% over 1 deg, %lld validity mismatches\n", d.mean,
              100 * d.frac_over_1, static_cast<long long>(d.valid_mismatch));
  return d;
}

/// Bit-exact equality of two normal sets (NaN rows equal).
bool identical(const Normals& a, const Normals& b) {
  if (a.rows() != b.rows()) return false;
  for (Eigen::Index i = 0; i < a.size(); ++i) {
    const double x = a.data()[i], y = b.data()[i];
    if (!(x == y || (std::isnan(x) && std::isnan(y)))) return false;
  }
  return true;
}

class Invariance : public ::testing::TestWithParam<Method> {};

}  // namespace

// Rotation changes every coordinate's rounding, so float kd-tree near-ties and MFPS's random
// samples can differ at a few points: the bar is a mean change under 0.5 degree and at most 2 %
// of the points moving by more than 1 degree (PCA alone stays far below that).
TEST_P(Invariance, RotationEquivariantUpToSign) {
  const Points p = noisy_cube();
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Points q = (p * R.transpose()).eval();
  const EstimateResult a = run(p, GetParam()), b = run(q, GetParam());
  const Diff d = compare(a, b, {}, R);
  EXPECT_LT(d.mean, 0.5);
  EXPECT_LE(d.frac_over_1, 0.02);
  EXPECT_LE(d.valid_mismatch, 0);
}

// A 1e6 offset (UTM-scale scan) only adds the double rounding of p + t (about 1e-10 of the unit
// cloud), far below float resolution after recentring: same bar as rotation.
TEST_P(Invariance, FarFromOriginSameAsAtOrigin) {
  const Points p = noisy_cube();
  Points q = p;
  q.rowwise() += Eigen::RowVector3d(1e6, -2.5e6, 4e6);
  const EstimateResult a = run(p, GetParam()), b = run(q, GetParam());
  const Diff d = compare(a, b, {});
  EXPECT_LT(d.mean, 0.5);
  EXPECT_LE(d.frac_over_1, 0.02);
  EXPECT_EQ(d.valid_mismatch, 0);
  EXPECT_NEAR(a.noise_ratio, b.noise_ratio, 1e-3 * a.noise_ratio);
}

// Power-of-two factors are exact in binary floating point: bit-identical normals, down to 2^-60
// and up to 2^100 (~1e30; squared distances would overflow a float tree without rescaling).
// A factor of 1000 or 1e31 rounds every coordinate: same bar as rotation.
TEST_P(Invariance, UniformScale) {
  const Points p = noisy_cube();
  const EstimateResult a = run(p, GetParam());
  for (const int e : {-60, 10, 100}) {
    SCOPED_TRACE(e);
    const EstimateResult b = run((p * std::ldexp(1.0, e)).eval(), GetParam());
    EXPECT_TRUE(identical(a.normals, b.normals));
    EXPECT_DOUBLE_EQ(b.spacing, std::ldexp(a.spacing, e));
  }
  for (const double s : {1e-3, 1e3, 1e31}) {
    SCOPED_TRACE(s);
    const EstimateResult b = run((p * s).eval(), GetParam());
    const Diff d = compare(a, b, {});
    EXPECT_LT(d.mean, 0.5);
    EXPECT_LE(d.frac_over_1, 0.02);
    EXPECT_EQ(d.valid_mismatch, 0);
    EXPECT_NEAR(b.spacing / s, a.spacing, 1e-3 * a.spacing);
  }
}

// The pipeline works in a canonical point order: a shuffled cloud gets bit-identical
// per-point normals once un-shuffled.
TEST_P(Invariance, PermutationBitExact) {
  const Points p = noisy_cube();
  std::vector<int64_t> perm(size_t(p.rows()));
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), std::mt19937(5));
  Points q(p.rows(), 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i) q.row(perm[size_t(i)]) = p.row(i);  // i -> perm[i]
  const EstimateResult a = run(p, GetParam()), b = run(q, GetParam());
  Normals back(p.rows(), 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i) back.row(i) = b.normals.row(perm[size_t(i)]);
  EXPECT_TRUE(identical(a.normals, back));
  EXPECT_EQ(a.failed, b.failed);
}

// Every point three times (k = 16 copies would otherwise fill a neighbourhood with one
// position): the same normals as the deduplicated cloud, bit for bit, and a warning.
TEST_P(Invariance, ExactDuplicatesSameAsDeduplicated) {
  const Points p = noisy_cube();
  Points q(3 * p.rows(), 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    for (int c = 0; c < 3; ++c) q.row(c * p.rows() + i) = p.row(i);
  const EstimateResult a = run(p, GetParam()), b = run(q, GetParam());
  for (int c = 0; c < 3; ++c) {
    EXPECT_TRUE(identical(a.normals, b.normals.middleRows(c * p.rows(), p.rows())));
    for (Eigen::Index i = 0; i < p.rows(); ++i) {
      const double x = a.curvature[i], y = b.curvature[c * p.rows() + i];
      EXPECT_TRUE(x == y || (std::isnan(x) && std::isnan(y)))
          << "curvature of copy " << c << " of " << i;
    }
  }
  EXPECT_EQ(b.failed, 3 * a.failed);
  EXPECT_TRUE(std::any_of(b.warnings.begin(), b.warnings.end(), [](const std::string& w) {
    return w.find("duplicate") != std::string::npos;
  }));
}

TEST_P(Invariance, ThreadCountBitExact) {
  const Points p = noisy_cube();
  EXPECT_TRUE(identical(run(p, GetParam(), 1).normals, run(p, GetParam(), 2).normals));
}

// 5 % non-finite points: they fail (NaN normal, valid 0), are counted and warned about, and the
// finite points get exactly the normals they get without them (neighbours unaffected).
TEST_P(Invariance, NonFinitePointsDoNotDisturbNeighbours) {
  const Points p = noisy_cube();
  const double bad[3] = {std::numeric_limits<double>::quiet_NaN(),
                         std::numeric_limits<double>::infinity(),
                         -std::numeric_limits<double>::infinity()};
  Points q(p.rows() + (p.rows() + 18) / 19, 3);
  std::vector<int64_t> map;
  Eigen::Index r = 0;
  for (Eigen::Index i = 0; i < p.rows(); ++i) {
    if (i % 19 == 0) q.row(r++) << 0.5, bad[i % 3], 0.25;
    map.push_back(r);
    q.row(r++) = p.row(i);
  }
  ASSERT_EQ(r, q.rows());
  const EstimateResult a = run(p, GetParam()), b = run(q, GetParam());
  Normals back(p.rows(), 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i) back.row(i) = b.normals.row(map[size_t(i)]);
  EXPECT_TRUE(identical(a.normals, back));
  EXPECT_EQ(b.failed, a.failed + (q.rows() - p.rows()));
  for (Eigen::Index i = 0; i < q.rows(); ++i)
    if (!q.row(i).allFinite()) {
      EXPECT_EQ(b.valid[size_t(i)], 0);
      EXPECT_TRUE(b.normals.row(i).array().isNaN().all());
    }
  EXPECT_TRUE(std::any_of(b.warnings.begin(), b.warnings.end(), [](const std::string& w) {
    return w.find("non-finite") != std::string::npos;
  }));
}

INSTANTIATE_TEST_SUITE_P(Methods, Invariance, ::testing::Values(Method::Pca, Method::Mfps),
                         [](const ::testing::TestParamInfo<Method>& i) {
                           return std::string(to_string(i.param));
                         });

// Degenerate geometry (matrix rows 21-23): a perfect plane gets exactly +-z; collinear points
// and a single repeated position never get a made-up normal; mixed 1e-12 / 1e12 magnitudes do
// not crash.
TEST(Degenerate, PlaneLineIdenticalMixedMagnitudes) {
  for (const Method m : {Method::Pca, Method::Mfps}) {
    SCOPED_TRACE(to_string(m));
    const fixtures::Fixture plane = fixtures::plane(2000, 3);
    const EstimateResult pr = run(plane.points, m);
    EXPECT_EQ(pr.failed, 0);
    for (Eigen::Index i = 0; i < plane.points.rows(); ++i) {
      EXPECT_EQ(pr.normals(i, 0), 0.0);
      EXPECT_EQ(pr.normals(i, 1), 0.0);
      EXPECT_EQ(std::abs(pr.normals(i, 2)), 1.0);
    }
    Points line(300, 3);
    for (int i = 0; i < 300; ++i) line.row(i) << 0.01 * i, 0.02 * i, -0.03 * i;
    const EstimateResult lr = run(line, m);
    EXPECT_EQ(lr.failed, 300);
    EXPECT_TRUE(lr.normals.array().isNaN().all());

    const Points same = Points::Constant(50, 3, 7.0);
    EXPECT_THROW(run(same, m), UnprocessableInput);

    Points mixed = fixtures::sphere(500, 4).points;
    mixed.topRows(250) *= 1e-12;
    mixed.bottomRows(250) *= 1e12;
    const EstimateResult xr = run(mixed, m);
    EXPECT_EQ(xr.valid.size(), 500u);
    for (Eigen::Index i = 0; i < 500; ++i)
      if (xr.valid[size_t(i)]) {
        EXPECT_NEAR(xr.normals.row(i).norm(), 1.0, 1e-12);
      }
  }
}
