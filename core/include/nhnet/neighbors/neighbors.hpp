// One kd-tree per cloud, built once and shared by every stage (kNN at several K, radius
// queries). The tree implementation (nanoflann) sits behind a PImpl.
#pragma once

#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

#include <memory>
#include <utility>
#include <vector>

namespace nhnet {

class Neighbors {
 public:
  /// Builds the tree over `points` (N x 3, all rows finite). Coordinates are re-centred in double
  /// before being stored as float, so clouds far from the origin keep their precision.
  explicit Neighbors(const Points& points);
  ~Neighbors();
  Neighbors(Neighbors&&) noexcept;
  Neighbors& operator=(Neighbors&&) noexcept;
  Neighbors(const Neighbors&) = delete;
  Neighbors& operator=(const Neighbors&) = delete;

  /// Number of points in the tree.
  Eigen::Index size() const;

  /// K nearest neighbours of every point, self included as column 0. K is clamped to size().
  /// `indices` becomes N x K; `sq_distances` (optional) N x K squared distances.
  void knn_all(int k, IndexMatrix& indices, DistanceMatrix* sq_distances,
               const RunContext& run = {}) const;

  /// K nearest neighbours of the points `rows` (R indices into the tree's points), self first as
  /// in knn_all: `indices` becomes R x K (row r = point rows[r]), `sq_distances` (optional)
  /// R x K. The same neighbours as the matching rows of knn_all.
  void knn_rows(int k, const std::vector<int64_t>& rows, IndexMatrix& indices,
                DistanceMatrix* sq_distances, const RunContext& run = {}) const;

  /// K nearest neighbours of an arbitrary query point (3-vector), ascending distance.
  void knn(const Eigen::Vector3d& query, int k, std::vector<int32_t>& indices,
           std::vector<float>& sq_distances) const;

  /// All points within `radius` (inclusive) of `query`: (index, squared distance) pairs,
  /// ascending distance.
  void radius(const Eigen::Vector3d& query, double radius,
              std::vector<std::pair<int32_t, float>>& out) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace nhnet
