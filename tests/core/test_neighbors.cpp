// kd-tree: kNN matches brute force, self first even with duplicates, far-from-origin clouds.
#include "fixtures.hpp"

#include "knn_heap.hpp"
#include "nhnet/neighbors.hpp"

#include <gtest/gtest.h>
#include <nanoflann.hpp>

#include <algorithm>
#include <random>
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

// The heap result set must give exactly what nanoflann's KNNResultSet gives for the same stream
// of candidates, tie order included (MFPS and the descriptors take prefixes of the rows, so an
// order change would change results). Distances drawn from a few values force many ties; the
// tree only offers a candidate below the worst distance it read at the start of a leaf, so the
// stream is filtered the same way with a stale bound.
TEST(Neighbors, HeapResultSetEqualsNanoflannsIncludingTies) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 300; ++trial) {
    const size_t k = 1 + rng() % 130;
    const int values = 1 + int(rng() % 40);
    nanoflann::KNNResultSet<float, uint32_t> ref(k);
    std::vector<uint32_t> ri(k);
    std::vector<float> rd(k);
    ref.init(ri.data(), rd.data());
    detail::KnnHeap<float, uint32_t> heap;
    heap.reset(k);
    const int stream = int(k) + int(rng() % 600);
    float bound_ref = ref.worstDist(), bound_heap = heap.worstDist();
    for (int c = 0; c < stream; ++c) {
      if (c % 10 == 0) {  // a new leaf: the tree re-reads the bound
        bound_ref = ref.worstDist();
        bound_heap = heap.worstDist();
        ASSERT_EQ(bound_ref, bound_heap) << "trial " << trial;
      }
      const float d = float(rng() % uint32_t(values));
      const uint32_t id = uint32_t(c * 3 + 1);
      if (d < bound_ref) ref.addPoint(d, id);
      if (d < bound_heap) heap.addPoint(d, id);
    }
    ASSERT_EQ(ref.size(), heap.size());
    std::vector<uint32_t> hi(heap.size());
    std::vector<float> hd(heap.size());
    heap.finish(hi.data(), hd.data());
    for (size_t j = 0; j < heap.size(); ++j) {
      ASSERT_EQ(ri[j], hi[j]) << "trial " << trial << " rank " << j;
      ASSERT_EQ(rd[j], hd[j]) << "trial " << trial << " rank " << j;
    }
  }
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
