// Internal: a fixed-size subset of a large neighbourhood, spread over its distance ranks (issue
// 23: the cost per point must not grow with the noise-driven k). Means over the subset estimate
// the whole neighbourhood's without bias, and its reach stays the whole neighbourhood's.
#pragma once

#include <cstdint>

namespace nhnet::detail {

/// How many of a neighbourhood's `k` members a stage uses when it takes at most `cap` of them
/// (cap < 2 or cap >= k: all of them).
inline int spread_count(int k, int cap) { return cap >= 2 && cap < k ? cap : k; }

/// Distance rank of the t-th of m members spread evenly over ranks 0 (the centre) to k - 1
/// (the farthest), rounded to the nearest; rank t itself when m == k.
inline int spread_rank(int t, int m, int k) {
  return m >= k || m < 2 ? t : int((int64_t(t) * (k - 1) + (m - 1) / 2) / (m - 1));
}

}  // namespace nhnet::detail
