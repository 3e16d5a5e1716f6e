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

/// Rows of `points` sorted by the Morton code of their cell in a 1024^3 grid over the finite
/// points' bounding box (ties and non-finite rows by row, the latter last).
inline std::vector<int64_t> spatial_order(const Points& points) {
  const Eigen::Index n = points.rows();
  Eigen::RowVector3d lo = Eigen::RowVector3d::Constant(INFINITY), hi = -lo;
  for (Eigen::Index i = 0; i < n; ++i)
    if (points.row(i).allFinite()) {
      lo = lo.cwiseMin(points.row(i));
      hi = hi.cwiseMax(points.row(i));
    }
  const Eigen::RowVector3d scale = (1023.0 / (hi - lo).array().max(1e-300)).matrix();
  std::vector<std::pair<uint32_t, int64_t>> keys(static_cast<size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) {
    uint32_t code = UINT32_MAX;
    if (points.row(i).allFinite()) {
      const Eigen::RowVector3d c = (points.row(i) - lo).cwiseProduct(scale);
      code = spread_bits(uint32_t(c.x())) | spread_bits(uint32_t(c.y())) << 1 |
             spread_bits(uint32_t(c.z())) << 2;
    }
    keys[size_t(i)] = {code, int64_t(i)};
  }
  std::sort(keys.begin(), keys.end());
  std::vector<int64_t> order(keys.size());
  for (size_t i = 0; i < keys.size(); ++i) order[i] = keys[i].second;
  return order;
}

}  // namespace nhnet::detail
