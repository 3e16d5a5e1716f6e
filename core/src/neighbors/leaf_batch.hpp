// Internal: the k nearest neighbours of all the points of one kd-tree leaf from one radius
// search around the leaf (knn_all at large k). The points of a leaf are a few spacings apart and
// share most of their neighbours, so one tree descent serves them all: every point within the
// guessed k-th distance R of a query lies within R + rho of the leaf's centre (rho: the leaf's
// radius), and each query then takes its first k from those candidates by (distance, visit) -
// exactly what a search per point returns, equal distances included (their order is the one
// the query's own search would visit them in, kdtree.hpp's visits_before).
#pragma once

#include "neighbors/ball_search.hpp"
#include "neighbors/first_k.hpp"
#include "neighbors/kdtree.hpp"

#include <cstdint>
#include <vector>

namespace nhnet::detail {

class LeafBatch {
 public:
  /// The guess of the next leaf's k-th distance: this x the largest k-th distance just found.
  static constexpr float kNextGuess = 1.1f;
  /// The kk nearest of each point of one leaf (positions [a, b)), nearest first. `radius` is the
  /// guess of the k-th distance (> 0), widened while some query has fewer than kk points
  /// within it, and on success set to the guess for the next leaf. False when a few widenings
  /// did not reach kk points for every query (the caller then searches point by point).
  bool run(const FloatCloud& cloud, const TreeShape& shape, uint32_t a, uint32_t b, int kk,
           float& radius);
  /// Query t's (t-th point of the leaf) neighbours' positions and squared distances, kk each.
  const uint32_t* indices(size_t t) const { return idx_.data() + t * size_t(kk_); }
  const float* distances(size_t t) const { return d2_.data() + t * size_t(kk_); }

 private:
  bool select(const TreeShape& shape, const float* q, float r2, float bound2, size_t t);
  size_t keep_below(float lim);

  int kk_ = 0;
  Ball ball_;                   // the candidates: every point within reach of the leaf
  std::vector<float> dist_;     // each candidate's distance to the query
  std::vector<uint32_t> near_;  // the candidates below a bound (keep_below)
  std::vector<float> near_d_;   // and their distances
  FirstK order_;
  std::vector<uint32_t> idx_;
  std::vector<float> d2_;
};

}  // namespace nhnet::detail
