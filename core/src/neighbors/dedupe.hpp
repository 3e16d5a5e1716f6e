// Internal: exact-duplicate detection shared by the estimator (estimate.cpp) and MST orientation
// (orient.cpp), so both treat k copies of one position as one point.
#pragma once

#include "nhnet/types.hpp"
#include "util/spatial_order.hpp"

#include <algorithm>
#include <cstdint>
#include <vector>

namespace nhnet::detail {

/// Keeps in `rows` (finite row indices of `points`, ascending) only the first row of every
/// exact position, in Morton order of the positions (util/spatial_order.hpp's cells over the
/// bounding box of `rows`, ties in (x, y, z) order): the pipeline then sees the same points in
/// the same order whatever the input order, so a permuted cloud gets bit-identical normals
/// (kd-tree ties, summation order and MFPS's per-patch seeds included), and points near each
/// other sit near each other in memory, so every stage reads a neighbourhood from a few cache
/// lines. Returns, for every row of `points`, the row of its first copy (itself when unique; -1
/// for rows not in `rows`).
inline std::vector<int64_t> dedupe_exact(const Points& points, std::vector<int64_t>& rows) {
  std::vector<int64_t> first(size_t(points.rows()), -1);
  // Sorted as contiguous (cell, x, y, z, row) keys: the same order as a stable sort of the rows
  // by cell and position (ties by row, and `rows` is ascending), without the column-major
  // matrix's scattered reads in every comparison (10M points: ~3x faster).
  struct Key {
    uint32_t cell;
    double x, y, z;
    int64_t row;
  };
  const MortonGrid grid = morton_grid(points, rows);
  std::vector<Key> keys(rows.size());
  for (size_t i = 0; i < rows.size(); ++i) {
    const Eigen::RowVector3d p = points.row(rows[i]);
    keys[i] = Key{grid.code(p), p.x(), p.y(), p.z(), rows[i]};
  }
  const auto same = [](const Key& a, const Key& b) {
    return a.x == b.x && a.y == b.y && a.z == b.z;
  };
  std::sort(keys.begin(), keys.end(), [](const Key& a, const Key& b) {
    if (a.cell != b.cell) return a.cell < b.cell;
    if (a.x != b.x) return a.x < b.x;
    if (a.y != b.y) return a.y < b.y;
    if (a.z != b.z) return a.z < b.z;
    return a.row < b.row;
  });
  std::vector<int64_t> kept;
  for (size_t i = 0; i < keys.size(); ++i) {
    const bool leads = i == 0 || !same(keys[i - 1], keys[i]);
    const int64_t r = keys[i].row;
    first[size_t(r)] = leads ? r : first[size_t(keys[i - 1].row)];
    if (leads) kept.push_back(r);
  }
  rows = std::move(kept);
  return first;
}

}  // namespace nhnet::detail
