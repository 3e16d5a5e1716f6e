// Two kernels of MFPS's plane stage (paper Eq. 1-2), which were 40 % of its time as library calls:
// exp of the Gaussian kernels, and the smallest eigenpair of the 4-point planes' 3x3 covariances.
// The batch exp also weighs the height maps' cells (learned/height_map.cpp).
//
// exp_nonpositive: exp(x) for a batch of arguments x <= 0.
// Range reduction x = k ln2 + r (|r| <= ln2 / 2, Cody-Waite split of ln2), a degree-11 Taylor
// polynomial for exp(r) (truncation < 7e-15 relative), and 2^k from the exponent bits. Relative
// error against std::exp below 1e-14 for every x in [-708, 0] (tests/core/test_fast_math.cpp);
// arguments below -708 give exp(-708) ~ 3e-308 instead of a smaller number or 0, which no sum of
// kernels can tell apart. NaN stays NaN. Two lanes at a time with SSE2 (baseline x86-64); the
// scalar path is the same sequence of IEEE operations, so both give the same bits (no FMA: the
// project builds for baseline x86-64, where the compiler cannot contract a * b + c).
//
// plane_kernels: exp(-r^2 / s^2) of the residuals r = (p - c) . n of points held as three
// coordinate arrays, r summed in Eigen's order for a Vector3d dot, ((dx nx + dy ny) + dz nz), so
// the kernels are those of the per-point Eigen code bit for bit. Four lanes at a time with AVX2
// where the CPU has it (checked once at run time; still no FMA, so the same bits), else the
// scalar residuals and the SSE2 exp above.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define NHNET_HAVE_AVX2_LANES 1
#endif

namespace nhnet::detail {

namespace fast_exp_constants {
constexpr double kLog2e = 1.4426950408889634;
constexpr double kShifter = 6755399441055744.0;  // 1.5 * 2^52: x + kShifter rounds x to an integer
constexpr double kLn2Hi = 6.93145751953125e-1;   // ln 2 = kLn2Hi + kLn2Lo, kLn2Hi exact in 11 bits
constexpr double kLn2Lo = 1.42860682030941723212e-6;
constexpr double kLowest = -708.0;
// 1 / n! for n = 11 .. 2 (Horner from the top)
constexpr double kC[10] = {1.0 / 39916800, 1.0 / 3628800, 1.0 / 362880, 1.0 / 40320, 1.0 / 5040,
                           1.0 / 720,      1.0 / 120,     1.0 / 24,     1.0 / 6,     0.5};
}  // namespace fast_exp_constants

/// exp of one argument x <= 0 (see the file comment); same bits as exp_nonpositive's lanes.
inline double exp_nonpositive(double x) {
  namespace c = fast_exp_constants;
  x = c::kLowest < x ? x : (x != x ? x : c::kLowest);  // clamp, NaN kept
  double kd = x * c::kLog2e + c::kShifter;
  uint64_t bits;
  std::memcpy(&bits, &kd, sizeof bits);
  kd = kd - c::kShifter;
  const double r = (x - kd * c::kLn2Hi) - kd * c::kLn2Lo;
  double p = c::kC[0];
  for (int i = 1; i < 10; ++i) p = p * r + c::kC[i];
  p = (p * r + 1.0) * r + 1.0;
  const uint64_t sbits = (bits + 1023u) << 52;
  double scale;
  std::memcpy(&scale, &sbits, sizeof scale);
  return p * scale;
}

/// y[i] = exp(x[i]) for i < n, every x[i] <= 0 (see the file comment). x and y may alias.
inline void exp_nonpositive(const double* x, double* y, size_t n) {
  size_t i = 0;
#if defined(__SSE2__)
  namespace c = fast_exp_constants;
  const __m128d lowest = _mm_set1_pd(c::kLowest), log2e = _mm_set1_pd(c::kLog2e),
                shifter = _mm_set1_pd(c::kShifter), ln2hi = _mm_set1_pd(c::kLn2Hi),
                ln2lo = _mm_set1_pd(c::kLn2Lo), one = _mm_set1_pd(1.0);
  const __m128i bias = _mm_set1_epi64x(1023);
  for (; i + 2 <= n; i += 2) {
    __m128d v = _mm_loadu_pd(x + i);
    // max(lowest, v) returns v when v is NaN, as the scalar path keeps NaN.
    v = _mm_max_pd(lowest, v);
    __m128d kd = _mm_add_pd(_mm_mul_pd(v, log2e), shifter);
    const __m128i bits = _mm_castpd_si128(kd);
    kd = _mm_sub_pd(kd, shifter);
    const __m128d r = _mm_sub_pd(_mm_sub_pd(v, _mm_mul_pd(kd, ln2hi)), _mm_mul_pd(kd, ln2lo));
    __m128d p = _mm_set1_pd(c::kC[0]);
    for (int t = 1; t < 10; ++t) p = _mm_add_pd(_mm_mul_pd(p, r), _mm_set1_pd(c::kC[t]));
    p = _mm_add_pd(_mm_mul_pd(_mm_add_pd(_mm_mul_pd(p, r), one), r), one);
    const __m128d scale = _mm_castsi128_pd(_mm_slli_epi64(_mm_add_epi64(bits, bias), 52));
    _mm_storeu_pd(y + i, _mm_mul_pd(p, scale));
  }
#endif
  for (; i < n; ++i) y[i] = exp_nonpositive(x[i]);
}

/// Plane residuals' Gaussian kernels (see the file comment), one lane per point: out[t] =
/// exp(-r_t^2 inv_s2), r_t = (p_t - c) . n, p_t = (x[t], y[t], z[t]). Portable path.
inline void plane_kernels_baseline(const double* x, const double* y, const double* z, size_t m,
                                   const double* c, const double* n, double inv_s2, double* out) {
  for (size_t t = 0; t < m; ++t) {
    const double r = ((x[t] - c[0]) * n[0] + (y[t] - c[1]) * n[1]) + (z[t] - c[2]) * n[2];
    out[t] = -r * r * inv_s2;
  }
  exp_nonpositive(out, out, m);
}

#if defined(NHNET_HAVE_AVX2_LANES)
/// exp_nonpositive of four lanes v (same IEEE operations per lane as the scalar path, no FMA);
/// only for a CPU with AVX2 (has_avx2()).
__attribute__((target("avx2"))) inline __m256d exp_lanes_avx2(__m256d v) {
  namespace k = fast_exp_constants;
  const __m256d log2e = _mm256_set1_pd(k::kLog2e), shifter = _mm256_set1_pd(k::kShifter),
                ln2hi = _mm256_set1_pd(k::kLn2Hi), ln2lo = _mm256_set1_pd(k::kLn2Lo),
                one = _mm256_set1_pd(1.0);
  // max(lowest, v) returns v when v is NaN, as the scalar path keeps NaN.
  v = _mm256_max_pd(_mm256_set1_pd(k::kLowest), v);
  __m256d kd = _mm256_add_pd(_mm256_mul_pd(v, log2e), shifter);
  const __m256i bits = _mm256_castpd_si256(kd);
  kd = _mm256_sub_pd(kd, shifter);
  const __m256d e =
      _mm256_sub_pd(_mm256_sub_pd(v, _mm256_mul_pd(kd, ln2hi)), _mm256_mul_pd(kd, ln2lo));
  __m256d p = _mm256_set1_pd(k::kC[0]);
  for (int i = 1; i < 10; ++i) p = _mm256_add_pd(_mm256_mul_pd(p, e), _mm256_set1_pd(k::kC[i]));
  p = _mm256_add_pd(_mm256_mul_pd(_mm256_add_pd(_mm256_mul_pd(p, e), one), e), one);
  const __m256i bias = _mm256_set1_epi64x(1023);
  return _mm256_mul_pd(p, _mm256_castsi256_pd(_mm256_slli_epi64(_mm256_add_epi64(bits, bias), 52)));
}

/// exp_nonpositive(x, y, n) four lanes at a time (same bits); only for a CPU with AVX2.
__attribute__((target("avx2"))) inline void exp_nonpositive_avx2(const double* x, double* y,
                                                                 size_t n) {
  size_t i = 0;
  for (; i + 4 <= n; i += 4) _mm256_storeu_pd(y + i, exp_lanes_avx2(_mm256_loadu_pd(x + i)));
  exp_nonpositive(x + i, y + i, n - i);
}

/// plane_kernels_baseline four lanes at a time (same IEEE operations per lane, no FMA); only
/// for a CPU with AVX2 (has_avx2()).
__attribute__((target("avx2"))) inline void plane_kernels_avx2(const double* x, const double* y,
                                                               const double* z, size_t m,
                                                               const double* c, const double* n,
                                                               double inv_s2, double* out) {
  const __m256d cx = _mm256_set1_pd(c[0]), cy = _mm256_set1_pd(c[1]), cz = _mm256_set1_pd(c[2]);
  const __m256d nx = _mm256_set1_pd(n[0]), ny = _mm256_set1_pd(n[1]), nz = _mm256_set1_pd(n[2]);
  const __m256d neg_inv = _mm256_set1_pd(-inv_s2);
  size_t t = 0;
  for (; t + 4 <= m; t += 4) {
    const __m256d r =
        _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(_mm256_sub_pd(_mm256_loadu_pd(x + t), cx), nx),
                                    _mm256_mul_pd(_mm256_sub_pd(_mm256_loadu_pd(y + t), cy), ny)),
                      _mm256_mul_pd(_mm256_sub_pd(_mm256_loadu_pd(z + t), cz), nz));
    // -r * r * inv_s2 == (r * r) * -inv_s2 exactly (rounding is symmetric in the sign).
    _mm256_storeu_pd(out + t, exp_lanes_avx2(_mm256_mul_pd(_mm256_mul_pd(r, r), neg_inv)));
  }
  plane_kernels_baseline(x + t, y + t, z + t, m - t, c, n, inv_s2, out + t);
}
#endif

/// Whether plane_kernels can take the AVX2 lanes (the CPU's answer, asked once).
inline bool has_avx2() {
#if defined(NHNET_HAVE_AVX2_LANES)
  static const bool yes = __builtin_cpu_supports("avx2");
  return yes;
#else
  return false;
#endif
}

/// exp_nonpositive(x, y, n), four lanes at a time where the CPU has AVX2 (same bits).
inline void exp_nonpositive_batch(const double* x, double* y, size_t n) {
#if defined(NHNET_HAVE_AVX2_LANES)
  if (has_avx2()) return exp_nonpositive_avx2(x, y, n);
#endif
  exp_nonpositive(x, y, n);
}

/// y[i] = tanh(x[i]) for i < n (x and y distinct): (1 - e) / (1 + e) with e = exp(-2 |x|) from
/// exp_nonpositive_batch, the sign of x put back. e's relative error (< 1e-14) bounds the
/// absolute error by 1e-14 (the candidate mix's hidden units, where libm's tanh was most of the
/// time); NaN stays NaN, +-inf give +-1.
inline void tanh_batch(const double* x, double* y, size_t n) {
  for (size_t i = 0; i < n; ++i) y[i] = -2.0 * std::abs(x[i]);
  exp_nonpositive_batch(y, y, n);
  for (size_t i = 0; i < n; ++i) y[i] = std::copysign((1.0 - y[i]) / (1.0 + y[i]), x[i]);
}

/// log(1 + t) for t in [0, 1]: 2 atanh(s) with s = t / (2 + t) in [0, 1/3] (no cancellation:
/// 1 + t is never formed), its odd series to s^21; truncation below 2e-12 relative, rounding
/// ~1e-15. Plain arithmetic (the compiler vectorises a loop of it), the same on every machine.
inline double log1p_unit(double t) {
  const double s = t / (2.0 + t), s2 = s * s;
  double p = 1.0 / 21;
  for (int k = 19; k >= 1; k -= 2) p = p * s2 + 1.0 / k;
  return 2.0 * s * p;
}

/// y[i] = softplus(x[i]) = log(1 + exp(x[i])) for i < n, as max(x, 0) + log1p(exp(-|x|)):
/// exp from exp_nonpositive_batch, the log from log1p_unit; relative error below 1e-11 against
/// libm (tests/core/test_fast_math.cpp). NaN stays NaN, +inf gives +inf, -inf ~3e-308. x and y
/// may alias. (The learned fit's member weights, where libm's expf and log1pf were ~40 % of the
/// member network's time.)
inline void softplus_batch(const double* x, double* y, size_t n) {
  thread_local std::vector<double> t;
  t.resize(n);
  for (size_t i = 0; i < n; ++i) t[i] = -std::abs(x[i]);
  exp_nonpositive_batch(t.data(), t.data(), n);
  for (size_t i = 0; i < n; ++i) y[i] = std::max(x[i], 0.0) + log1p_unit(t[i]);
}

/// plane_kernels_baseline, four lanes at a time where the CPU has AVX2 (same bits).
inline void plane_kernels(const double* x, const double* y, const double* z, size_t m,
                          const double* c, const double* n, double inv_s2, double* out) {
#if defined(NHNET_HAVE_AVX2_LANES)
  if (has_avx2()) return plane_kernels_avx2(x, y, z, m, c, n, inv_s2, out);
#endif
  plane_kernels_baseline(x, y, z, m, c, n, inv_s2, out);
}

/// Smallest eigenvalue's unit eigenvector of a symmetric positive semi-definite 3 x 3 matrix `a`
/// (a 3x3 covariance). False when `a` is not finite or zero, or when its middle eigenvalue is
/// not above `rel_tol` x its largest (the points are collinear: no plane), or when the smallest
/// eigenvalue is double (no unique normal). The smallest root of the characteristic polynomial
/// g(l) = det(l I - a) is found by Newton's method from l = 0: g is increasing and concave below
/// its smallest root, so the iterates rise monotonically to it (quadratically for a simple root);
/// the eigenvector is the largest cross product of two rows of a - l I. Replaces Eigen's
/// computeDirect (atan2, sin, cos for all three roots) where only the normal is needed.
inline bool smallest_eigenvector(const Eigen::Matrix3d& a_in, double rel_tol, Eigen::Vector3d& n) {
  const double scale = a_in.cwiseAbs().maxCoeff();
  if (!(scale > 0) || !std::isfinite(scale)) return false;
  const Eigen::Matrix3d a = a_in / scale;
  const double c2 = a.trace();
  const double c1 = a(0, 0) * a(1, 1) - a(0, 1) * a(1, 0) + a(0, 0) * a(2, 2) - a(0, 2) * a(2, 0) +
                    a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1);
  const double c0 = a.determinant();
  double l = 0;
  for (int it = 0; it < 200; ++it) {
    const double g = ((l - c2) * l + c1) * l - c0;
    const double dg = (3 * l - 2 * c2) * l + c1;
    if (!(dg > 0) || !(g < 0)) break;
    const double next = l - g / dg;
    if (!(next > l)) break;
    const bool done = next - l <= 1e-15 * c2;
    l = next;
    if (done) break;
  }
  // The other two eigenvalues: their sum and product from the polynomial's coefficients.
  const double p = c2 - l, q = c1 - l * p;
  const double big = 0.5 * (p + std::sqrt(std::max(p * p - 4 * q, 0.0)));
  const double mid = big > 0 ? q / big : 0;
  if (!(mid > rel_tol * big)) return false;
  const Eigen::Matrix3d m = a - l * Eigen::Matrix3d::Identity();
  const Eigen::Vector3d r0 = m.row(0).transpose(), r1 = m.row(1).transpose(),
                        r2 = m.row(2).transpose();
  const Eigen::Vector3d x01 = r0.cross(r1), x02 = r0.cross(r2), x12 = r1.cross(r2);
  const double d01 = x01.squaredNorm(), d02 = x02.squaredNorm(), d12 = x12.squaredNorm();
  const Eigen::Vector3d& best = d01 >= d02 ? (d01 >= d12 ? x01 : x12) : (d02 >= d12 ? x02 : x12);
  const double bn = std::max(d01, std::max(d02, d12));
  // The cross products of m's rows are the columns of its adjugate, (mid - l)(big - l) v v^T
  // (v: the eigenvector), so the largest has squared norm >= ((mid - l)(big - l))^2 / 3; rounding
  // makes them ~1e-16 (a is scaled to 1). Below 1e-24 the smallest eigenvalue is (nearly) double.
  if (!(bn > 1e-24)) return false;
  n = best / std::sqrt(bn);
  return true;
}

}  // namespace nhnet::detail
