// kd-tree: kNN matches brute force, self first even with duplicates, far-from-origin clouds.
#include "fixtures.hpp"

#include "nhnet/neighbors/neighbors.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

using namespace nhnet;

TEST(Neighbors, KnnMatchesBruteForce) {
  const auto f = fixtures::sphere(2000, 4);
  Neighbors tree(f.points);
  IndexMatrix idx;
  DistanceMatrix d2;
  tree.knn_all(12, idx, &d2);
  for (int i = 0; i < 2000; i += 97) {
    std::vector<double> all;
    for (int j = 0; j < 2000; ++j) all.push_back((f.points.row(j) - f.points.row(i)).squaredNorm());
    std::sort(all.begin(), all.end());
    EXPECT_EQ(idx(i, 0), i);
    for (int t = 0; t < 12; ++t) EXPECT_NEAR(d2(i, t), all[size_t(t)], 1e-6);
  }
}

// From 48 neighbours on the search keeps its candidates in a heap (neighbors.cpp): the same
// neighbours as brute force, nearest first.
TEST(Neighbors, LargeKMatchesBruteForce) {
  const auto f = fixtures::sphere(3000, 5);
  Neighbors tree(f.points);
  IndexMatrix idx;
  DistanceMatrix d2;
  tree.knn_all(300, idx, &d2);
  for (int i = 0; i < 3000; i += 113) {
    std::vector<double> all;
    for (int j = 0; j < 3000; ++j) all.push_back((f.points.row(j) - f.points.row(i)).squaredNorm());
    std::sort(all.begin(), all.end());
    EXPECT_EQ(idx(i, 0), i);
    for (int t = 0; t < 300; ++t) EXPECT_NEAR(d2(i, t), all[size_t(t)], 1e-6);
  }
}

// On a grid nearly every distance is tied: the deep tables (searched one leaf at a time, their
// per-point fallback a heap) must break ties as nanoflann's sorted insertion does (the small-k
// table), so a deep table's first columns are the shallow table.
TEST(Neighbors, LargeKBreaksTiesLikeSmallK) {
  Points p(20 * 20 * 3, 3);
  for (int i = 0; i < p.rows(); ++i) p.row(i) << (i % 20), (i / 20) % 20, i / 400;
  Neighbors tree(p);
  IndexMatrix shallow, deep, deeper;
  tree.knn_all(20, shallow, nullptr);  // below 24: nanoflann's own result set
  tree.knn_all(48, deep, nullptr);
  tree.knn_all(150, deeper, nullptr);
  for (int i = 0; i < p.rows(); ++i)
    for (int t = 0; t < 20; ++t) {
      ASSERT_EQ(deep(i, t), shallow(i, t)) << "point " << i << " column " << t;
      ASSERT_EQ(deeper(i, t), shallow(i, t)) << "point " << i << " column " << t;
    }
}

// From 24 neighbours on knn_all searches one kd-tree leaf at a time (leaf_batch.hpp); knn_rows
// still searches point by point (a radius search, or a heap, from 48 on). Both must give the same
// table, equal distances included (a grid ties nearly every distance; their order is the one each
// query's own search visits), with exact duplicates, with density varying 100-fold, and with k
// close to the cloud's size.
void expect_same_as_rows(const Points& p, int k) {
  Neighbors tree(p);
  IndexMatrix all, rows;
  DistanceMatrix d_all, d_rows;
  tree.knn_all(k, all, &d_all, RunContext{2, {}});
  std::vector<int64_t> every(size_t(p.rows()));
  for (size_t i = 0; i < every.size(); ++i) every[i] = int64_t(i);
  tree.knn_rows(k, every, rows, &d_rows);
  ASSERT_EQ(all.cols(), rows.cols());
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    for (Eigen::Index t = 0; t < all.cols(); ++t) {
      ASSERT_EQ(all(i, t), rows(i, t)) << "k " << k << " point " << i << " column " << t;
      ASSERT_EQ(d_all(i, t), d_rows(i, t)) << "k " << k << " point " << i << " column " << t;
    }
}

TEST(Neighbors, LeafBatchMatchesPointByPoint) {
  Points grid(24 * 24 * 4, 3);
  for (int i = 0; i < grid.rows(); ++i) grid.row(i) << (i % 24), (i / 24) % 24, i / 576;
  expect_same_as_rows(grid, 30);
  expect_same_as_rows(grid, 48);
  expect_same_as_rows(grid, 200);
  Points dup(3000, 3);  // every position three times
  const auto f = fixtures::sphere(1000, 3);
  for (int i = 0; i < 3000; ++i) dup.row(i) = f.points.row(i % 1000);
  expect_same_as_rows(dup, 60);
  Points dense = fixtures::sphere(4000, 8).points;  // a cluster 100x denser
  dense.topRows(2000) *= 0.01;
  expect_same_as_rows(dense, 120);
  expect_same_as_rows(fixtures::sphere(70, 2).points, 64);
  expect_same_as_rows(fixtures::sphere(70, 2).points, 70);
}

TEST(Neighbors, SelfFirstWithExactDuplicates) {
  Points p(40, 3);
  for (int i = 0; i < 40; ++i) p.row(i) << (i % 4), 0.0, 0.0;  // each point 10 times
  Neighbors tree(p);
  IndexMatrix idx;
  tree.knn_all(5, idx, nullptr);
  for (int i = 0; i < 40; ++i) EXPECT_EQ(idx(i, 0), i);
}

TEST(Neighbors, FarFromOriginKeepsPrecision) {
  auto f = fixtures::plane(1000, 2);
  Points shifted = f.points;
  shifted.col(0).array() += 5e6;  // UTM-scale easting
  shifted.col(1).array() += 4e6;
  Neighbors a(f.points), b(shifted);
  IndexMatrix ia, ib;
  a.knn_all(8, ia, nullptr);
  b.knn_all(8, ib, nullptr);
  // Re-centring in double keeps the neighbour sets identical.
  EXPECT_EQ((ia - ib).cwiseAbs().maxCoeff(), 0);
}

TEST(Neighbors, RadiusQuery) {
  const auto f = fixtures::plane(3000, 9);
  Neighbors tree(f.points);
  std::vector<std::pair<int32_t, float>> out;
  tree.radius(Eigen::Vector3d(0, 0, 0), 0.1, out);
  int brute = 0;
  for (int j = 0; j < 3000; ++j) brute += f.points.row(j).squaredNorm() < 0.01;
  EXPECT_EQ(int(out.size()), brute);
}

// An exception thrown inside a parallel loop (here by the progress callback, which thread 0
// calls from inside the OpenMP region; std::bad_alloc from a worker takes the same path) is
// carried out of the region and rethrown on the caller, never std::terminate; the output
// table stays a valid (destructible, reusable) matrix.
TEST(Neighbors, ExceptionInsideParallelLoopReachesTheCaller) {
  const auto f = fixtures::sphere(20000, 5);
  Neighbors tree(f.points);
  IndexMatrix idx;
  tree.knn_all(4, idx, nullptr);  // non-empty before the failing call
  for (int threads : {1, 2, 4}) {
    RunContext run;
    run.threads = threads;
    run.progress = [](double fraction, const std::string&) -> bool {
      if (fraction > 0 && fraction < 1) throw std::runtime_error("callback failed");
      return true;
    };
    EXPECT_THROW(tree.knn_all(12, idx, nullptr, run), std::runtime_error) << threads;
  }
  tree.knn_all(6, idx, nullptr);
  EXPECT_EQ(idx.rows(), 20000);
  EXPECT_EQ(idx.cols(), 6);
}
