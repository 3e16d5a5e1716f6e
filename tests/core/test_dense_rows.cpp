// The learned fit's dense layer (core/src/learned/dense_rows.hpp): the lanes path (AVX2 where
// this CPU has it) gives the same bits as the row-by-row reference, so the learned fit's
// normals do not depend on the CPU; groups of rows take their own bias.
#include "learned/dense_rows.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

namespace {

using nhnet::detail::dense_row;
using nhnet::detail::dense_rows;
using nhnet::detail::kDenseWidth;

std::vector<float> random_floats(size_t n, std::mt19937& rng) {
  std::normal_distribution<float> g(0.f, 1.f);
  std::vector<float> v(n);
  for (float& x : v) x = g(rng);
  return v;
}

// Every width the learned fit uses (7 features, 16 hidden, 17 with the noise), row counts that
// leave a remainder after the fours, per-group biases (64 rows a group, as the members, and 6,
// whose groups change inside a block of four), and input rows longer than the width (the pooled
// layer reads 16 of the gate input's 17).
TEST(DenseRows, SameBitsAsTheRowByRowReference) {
  std::mt19937 rng(5);
  for (int width : {7, 16, 17}) {
    for (size_t rows : {size_t(1), size_t(6), size_t(130), size_t(256)}) {
      for (size_t group : {std::min(rows, size_t(64)), std::min(rows, size_t(6))}) {
        for (size_t stride : {size_t(width), size_t(width) + 1}) {
          for (bool relu : {false, true}) {
            const size_t groups = (rows + group - 1) / group;
            const std::vector<float> in = random_floats(rows * stride, rng);
            const std::vector<float> w = random_floats(size_t(width) * kDenseWidth, rng);
            const std::vector<float> bias = random_floats(groups * kDenseWidth, rng);
            std::vector<float> out(rows * kDenseWidth), want(rows * kDenseWidth);
            dense_rows(in.data(), stride, rows, width, w.data(), bias.data(), group, relu,
                       out.data());
            for (size_t r = 0; r < rows; ++r)
              dense_row(in.data() + r * stride, width, w.data(),
                        bias.data() + (r / group) * kDenseWidth, relu,
                        want.data() + r * kDenseWidth);
            EXPECT_EQ(std::memcmp(out.data(), want.data(), out.size() * sizeof(float)), 0)
                << "width " << width << ", stride " << stride << ", " << rows << " rows, groups of "
                << group << ", relu " << relu;
          }
        }
      }
    }
  }
}

// The reference itself: a hand-computed row, and relu's max(v, 0) keeping NaN.
TEST(DenseRows, ReferenceRowIsTheAffineMapThenRelu) {
  const float in[2] = {2.f, -1.f};
  std::vector<float> w(2 * kDenseWidth, 0.f), bias(kDenseWidth, 0.f);
  for (int c = 0; c < kDenseWidth; ++c) {
    w[size_t(c)] = float(c);         // k = 0
    w[size_t(kDenseWidth + c)] = 1;  // k = 1
    bias[size_t(c)] = -3;
  }
  float out[kDenseWidth];
  dense_row(in, 2, w.data(), bias.data(), false, out);
  for (int c = 0; c < kDenseWidth; ++c) EXPECT_EQ(out[c], 2.f * float(c) - 1.f - 3.f);
  dense_row(in, 2, w.data(), bias.data(), true, out);
  EXPECT_EQ(out[0], 0.f);  // -4 -> 0
  EXPECT_EQ(out[3], 2.f);  // 6 - 4
  const float nan_in[2] = {std::numeric_limits<float>::quiet_NaN(), 0.f};
  std::vector<float> lanes(4 * kDenseWidth);
  std::vector<float> four(4 * 2, 0.f);
  four[0] = nan_in[0];
  dense_rows(four.data(), 2, 4, 2, w.data(), bias.data(), 4, true, lanes.data());
  EXPECT_TRUE(std::isnan(lanes[1]));   // NaN kept by relu, in the lanes path too
  EXPECT_EQ(lanes[kDenseWidth], 0.f);  // row 1: all zero input, bias -3 -> 0
}

}  // namespace
