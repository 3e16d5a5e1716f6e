// Internal: an order of a cloud's rows along a Morton (Z-order) curve. A stage that reads each
// point's neighbours through a table in input rows reads them from scattered memory when the
// input is shuffled (a sampled mesh, a merged file); taking the points in this order, the points
// of one block share most of their neighbours and read them from a few cache lines. Only the
// order of the work changes, never a point's result.
#pragma once

#include "nhnet/types.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

namespace nhnet::detail {

/// The 10 bits of v spread to every third bit (bit i to bit 3i).
inline uint32_t spread_bits(uint32_t v) {
  v &= 0x3ffu;
  v = (v | (v << 16)) & 0x030000ffu;
  v = (v | (v << 8)) & 0x0300f00fu;
  v = (v | (v << 4)) & 0x030c30c3u;
  v = (v | (v << 2)) & 0x09249249u;
  return v;
}

/// A 1024^3 grid over a bounding box and the Morton code of a point's cell in it.
struct MortonGrid {
  Eigen::RowVector3d lo, scale;
  /// The cell's code; a point outside the box (or overflowing it) goes to the nearest cell.
  uint32_t code(const Eigen::RowVector3d& p) const {
    uint32_t out = 0;
    for (int j = 0; j < 3; ++j) {
      const double c = (p[j] - lo[j]) * scale[j];  // NaN only where the box overflows
      out |= spread_bits(c > 0 ? uint32_t(std::min(c, 1023.0)) : 0u) << j;
    }
    return out;
  }
};

/// The grid over the bounding box of the finite points among `rows` of `points`.
inline MortonGrid morton_grid(const Points& points, const std::vector<int64_t>& rows) {
  Eigen::RowVector3d lo = Eigen::RowVector3d::Constant(INFINITY), hi = -lo;
  for (const int64_t i : rows)
    if (points.row(i).allFinite()) {
      lo = lo.cwiseMin(points.row(i));
      hi = hi.cwiseMax(points.row(i));
    }
  return MortonGrid{lo, (1023.0 / (hi - lo).array().max(1e-300)).matrix()};
}

/// Rows of `points` sorted by the Morton code of their cell in a 1024^3 grid over the finite
/// points' bounding box (ties and non-finite rows by row, the latter last).
inline std::vector<int64_t> spatial_order(const Points& points) {
  const Eigen::Index n = points.rows();
  std::vector<int64_t> all(static_cast<size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) all[size_t(i)] = int64_t(i);
  const MortonGrid grid = morton_grid(points, all);
  std::vector<std::pair<uint32_t, int64_t>> keys(static_cast<size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i)
    keys[size_t(i)] = {points.row(i).allFinite() ? grid.code(points.row(i)) : UINT32_MAX,
                       int64_t(i)};
  std::sort(keys.begin(), keys.end());
  std::vector<int64_t> order(keys.size());
  for (size_t i = 0; i < keys.size(); ++i) order[i] = keys[i].second;
  return order;
}

}  // namespace nhnet::detail
