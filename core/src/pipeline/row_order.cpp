// Rows along a Morton curve for a stage, its result back in input rows (row_order.hpp).
#include "pipeline/row_order.hpp"

#include "util/spatial_order.hpp"

#include <algorithm>
#include <limits>
#include <numeric>
#include <utility>

namespace nhnet::detail {

namespace {

/// Rows of `m` (one per permuted row) moved to their input rows.
template <class Matrix>
void restore_matrix_rows(Matrix& m, const std::vector<int64_t>& order) {
  if (m.rows() != Eigen::Index(order.size())) return;  // not computed
  Matrix out(m.rows(), m.cols());
  for (size_t i = 0; i < order.size(); ++i) out.row(order[i]) = m.row(Eigen::Index(i));
  m = std::move(out);
}

template <class T>
void restore_vector(std::vector<T>& v, const std::vector<int64_t>& order) {
  if (v.size() != order.size()) return;
  std::vector<T> out(v.size());
  for (size_t i = 0; i < order.size(); ++i) out[size_t(order[i])] = v[i];
  v = std::move(out);
}

/// The MFPS blend records: rows to input rows, ascending as the estimator writes them.
void restore_blend_rows(EstimateResult& res, const std::vector<int64_t>& order) {
  const size_t m = res.mfps_blend_rows.size();
  if (m == 0) return;
  std::vector<size_t> by_row(m);
  std::iota(by_row.begin(), by_row.end(), size_t(0));
  std::vector<int64_t> rows(m);
  for (size_t r = 0; r < m; ++r) rows[r] = order[size_t(res.mfps_blend_rows[r])];
  std::sort(by_row.begin(), by_row.end(), [&](size_t a, size_t b) { return rows[a] < rows[b]; });
  const Eigen::MatrixXd features = res.mfps_blend_features;
  const Normals unblended = res.mfps_unblended;
  for (size_t r = 0; r < m; ++r) {
    res.mfps_blend_rows[r] = rows[by_row[r]];
    if (features.rows() == Eigen::Index(m))
      res.mfps_blend_features.row(Eigen::Index(r)) = features.row(Eigen::Index(by_row[r]));
    if (unblended.rows() == Eigen::Index(m))
      res.mfps_unblended.row(Eigen::Index(r)) = unblended.row(Eigen::Index(by_row[r]));
  }
}

}  // namespace

RowOrder row_order(const Points& points) { return RowOrder{spatial_order(points)}; }

Points permute_rows(const Points& points, const RowOrder& o) {
  Points out(points.rows(), 3);
  for (size_t i = 0; i < o.order.size(); ++i) out.row(Eigen::Index(i)) = points.row(o.order[i]);
  return out;
}

void restore_rows(EstimateResult& res, const RowOrder& o) {
  restore_matrix_rows(res.normals, o.order);
  restore_vector(res.valid, o.order);
  restore_matrix_rows(res.curvature, o.order);
  restore_vector(res.candidate, o.order);
  restore_blend_rows(res, o.order);
  if (res.neighbours.rows() == Eigen::Index(o.order.size())) {
    for (Eigen::Index i = 0; i < res.neighbours.rows(); ++i)
      for (Eigen::Index j = 0; j < res.neighbours.cols(); ++j) {
        int32_t& v = res.neighbours(i, j);
        if (v >= 0) v = int32_t(o.order[size_t(v)]);
      }
    restore_matrix_rows(res.neighbours, o.order);
  }
}

void permute_prepared(Prepared& prepared, const RowOrder& o, const Points& permuted) {
  Canonical& c = prepared.canon;
  const size_t n = o.order.size();
  std::vector<int64_t> at(n);  // input row -> permuted row
  for (size_t i = 0; i < n; ++i) at[size_t(o.order[i])] = int64_t(i);
  // Per first copy (input row): the lowest permuted row of its copies.
  std::vector<int64_t> lowest(n, std::numeric_limits<int64_t>::max());
  for (size_t r = 0; r < n; ++r)
    if (c.copies[r] >= 0) {
      int64_t& l = lowest[size_t(c.copies[r])];
      l = std::min(l, at[r]);
    }
  for (int64_t& row : c.rows) row = lowest[size_t(row)];
  std::vector<int64_t> copies(n, -1);
  for (size_t i = 0; i < n; ++i) {
    const int64_t first = c.copies[size_t(o.order[i])];
    if (first >= 0) copies[i] = lowest[size_t(first)];
  }
  c.copies = std::move(copies);
  prepared.source = permuted.data();
}

}  // namespace nhnet::detail
