// fast_math.hpp: the batched exp of MFPS's Gaussian kernels (paper Eq. 1) against std::exp, the
// kernels of coordinate arrays against the per-point Eigen code, and the smallest eigenvector of
// its 4-point planes (Eq. 2's samples) against Eigen's solver.
#include "util/fast_math.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace {

std::vector<double> arguments() {
  std::vector<double> x;
  for (int i = 0; i <= 70800; ++i) x.push_back(-0.01 * i);  // grid over [-708, 0]
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> wide(-708.0, 0.0), narrow(-40.0, 0.0);
  for (int i = 0; i < 100000; ++i) x.push_back(wide(rng));
  for (int i = 0; i < 100000; ++i) x.push_back(narrow(rng));  // where kernels are not ~0
  x.push_back(-0.0);
  x.push_back(-std::numeric_limits<double>::denorm_min());
  x.push_back(-0.5 * std::log(2.0));  // reduction boundaries
  x.push_back(-1.5 * std::log(2.0));
  return x;
}

}  // namespace

TEST(FastExp, RelativeErrorBelow1e14OnTheWholeRange) {
  const std::vector<double> x = arguments();
  std::vector<double> y(x.size());
  nhnet::detail::exp_nonpositive(x.data(), y.data(), x.size());
  double worst = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    const double ref = std::exp(x[i]);
    worst = std::max(worst, std::abs(y[i] - ref) / ref);
  }
  // A sum of kernels that argmax compares needs far less; 1e-14 is what the degree-11
  // polynomial and the two-part ln2 give (the file comment), so a broken constant fails here.
  EXPECT_LT(worst, 1e-14);
  EXPECT_EQ(nhnet::detail::exp_nonpositive(0.0), 1.0);
}

TEST(FastExp, BatchLanesAndScalarGiveTheSameBits) {
  const std::vector<double> x = arguments();
  for (size_t n : {size_t(1), size_t(2), size_t(3), size_t(7), x.size()}) {
    std::vector<double> y(n), b(n);
    nhnet::detail::exp_nonpositive(x.data(), y.data(), n);
    // The dispatched batch (four AVX2 lanes where the CPU has them, the height maps' exp).
    nhnet::detail::exp_nonpositive_batch(x.data(), b.data(), n);
    for (size_t i = 0; i < n; ++i) {
      const double s = nhnet::detail::exp_nonpositive(x[i]);
      ASSERT_EQ(std::memcmp(&s, &y[i], sizeof s), 0) << "x = " << x[i] << " n = " << n;
      ASSERT_EQ(std::memcmp(&s, &b[i], sizeof s), 0) << "batch, x = " << x[i] << " n = " << n;
    }
  }
}

TEST(FastExp, ClampsBelowTheNormalRangeAndKeepsNaN) {
  const double lowest = std::exp(-708.0);
  std::vector<double> x = {-709.0, -1e6, -std::numeric_limits<double>::infinity(),
                           std::numeric_limits<double>::quiet_NaN()};
  std::vector<double> y(x.size());
  nhnet::detail::exp_nonpositive(x.data(), y.data(), x.size());
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(y[size_t(i)] / lowest, 1.0, 1e-14) << x[size_t(i)];
  EXPECT_TRUE(std::isnan(y[3]));
  EXPECT_TRUE(std::isnan(nhnet::detail::exp_nonpositive(x[3])));
}

// tanh_batch against libm over the candidate mix's range of hidden-unit inputs and far
// beyond: the bound is exp_nonpositive's relative 1e-14 carried through (1 - e) / (1 + e), whose
// derivative in e is at most 1/2 in size.
TEST(FastTanh, AbsoluteErrorBelow1e14AndTheEdgesKept) {
  std::vector<double> x;
  for (double v = -40; v <= 40; v += 0.0037) x.push_back(v);
  for (double v : {0.0, -0.0, 1e-300, -1e-12, 1e-6, 19.0, 710.0, -1e308}) x.push_back(v);
  std::vector<double> y(x.size());
  nhnet::detail::tanh_batch(x.data(), y.data(), x.size());
  double worst = 0;
  for (size_t i = 0; i < x.size(); ++i) worst = std::max(worst, std::abs(y[i] - std::tanh(x[i])));
  std::printf("  measured: largest |tanh_batch - std::tanh| %.3g\n", worst);
  EXPECT_LT(worst, 1e-14);
  const double inf = std::numeric_limits<double>::infinity();
  const double edge[4] = {inf, -inf, std::nan(""), -0.0};
  double out[4];
  nhnet::detail::tanh_batch(edge, out, 4);
  EXPECT_EQ(out[0], 1.0);
  EXPECT_EQ(out[1], -1.0);
  EXPECT_TRUE(std::isnan(out[2]));
  EXPECT_TRUE(out[3] == 0.0 && std::signbit(out[3]));
}

// softplus_batch against libm's log1p(exp(x)) over the learned fit's range of member scores
// and far beyond; the edges as documented.
TEST(FastSoftplus, RelativeErrorBelow1e11AndTheEdgesKept) {
  std::vector<double> x;
  for (double v = -60; v <= 60; v += 0.0041) x.push_back(v);
  for (double v : {0.0, -0.0, 1e-300, -1e-12, 1e-6, 19.999, 20.0, 700.0, -700.0}) x.push_back(v);
  std::vector<double> y(x.size());
  nhnet::detail::softplus_batch(x.data(), y.data(), x.size());
  double worst = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    const double want = x[i] > 30 ? x[i] + std::exp(-x[i]) : std::log1p(std::exp(x[i]));
    worst = std::max(worst, std::abs(y[i] - want) / want);
  }
  std::printf("  measured: largest relative |softplus_batch - libm| %.3g\n", worst);
  EXPECT_LT(worst, 1e-11);
  const double inf = std::numeric_limits<double>::infinity();
  const double edge[3] = {inf, -inf, std::nan("")};
  double out[3];
  nhnet::detail::softplus_batch(edge, out, 3);
  EXPECT_EQ(out[0], inf);
  EXPECT_GE(out[1], 0.0);
  EXPECT_LT(out[1], 1e-300);
  EXPECT_TRUE(std::isnan(out[2]));
  // log1p_unit on its own over [0, 1], against libm.
  double worst_log = 0;
  for (double t = 0; t <= 1.0; t += 1.0 / 4096)
    if (t > 0)
      worst_log = std::max(worst_log,
                           std::abs(nhnet::detail::log1p_unit(t) - std::log1p(t)) / std::log1p(t));
  EXPECT_LT(worst_log, 1e-11);
  EXPECT_EQ(nhnet::detail::log1p_unit(0.0), 0.0);
}

TEST(PlaneKernels, EveryPathGivesThePerPointEigenBits) {
  // MFPS's objective took exp(-r^2 / s^2) of r = (q - c).dot(n) point by point (Vector3d); the
  // coordinate-array paths must give the same bits, so MFPS's planes and scores do not move.
  std::mt19937_64 rng(11);
  std::normal_distribution<double> g(0.0, 1.0);
  for (size_t m : {size_t(1), size_t(3), size_t(4), size_t(5), size_t(48), size_t(301)}) {
    std::vector<double> x(m), y(m), z(m);
    for (size_t t = 0; t < m; ++t) {
      x[t] = g(rng);
      y[t] = g(rng);
      z[t] = 0.05 * g(rng);
    }
    const Eigen::Vector3d c(0.01 * g(rng), 0.01 * g(rng), 0.02 * g(rng));
    const Eigen::Vector3d n = Eigen::Vector3d(0.1 * g(rng), 0.1 * g(rng), 1.0).normalized();
    const double inv_s2 = 1.0 / (0.03 * 0.03);
    std::vector<double> base(m), fast(m);
    nhnet::detail::plane_kernels_baseline(x.data(), y.data(), z.data(), m, c.data(), n.data(),
                                          inv_s2, base.data());
    nhnet::detail::plane_kernels(x.data(), y.data(), z.data(), m, c.data(), n.data(), inv_s2,
                                 fast.data());
    for (size_t t = 0; t < m; ++t) {
      const double r = (Eigen::Vector3d(x[t], y[t], z[t]) - c).dot(n);
      const double want = nhnet::detail::exp_nonpositive(-r * r * inv_s2);
      ASSERT_EQ(std::memcmp(&want, &base[t], sizeof want), 0) << "baseline, m = " << m;
      ASSERT_EQ(std::memcmp(&want, &fast[t], sizeof want), 0) << "dispatched, m = " << m;
    }
  }
}

namespace {

/// Covariance of `m` points drawn around a plane (thickness t) with random orientation.
Eigen::Matrix3d random_cov(std::mt19937_64& rng, int m, double t, Eigen::Vector3d* normal) {
  std::normal_distribution<double> g(0.0, 1.0);
  const Eigen::Vector3d n = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
  const Eigen::Vector3d u = n.unitOrthogonal(), v = n.cross(u);
  std::vector<Eigen::Vector3d> p;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int i = 0; i < m; ++i) {
    p.push_back(g(rng) * u + g(rng) * v + t * g(rng) * n);
    mean += p.back();
  }
  mean /= m;
  Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
  for (const auto& x : p) c += (x - mean) * (x - mean).transpose();
  if (normal) *normal = n;
  return c;
}

}  // namespace

TEST(SmallestEigenvector, MatchesEigensSolverOnFourPointAndWiderCovariances) {
  std::mt19937_64 rng(11);
  double worst_deg = 0;
  int count = 0;
  for (int m : {4, 8, 50}) {
    for (double t : {0.0, 1e-6, 1e-3, 0.05, 0.3}) {
      for (int rep = 0; rep < 2000; ++rep) {
        const Eigen::Matrix3d c = random_cov(rng, m, t, nullptr) * std::pow(10.0, rep % 13 - 6);
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(c);
        Eigen::Vector3d n;
        const Eigen::Vector3d ev = es.eigenvalues();
        // Only well-separated smallest eigenvalues have a unique normal to compare.
        if (!(ev[1] > 1.01 * ev[0])) continue;
        ASSERT_TRUE(nhnet::detail::smallest_eigenvector(c, 1e-12, n)) << c;
        const double cosang = std::min(1.0, std::abs(n.dot(es.eigenvectors().col(0))));
        worst_deg = std::max(worst_deg, std::acos(cosang) * 180 / M_PI);
        EXPECT_NEAR(n.norm(), 1.0, 1e-12);
        ++count;
      }
    }
  }
  EXPECT_GT(count, 25000);
  // Both are double-precision solvers of the same matrix; 1e-5 deg (2e-7 rad) leaves room for the
  // 1 % eigen gap admitted above (error ~ eps / gap) and fails for any formula slip.
  EXPECT_LT(worst_deg, 1e-5);
  RecordProperty("worst_deg", std::to_string(worst_deg));
  std::printf("worst %.3g deg over %d matrices\n", worst_deg, count);
}

TEST(SmallestEigenvector, RejectsCollinearZeroAndNonFinite) {
  Eigen::Vector3d n;
  const Eigen::Vector3d d(1, 2, 3);
  EXPECT_FALSE(nhnet::detail::smallest_eigenvector(d * d.transpose(), 1e-12, n));  // collinear
  EXPECT_FALSE(nhnet::detail::smallest_eigenvector(Eigen::Matrix3d::Zero(), 1e-12, n));
  Eigen::Matrix3d bad = Eigen::Matrix3d::Identity();
  bad(1, 2) = bad(2, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(nhnet::detail::smallest_eigenvector(bad, 1e-12, n));
  // A plane's covariance: the normal exactly.
  Eigen::Matrix3d plane = Eigen::Matrix3d::Zero();
  plane(0, 0) = 2;
  plane(1, 1) = 1;
  ASSERT_TRUE(nhnet::detail::smallest_eigenvector(plane, 1e-12, n));
  EXPECT_NEAR(std::abs(n.z()), 1.0, 1e-15);
}
