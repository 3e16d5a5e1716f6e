// Internal: one dense layer of 16 outputs over many rows, in float, for the learned fit's member
// network (learned_fit.cpp): out[r][c] = act(sum_k in[r][k] w[k][c] + bias[r / group][c]), the
// sum over k in order from 0, each term a product then an add (no FMA). Eight lanes at a time
// with AVX2 where the CPU has it (util/fast_math.hpp's has_avx2()), four rows together so that
// the adds of one row do not wait on each other; else plain loops. Both paths do the same IEEE
// operations on every output, so they give the same bits. (Eigen's general product on the
// baseline x86-64 build, four lanes, was ~80 % of the learned fit's time.)
#pragma once

#include "util/fast_math.hpp"

#include <algorithm>
#include <cstddef>

namespace nhnet::detail {

/// Outputs of a dense_rows layer.
constexpr int kDenseWidth = 16;

/// One row of dense_rows, plain loops: the reference arithmetic.
inline void dense_row(const float* in, int width, const float* w, const float* bias, bool relu,
                      float* out) {
  float acc[kDenseWidth] = {};
  for (int k = 0; k < width; ++k) {
    const float a = in[k];
    for (int c = 0; c < kDenseWidth; ++c) acc[c] += a * w[k * kDenseWidth + c];
  }
  for (int c = 0; c < kDenseWidth; ++c) {
    const float v = acc[c] + bias[c];
    out[c] = relu ? std::max(v, 0.0f) : v;
  }
}

#if defined(NHNET_HAVE_AVX2_LANES)
/// Rows [r, r + 4) of dense_rows with AVX2 (`stride` floats from one input row to the next):
/// the same operations per output as dense_row.
__attribute__((target("avx2"))) inline void dense_rows4_avx2(const float* in, size_t stride,
                                                             int width, const float* w,
                                                             const float* bias, bool relu,
                                                             float* out) {
  __m256 acc[4][2];
  for (auto& row : acc) row[0] = row[1] = _mm256_setzero_ps();
  for (int k = 0; k < width; ++k) {
    const __m256 w0 = _mm256_loadu_ps(w + k * kDenseWidth);
    const __m256 w1 = _mm256_loadu_ps(w + k * kDenseWidth + 8);
    for (int i = 0; i < 4; ++i) {
      const __m256 a = _mm256_set1_ps(in[size_t(i) * stride + size_t(k)]);
      acc[i][0] = _mm256_add_ps(acc[i][0], _mm256_mul_ps(a, w0));
      acc[i][1] = _mm256_add_ps(acc[i][1], _mm256_mul_ps(a, w1));
    }
  }
  const __m256 b0 = _mm256_loadu_ps(bias), b1 = _mm256_loadu_ps(bias + 8);
  const __m256 zero = _mm256_setzero_ps();
  for (int i = 0; i < 4; ++i) {
    __m256 v0 = _mm256_add_ps(acc[i][0], b0), v1 = _mm256_add_ps(acc[i][1], b1);
    if (relu) {  // std::max(v, 0.0f) as dense_row: 0 > v ? 0 : v (NaN and -0 kept)
      v0 = _mm256_max_ps(zero, v0);
      v1 = _mm256_max_ps(zero, v1);
    }
    _mm256_storeu_ps(out + i * kDenseWidth, v0);
    _mm256_storeu_ps(out + i * kDenseWidth + 8, v1);
  }
}
#endif

/// The layer over `rows` rows of `in` (row-major, `width` floats used of `stride` a row) into
/// `out` (row-major, kDenseWidth a row); w is width x kDenseWidth (k-major: the transpose of
/// torch's weight), `bias` one row of kDenseWidth per `group` rows (group = rows: one bias for
/// all); relu or none.
inline void dense_rows(const float* in, size_t stride, size_t rows, int width, const float* w,
                       const float* bias, size_t group, bool relu, float* out) {
  const auto row = [&](size_t r) {
    dense_row(in + r * stride, width, w, bias + (r / group) * kDenseWidth, relu,
              out + r * kDenseWidth);
  };
  size_t r = 0;
#if defined(NHNET_HAVE_AVX2_LANES)
  if (has_avx2())
    for (; r + 4 <= rows; r += 4) {
      if (r / group != (r + 3) / group) {  // a bias change inside the four: row by row
        for (size_t i = r; i < r + 4; ++i) row(i);
        continue;
      }
      dense_rows4_avx2(in + r * stride, stride, width, w, bias + (r / group) * kDenseWidth, relu,
                       out + r * kDenseWidth);
    }
#endif
  for (; r < rows; ++r) row(r);
}

}  // namespace nhnet::detail
