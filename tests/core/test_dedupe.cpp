// neighbors/dedupe.hpp: the estimator's canonical point order (the MST uses it for copies only).
// Exact copies collapse to their first row; the kept positions come in Morton order (near points
// near in memory, whatever the input order), the same positions in the same order for any
// permutation of the input.
#include "neighbors/dedupe.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>
#include <vector>

using nhnet::Points;
using nhnet::detail::dedupe_exact;

namespace {

/// A shuffled 30^3 grid with every 7th point written twice (rows of the copies at the end).
Points grid_with_copies(unsigned seed) {
  const int side = 30, n = side * side * side, copies = n / 7;
  std::vector<int> perm(static_cast<size_t>(n));
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), std::mt19937(seed));
  Points p(n + copies, 3);
  for (int i = 0; i < n; ++i) {
    const int c = perm[size_t(i)];
    p.row(i) << c % side, (c / side) % side, c / (side * side);
  }
  for (int j = 0; j < copies; ++j) p.row(n + j) = p.row(7 * j);
  return p;
}

std::vector<int64_t> all_rows(const Points& p) {
  std::vector<int64_t> rows(size_t(p.rows()));
  std::iota(rows.begin(), rows.end(), int64_t(0));
  return rows;
}

}  // namespace

TEST(Dedupe, CopiesGoToTheirFirstRow) {
  const Points p = grid_with_copies(1);
  std::vector<int64_t> rows = all_rows(p);
  const std::vector<int64_t> first = dedupe_exact(p, rows);
  const int64_t n = 27000;
  EXPECT_EQ(rows.size(), size_t(n));
  for (int64_t r : rows) EXPECT_LT(r, n);  // the later copy is never kept
  for (int64_t j = 0; j < p.rows() - n; ++j) EXPECT_EQ(first[size_t(n + j)], 7 * j);
  for (int64_t i = 0; i < n; ++i) EXPECT_EQ(first[size_t(i)], i);
}

// The kept points in blocks of 64 (a cache's worth of rows): along the Z-curve a block is a small
// box of the grid, its largest side 7.1 spacings on average here (the curve's cells are not the
// grid's, so some blocks straddle a cell boundary); in lexicographic (x, y, z) order, the order
// before, a block is two rows of 30 points, 29 spacings long. Bound 12: between the two. The
// same positions come in the same order for two shuffles of the input.
TEST(Dedupe, KeptPointsFollowAMortonCurveWhateverTheInputOrder) {
  const Points a = grid_with_copies(1), b = grid_with_copies(2);
  std::vector<int64_t> ra = all_rows(a), rb = all_rows(b);
  dedupe_exact(a, ra);
  dedupe_exact(b, rb);
  ASSERT_EQ(ra.size(), rb.size());
  for (size_t i = 0; i < ra.size(); ++i) ASSERT_EQ(a.row(ra[i]), b.row(rb[i])) << "position " << i;
  double side = 0;
  int blocks = 0;
  for (size_t i = 0; i + 64 <= ra.size(); i += 64, ++blocks) {
    Eigen::RowVector3d lo = a.row(ra[i]), hi = lo;
    for (size_t j = i; j < i + 64; ++j) {
      lo = lo.cwiseMin(a.row(ra[j]));
      hi = hi.cwiseMax(a.row(ra[j]));
    }
    side += (hi - lo).maxCoeff();
  }
  EXPECT_LT(side / blocks, 12.0);
}
