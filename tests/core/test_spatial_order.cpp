// util/spatial_order.hpp: the Morton order the learned fit takes its blocks in (a shuffled cloud
// then reads its members from a few cache lines; only the order of the work changes).
#include "util/spatial_order.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <vector>

using nhnet::Points;
using nhnet::detail::spatial_order;
using nhnet::detail::spread_bits;

namespace {

/// Mean distance between points taken one after the other in `order`.
double mean_step(const Points& p, const std::vector<int64_t>& order) {
  double sum = 0;
  for (size_t i = 1; i < order.size(); ++i) sum += (p.row(order[i]) - p.row(order[i - 1])).norm();
  return sum / double(order.size() - 1);
}

}  // namespace

TEST(SpatialOrder, SpreadBitsInterleaves) {
  EXPECT_EQ(spread_bits(0), 0u);
  EXPECT_EQ(spread_bits(1), 1u);
  EXPECT_EQ(spread_bits(2), 8u);
  EXPECT_EQ(spread_bits(0x3ff), 0x09249249u);  // every third bit of 30
  EXPECT_EQ(spread_bits(0x7ff), 0x09249249u);  // bits past the 10th are dropped
}

// A shuffled 40^3 grid: the order is a permutation, and consecutive points in it are near
// neighbours (a Z-curve's mean step on a grid is under 2 spacings; the shuffled input's is
// about a third of the box, ~13 spacings), whatever the input order.
TEST(SpatialOrder, ShuffledGridComesBackAlongTheCurve) {
  const int side = 40;
  Points p(side * side * side, 3);
  for (int i = 0; i < side * side * side; ++i)
    p.row(i) << i % side, (i / side) % side, i / (side * side);
  std::vector<int64_t> perm(size_t(p.rows()));
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), std::mt19937(3));
  Points q(p.rows(), 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i) q.row(i) = p.row(perm[size_t(i)]);
  const std::vector<int64_t> order = spatial_order(q);
  std::vector<int64_t> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  for (size_t i = 0; i < sorted.size(); ++i) ASSERT_EQ(sorted[i], int64_t(i));
  EXPECT_LT(mean_step(q, order), 2.0);
  EXPECT_GT(mean_step(q, perm), 10.0);
}

TEST(SpatialOrder, NonFiniteRowsComeLastAndTinyCloudsWork) {
  Points p(4, 3);
  p << 1, 1, 1, NAN, 0, 0, 0, 0, 0, 1, 1, INFINITY;
  EXPECT_EQ(spatial_order(p), (std::vector<int64_t>{2, 0, 1, 3}));
  Points one(1, 3);
  one << 5, 5, 5;  // a zero-size box
  EXPECT_EQ(spatial_order(one), std::vector<int64_t>{0});
  EXPECT_TRUE(spatial_order(Points(0, 3)).empty());
}
