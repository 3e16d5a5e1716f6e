// Internal: every point of the kd-tree within a radius of a centre, as coordinate columns: what
// nanoflann's radius search returns (the same descent, the same pruning, the same float
// distances, hence the same points in the same order), walked over the flat TreeShape and
// written straight into columns, without a result set of pairs. Serves the search one leaf at a
// time (leaf_batch.hpp) and the single large-k query (neighbors.cpp).
#pragma once

#include "neighbors/kdtree.hpp"

#include <cstdint>
#include <vector>

namespace nhnet::detail {

class Ball {
 public:
  /// The points strictly within sqrt(r2) of centre, in nanoflann's visiting order.
  void gather(const TreeShape& shape, const FloatCloud& cloud, const float* centre, float r2);
  /// How many points gather found; the columns hold at least that many.
  size_t size() const { return size_; }
  /// The points' leaf-order positions, coordinates and squared distances to the centre.
  const uint32_t* pos() const { return pos_.data(); }
  const float* x() const { return x_.data(); }
  const float* y() const { return y_.data(); }
  const float* z() const { return z_.data(); }
  const float* d2() const { return d2_.data(); }

 private:
  void descend(const TreeShape& shape, const FloatCloud& cloud, int32_t id, float mindist,
               float* dists, const float* centre, float r2);
  void add_leaf(const FloatCloud& cloud, uint32_t a, uint32_t b, const float* centre, float r2);

  size_t size_ = 0;
  std::vector<uint32_t> pos_;
  std::vector<float> x_, y_, z_, d2_;
};

}  // namespace nhnet::detail
