// The k-NN's own radius walk (core/src/neighbors/ball_search.hpp): the same points in the same
// order, with the same float distances, as nanoflann's radius search on the same tree. Every
// large-k table's tie order rests on that order, so it is compared with nanoflann directly
// (the Neighbors tests compare tables that both come from the walk).
#include "fixtures.hpp"

#include "neighbors/ball_search.hpp"
#include "neighbors/kdtree.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <initializer_list>
#include <memory>
#include <utility>
#include <vector>

namespace {

using nhnet::detail::Ball;
using nhnet::detail::FloatCloud;
using nhnet::detail::Tree;
using nhnet::detail::TreeShape;

/// A tree over `xyz` with its coordinates in leaf order, as Neighbors builds it.
struct LeafOrderTree {
  FloatCloud cloud;
  std::unique_ptr<Tree> tree;
  TreeShape shape;

  explicit LeafOrderTree(std::vector<float> xyz) {
    cloud.xyz = std::move(xyz);
    const size_t n = cloud.kdtree_get_point_count();
    tree = std::make_unique<Tree>(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
    tree->buildIndex();
    std::vector<float> sorted(3 * n);
    for (size_t p = 0; p < n; ++p) {
      for (size_t d = 0; d < 3; ++d) sorted[3 * p + d] = cloud.xyz[3 * tree->vAcc[p] + d];
      tree->vAcc[p] = uint32_t(p);
    }
    cloud.xyz.swap(sorted);
    shape = nhnet::detail::tree_shape(*tree, uint32_t(n));
  }
};

/// Ball::gather against nanoflann's unsorted radius search, point by point.
void expect_same_as_nanoflann(const LeafOrderTree& t, const float* centre, float r2) {
  std::vector<std::pair<uint32_t, float>> want;
  nanoflann::RadiusResultSet<float, uint32_t> set(r2, want);
  t.tree->findNeighbors(set, centre, nanoflann::SearchParams(32, 0.f, false));
  Ball ball;
  ball.gather(t.shape, t.cloud, centre, r2);
  ASSERT_EQ(ball.size(), want.size()) << "r2 " << r2;
  for (size_t j = 0; j < want.size(); ++j) {
    ASSERT_EQ(ball.pos()[j], want[j].first) << "hit " << j << ", r2 " << r2;
    ASSERT_EQ(std::memcmp(&ball.d2()[j], &want[j].second, sizeof(float)), 0) << "hit " << j;
    const float* p = &t.cloud.xyz[3 * size_t(want[j].first)];
    EXPECT_EQ(ball.x()[j], p[0]);
    EXPECT_EQ(ball.y()[j], p[1]);
    EXPECT_EQ(ball.z()[j], p[2]);
  }
}

std::vector<float> as_floats(const nhnet::Points& p) {
  std::vector<float> xyz;
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    for (int d = 0; d < 3; ++d) xyz.push_back(float(p(i, d)));
  return xyz;
}

// A sphere (no ties), a grid (points on the split planes, every distance tied), and a cloud of
// triplicated positions; radii from empty to the whole cloud; centres on points and between.
TEST(BallSearch, SamePointsInTheSameOrderAsNanoflann) {
  const nhnet::Points sphere = fixtures::sphere(3000, 7).points;
  nhnet::Points grid(12 * 12 * 5, 3);
  for (Eigen::Index i = 0; i < grid.rows(); ++i) grid.row(i) << (i % 12), (i / 12) % 12, i / 144;
  nhnet::Points dup(1500, 3);
  for (Eigen::Index i = 0; i < dup.rows(); ++i) dup.row(i) = sphere.row(i % 500);
  for (const nhnet::Points* pts :
       std::initializer_list<const nhnet::Points*>{&sphere, &grid, &dup}) {
    const LeafOrderTree t(as_floats(*pts));
    const float extent = pts == &grid ? 12.f : 1.f;
    for (size_t p = 0; p < t.cloud.kdtree_get_point_count(); p += 37) {
      const float* at = &t.cloud.xyz[3 * p];
      const float between[3] = {at[0] + 0.37f * extent / 12, at[1], at[2] - 0.11f * extent / 12};
      for (float r : {0.f, 0.05f, 0.2f, 0.6f, 3.f}) {
        const float r2 = (r * extent) * (r * extent);
        expect_same_as_nanoflann(t, at, r2);
        expect_same_as_nanoflann(t, between, r2);
      }
    }
  }
}

// Found points are counted, the columns reused: a wide search, then a narrow one, then none.
TEST(BallSearch, ReusedBallHoldsOnlyTheLastSearch) {
  const LeafOrderTree t(as_floats(fixtures::sphere(800, 3).points));
  Ball ball;
  const float* c = &t.cloud.xyz[0];
  ball.gather(t.shape, t.cloud, c, 10.f);
  EXPECT_EQ(ball.size(), size_t(800));
  ball.gather(t.shape, t.cloud, c, 0.01f);
  EXPECT_GT(ball.size(), size_t(0));
  EXPECT_LT(ball.size(), size_t(800));
  for (size_t j = 0; j < ball.size(); ++j) EXPECT_LT(ball.d2()[j], 0.01f);
  ball.gather(t.shape, t.cloud, c, 0.f);  // strictly within: not even the centre
  EXPECT_EQ(ball.size(), size_t(0));
}

}  // namespace
