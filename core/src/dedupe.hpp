// Internal: exact-duplicate detection shared by the estimator (estimate.cpp) and MST orientation
// (orient.cpp), so both treat k copies of one position as one point.
#pragma once

#include "nhnet/types.hpp"

#include <algorithm>
#include <cstdint>
#include <vector>

namespace nhnet::detail {

/// Keeps in `rows` (finite row indices of `points`, ascending) only the first row of every
/// exact position, in lexicographic (x, y, z) order of the positions: the pipeline then sees
/// the same points in the same order whatever the input order, so a permuted cloud gets
/// bit-identical normals (kd-tree ties, summation order and MFPS's per-patch seeds included).
/// Returns, for every row of `points`, the row of its first copy (itself when unique; -1 for
/// rows not in `rows`).
inline std::vector<int64_t> dedupe_exact(const Points& points, std::vector<int64_t>& rows) {
  std::vector<int64_t> first(size_t(points.rows()), -1);
  std::vector<int64_t> order = rows;
  const auto less = [&](int64_t a, int64_t b) {
    for (int d = 0; d < 3; ++d)
      if (points(a, d) != points(b, d)) return points(a, d) < points(b, d);
    return false;
  };
  std::stable_sort(order.begin(), order.end(), less);  // stable: first copy leads its group
  std::vector<int64_t> kept;
  for (size_t i = 0; i < order.size(); ++i) {
    const bool leads = i == 0 || less(order[i - 1], order[i]);
    first[size_t(order[i])] = leads ? order[i] : first[size_t(order[i - 1])];
    if (leads) kept.push_back(order[i]);
  }
  rows = std::move(kept);
  return first;
}

}  // namespace nhnet::detail
