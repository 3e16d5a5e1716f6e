// k-nearest result set for nanoflann's findNeighbors, kept as a binary max-heap.
// nanoflann's KNNResultSet keeps its k best sorted by insertion: every accepted point shifts up
// to k entries, which at the K = 126 of the multi-scale fitting (paper Eq. 4, K = {50,100,150}
// scaled by the noise rule) is most of the query's time. The heap accepts a point in O(log k)
// and sorts once at the end. Its output is identical to KNNResultSet's, ties included: entries
// are ordered by (distance, order of discovery), so equal distances keep the order in which the
// tree met them and, when full, a point equal to the worst is not taken (KNNResultSet's rules).
// Internal header (not installed): included by neighbors.cpp and its test only.
#pragma once

#include <algorithm>
#include <cstdint>
#include <limits>
#include <vector>

namespace nhnet::detail {

template <class Dist, class Index>
class KnnHeap {
 public:
  /// Starts a query for the `capacity` (>= 1) nearest; keeps the storage of earlier queries.
  void reset(size_t capacity) {
    capacity_ = capacity;
    heap_.clear();
    heap_.reserve(capacity);
    seq_ = 0;
  }
  size_t size() const { return heap_.size(); }
  bool full() const { return heap_.size() == capacity_; }
  /// The distance a point must beat: the k-th best so far (infinite until k were seen).
  Dist worstDist() const {
    return full() ? heap_.front().dist : std::numeric_limits<Dist>::max();
  }
  /// Called by the tree for each candidate it did not prune; returns true (search on).
  bool addPoint(Dist dist, Index index) {
    const Entry e{dist, seq_++, index};
    if (!full()) {
      heap_.push_back(e);
      std::push_heap(heap_.begin(), heap_.end(), before);
    } else if (dist < heap_.front().dist) {
      std::pop_heap(heap_.begin(), heap_.end(), before);
      heap_.back() = e;
      std::push_heap(heap_.begin(), heap_.end(), before);
    }
    return true;
  }
  /// Writes the result nearest first into indices[0, size()) and dists[0, size()); the heap
  /// is sorted in place (call reset() before the next query).
  void finish(Index* indices, Dist* dists) {
    std::sort(heap_.begin(), heap_.end(), before);
    for (size_t j = 0; j < heap_.size(); ++j) {
      indices[j] = heap_[j].index;
      dists[j] = heap_[j].dist;
    }
  }

 private:
  struct Entry {
    Dist dist;
    uint32_t seq;  // order of discovery: breaks ties as KNNResultSet's insertion does
    Index index;
  };
  static bool before(const Entry& a, const Entry& b) {
    return a.dist < b.dist || (a.dist == b.dist && a.seq < b.seq);
  }
  size_t capacity_ = 0;
  uint32_t seq_ = 0;
  std::vector<Entry> heap_;
};

}  // namespace nhnet::detail
