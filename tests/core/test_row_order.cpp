// pipeline/row_order.hpp: NH-Net's stage runs on the rows along a Morton curve and hands its
// result back in input rows. Here: the permutation and its inverse on every per-point output and
// every row index a result holds; end to end, NH-Net's normals of a shuffled cloud are those of
// the cloud itself, bit for bit (the tiny test model: the path is what is checked, not the
// weights).
#include "pipeline/row_order.hpp"

#include "fixtures.hpp"
#include "nhnet/learned/nhnet_model.hpp"
#include "nhnet/pipeline/estimate.hpp"
#include "pipeline/estimator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <string>
#include <vector>

using namespace nhnet;
using nhnet::detail::permute_rows;
using nhnet::detail::restore_rows;
using nhnet::detail::row_order;

namespace {

/// A shuffled 12^3 grid.
Points shuffled_grid() {
  const int side = 12, n = side * side * side;
  std::vector<int> perm(static_cast<size_t>(n));
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), std::mt19937(4));
  Points p(n, 3);
  for (int i = 0; i < n; ++i) {
    const int c = perm[size_t(i)];
    p.row(i) << c % side, (c / side) % side, c / (side * side);
  }
  return p;
}

}  // namespace

TEST(RowOrder, PermutesAndRestoresEveryRowOutput) {
  const Points p = shuffled_grid();
  const Eigen::Index n = p.rows();
  const detail::RowOrder o = row_order(p);
  ASSERT_EQ(o.order.size(), size_t(n));
  std::vector<int64_t> sorted = o.order;
  std::sort(sorted.begin(), sorted.end());
  for (Eigen::Index i = 0; i < n; ++i) ASSERT_EQ(sorted[size_t(i)], i);  // a permutation
  const Points q = permute_rows(p, o);
  for (Eigen::Index i = 0; i < n; ++i) ASSERT_EQ(q.row(i), p.row(o.order[size_t(i)]));

  // A result on the permuted rows, each output naming the input row it belongs to.
  EstimateResult r;
  r.normals.resize(n, 3);
  r.valid.resize(size_t(n));
  r.curvature.resize(n);
  r.candidate.resize(size_t(n));
  r.neighbours.resize(n, 3);
  for (Eigen::Index i = 0; i < n; ++i) {
    const int64_t in = o.order[size_t(i)];
    r.normals.row(i) << double(in), 0, 1;
    r.valid[size_t(i)] = uint8_t(in % 2);
    r.curvature[i] = double(in);
    r.candidate[size_t(i)] = uint8_t(in % 3 == 0);
    for (int j = 0; j < 3; ++j) r.neighbours(i, j) = int32_t((i + j) % n);  // permuted rows
  }
  for (Eigen::Index i = 0; i < n; i += 5) r.mfps_blend_rows.push_back(i);  // permuted rows
  const Eigen::Index m = Eigen::Index(r.mfps_blend_rows.size());
  r.mfps_blend_features.resize(m, 2);
  r.mfps_unblended.resize(m, 3);
  for (Eigen::Index b = 0; b < m; ++b) {
    const double in = double(o.order[size_t(r.mfps_blend_rows[size_t(b)])]);
    r.mfps_blend_features.row(b) << in, -in;
    r.mfps_unblended.row(b) << 0, in, 0;
  }

  restore_rows(r, o);
  for (Eigen::Index row = 0; row < n; ++row) {
    EXPECT_EQ(r.normals(row, 0), double(row));
    EXPECT_EQ(r.valid[size_t(row)], uint8_t(row % 2));
    EXPECT_EQ(r.curvature[row], double(row));
    EXPECT_EQ(r.candidate[size_t(row)], uint8_t(row % 3 == 0));
  }
  for (Eigen::Index i = 0; i < n; ++i)  // permuted row i's neighbours, now input rows
    for (int j = 0; j < 3; ++j)
      ASSERT_EQ(r.neighbours(o.order[size_t(i)], j), o.order[size_t((i + j) % n)]);
  ASSERT_EQ(Eigen::Index(r.mfps_blend_rows.size()), m);
  for (Eigen::Index b = 0; b < m; ++b) {
    const int64_t row = r.mfps_blend_rows[size_t(b)];
    if (b > 0) {
      EXPECT_LT(r.mfps_blend_rows[size_t(b - 1)], row);  // ascending, as written
    }
    EXPECT_EQ(r.mfps_blend_features(b, 0), double(row));
    EXPECT_EQ(r.mfps_unblended(b, 1), double(row));
  }
}

TEST(RowOrder, NhNetNormalsOfAShuffledCloudAreTheCloudsOwn) {
  if (!nhnet_available()) GTEST_FAIL() << "built without libtorch (CI installs it)";
  const Points p = fixtures::cube(3000, 0.004, 11).points;
  std::vector<int64_t> perm(size_t(p.rows()));
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), std::mt19937(5));
  Points q(p.rows(), 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i) q.row(perm[size_t(i)]) = p.row(i);
  EstimateOptions o;
  o.method = Method::NhNet;
  o.model.path = std::string(NHNET_SOURCE_DIR) + "/tests/data/nhnet_tiny.pt";
  o.neighbours = 8;  // the table handed to an MST, in input rows too
  const EstimateResult a = estimate_normals(p, o), b = estimate_normals(q, o);
  ASSERT_EQ(a.failed, b.failed);
  for (Eigen::Index i = 0; i < p.rows(); ++i) {
    const Eigen::Index j = perm[size_t(i)];
    ASSERT_EQ(a.valid[size_t(i)], b.valid[size_t(j)]) << i;
    if (a.valid[size_t(i)]) {
      ASSERT_EQ(a.normals.row(i), b.normals.row(j)) << i;
    }
  }
  ASSERT_EQ(a.neighbours.rows(), p.rows());
  ASSERT_EQ(b.neighbours.rows(), p.rows());
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    for (Eigen::Index c = 0; c < a.neighbours.cols(); ++c)
      ASSERT_EQ(perm[size_t(a.neighbours(i, c))], b.neighbours(perm[size_t(i)], c)) << i;
}

// The canonical points built on the input rows, renumbered for the permuted rows, are what
// canonical_points builds on the permuted rows: the same points, tree and unit; rows and copies
// in permuted rows, each exact copy's first its lowest permuted row; non-finite rows -1.
TEST(RowOrder, PermutedPreparedIsTheCanonicalPointsOfThePermutedRows) {
  Points p = shuffled_grid();
  const Eigen::Index n = p.rows();
  for (Eigen::Index i = 0; i < n; i += 7) p.row(i) = p.row((i * 13 + 5) % n);  // exact copies
  p(3, 1) = std::numeric_limits<double>::quiet_NaN();
  const detail::RowOrder o = row_order(p);
  const Points q = permute_rows(p, o);
  std::vector<std::string> w1, w2;
  detail::Prepared prepared;
  prepared.source = p.data();
  prepared.canon = detail::canonical_points(p, w1);
  detail::permute_prepared(prepared, o, q);
  const detail::Canonical want = detail::canonical_points(q, w2);
  EXPECT_EQ(prepared.source, q.data());
  EXPECT_EQ(w1, w2);
  EXPECT_EQ(prepared.canon.rows, want.rows);
  EXPECT_EQ(prepared.canon.copies, want.copies);
  EXPECT_EQ(prepared.canon.finite_count, want.finite_count);
  EXPECT_EQ(prepared.canon.unit, want.unit);
  ASSERT_EQ(prepared.canon.pts, want.pts);
  EXPECT_LT(want.rows.size(), size_t(n) - 100);  // the copies were there to renumber
}
