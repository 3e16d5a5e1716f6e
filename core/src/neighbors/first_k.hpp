// Internal: the first k of a radius search's hits by (squared distance, given order), for the
// neighbour searches of neighbors.cpp and leaf_batch.cpp.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace nhnet::detail {

/// A counting sort on the distance into buckets over [0, r2) (the items in their given order,
/// so each bucket keeps it), only the buckets that hold the k nearest, then a stable insertion
/// sort on the distance alone, which only has to order each bucket's few items. The bucket is
/// a non-decreasing function of the distance, so equal distances share a bucket and keep their
/// given order: the same order as sorting on the pair, in O(items + buckets) instead of a
/// selection and a sort of k (which dominated the search at k = 250 in a perf profile).
class FirstK {
 public:
  /// Buckets for n items: four each, within [64, 16384]. (One each left ~1 item a bucket, and
  /// the insertion sort's compares within a bucket mispredicted; four: 8 % less k-NN time at
  /// k = 375, eight: more, the buckets' scan then costs more than the compares saved.)
  static int bucket_count(size_t n) { return std::max(64, int(std::min<size_t>(4 * n, 16384))); }
  /// Orders the items t < n (squared distance dist[t], every one below r2): afterwards the
  /// first kk by (distance, t) lead, followed by every other item as far as the kk-th one's
  /// distance. False when n < kk. The callers keep only the items below r2 beforehand: an
  /// item outside would add one to the same counter as the previous one, and the chain of
  /// such increments was a quarter of the selection's time.
  bool sort(const float* dist, size_t n, float r2, int kk) {
    if (n < size_t(kk) || kk < 1) return false;
    const int buckets = bucket_count(n);
    const float scale = float(buckets) / r2;
    bucket_.resize(n);
    for (size_t t = 0; t < n; ++t) bucket_[t] = std::min(int(dist[t] * scale), buckets - 1);
    count_.assign(size_t(buckets) + 1, 0);
    for (size_t t = 0; t < n; ++t) ++count_[size_t(bucket_[t]) + 1];
    // Buckets [0, last] hold the k nearest; their items go to order_ at their bucket's start.
    int last = 0;
    for (;; ++last) {
      count_[size_t(last) + 1] += count_[size_t(last)];
      if (count_[size_t(last) + 1] >= uint32_t(kk)) break;
    }
    order_.resize(count_[size_t(last) + 1]);
    for (size_t t = 0; t < n; ++t)
      if (bucket_[t] <= last) order_[count_[size_t(bucket_[t])]++] = uint32_t(t);
    for (size_t j = 1; j < order_.size(); ++j) {  // stable: strict < on the distance
      const uint32_t t = order_[j];
      const float d = dist[t];
      size_t i = j;
      for (; i > 0 && d < dist[order_[i - 1]]; --i) order_[i] = order_[i - 1];
      order_[i] = t;
    }
    return true;
  }

  /// Reorders each run of equal distances that reaches into the first kk by before(s, t) on
  /// the items, for items given in another order than the one ties must follow.
  template <class Before>
  void order_ties(const float* dist, int kk, Before&& before) {
    for (size_t j = 0; j < size_t(kk);) {
      size_t e = j + 1;
      while (e < order_.size() && dist[order_[e]] == dist[order_[j]]) ++e;
      if (e - j > 1)
        std::sort(order_.begin() + std::ptrdiff_t(j), order_.begin() + std::ptrdiff_t(e), before);
      j = e;
    }
  }

  /// The j-th item after sort().
  uint32_t operator[](size_t j) const { return order_[j]; }

 private:
  std::vector<int> bucket_;
  std::vector<uint32_t> count_;
  std::vector<uint32_t> order_;
};

}  // namespace nhnet::detail
