// Neighbour search: one nanoflann kd-tree (float, re-centred coordinates) per cloud.
// Chosen by measurement against PCL's FLANN tree and CGAL's kd-tree
// (docs/design/decisions.md#kd-tree-nanoflann-with-queries-in-leaf-order). After the build the
// coordinates are stored in the tree's leaf order (the tree's index array becomes the identity), so
// a leaf's points are contiguous in memory and knn_all visits queries in that order: the same tree,
// the same visiting order, the same results (ties included), 20-30 % less neighbour-search time at
// 1M points (docs/design/decisions.md#kd-tree-nanoflann-with-queries-in-leaf-order). Indices map
// back to input order.
#include "nhnet/neighbors/neighbors.hpp"

#include "neighbors/ball_search.hpp"
#include "neighbors/first_k.hpp"
#include "neighbors/kdtree.hpp"
#include "neighbors/leaf_batch.hpp"
#include "nhnet/errors.hpp"
#include "util/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

namespace nhnet {

using detail::FloatCloud;
using detail::Tree;

struct Neighbors::Impl {
  FloatCloud cloud;                // in leaf order
  std::vector<uint32_t> original;  // leaf-order position -> input index
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  std::unique_ptr<Tree> tree;
  detail::TreeShape shape;  // for the search one leaf at a time
};

Neighbors::Neighbors(const Points& points) : impl_(std::make_unique<Impl>()) {
  const Eigen::Index n = points.rows();
  if (n == 0) throw InvalidOptions("Neighbors: empty point set");
  if (!points.allFinite()) throw InvalidOptions("Neighbors: points must be finite");
  impl_->centre = points.colwise().mean().transpose();
  impl_->cloud.xyz.resize(3 * size_t(n));
  for (Eigen::Index i = 0; i < n; ++i)
    for (int d = 0; d < 3; ++d)
      impl_->cloud.xyz[3 * i + d] = static_cast<float>(points(i, d) - impl_->centre[d]);
  impl_->tree =
      std::make_unique<Tree>(3, impl_->cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  impl_->tree->buildIndex();
  // Leaf order: permute the coordinates by the tree's index array and make that array the
  // identity. The nodes (split planes, bounding boxes, leaf ranges) are untouched.
  auto& vind = impl_->tree->vAcc;
  impl_->original.assign(vind.begin(), vind.end());
  std::vector<float> sorted(3 * size_t(n));
  for (size_t p = 0; p < size_t(n); ++p) {
    for (int d = 0; d < 3; ++d)
      sorted[3 * p + d] = impl_->cloud.xyz[3 * size_t(impl_->original[p]) + d];
    vind[p] = uint32_t(p);
  }
  impl_->cloud.xyz.swap(sorted);
  impl_->shape = detail::tree_shape(*impl_->tree, uint32_t(n));
}

Neighbors::~Neighbors() = default;
Neighbors::Neighbors(Neighbors&&) noexcept = default;
Neighbors& Neighbors::operator=(Neighbors&&) noexcept = default;

Eigen::Index Neighbors::size() const { return Eigen::Index(impl_->cloud.kdtree_get_point_count()); }

namespace {

/// nanoflann's KNNResultSet (1.4.x) keeps its k best sorted and inserts by shifting, O(k) per
/// accepted point: at k = 300 (the noise-driven sizes of a noisy cloud) the neighbour search
/// spent most of its time shifting. This set keeps them in a max-heap (O(log k)) and sorts once
/// at the end. Same results, ties included: the heap orders by (distance, arrival), a full set
/// rejects a point no nearer than its worst (KNNResultSet's `dist < worst` and its placement
/// after equal distances) and evicts the latest-arrived of its farthest, as KNNResultSet drops
/// its last slot; the final order is by distance, then arrival.
class HeapResultSet {
 public:
  using DistanceType = float;
  /// Empties the set for a query of `capacity` neighbours.
  void init(size_t capacity) {
    capacity_ = capacity;
    heap_.clear();
    heap_.reserve(capacity);
    arrived_ = 0;
  }
  size_t size() const { return heap_.size(); }
  bool full() const { return heap_.size() == capacity_; }
  bool addPoint(float dist, uint32_t index) {
    const Entry e{dist, arrived_++, index};
    if (!full()) {
      heap_.push_back(e);
      std::push_heap(heap_.begin(), heap_.end());
    } else if (dist < heap_.front().dist) {
      std::pop_heap(heap_.begin(), heap_.end());
      heap_.back() = e;
      std::push_heap(heap_.begin(), heap_.end());
    }
    return true;
  }
  float worstDist() const {
    return full() ? heap_.front().dist : std::numeric_limits<float>::max();
  }
  /// The neighbours nearest first into idx / d2 (size() entries each).
  void sorted(uint32_t* idx, float* d2) {
    std::sort_heap(heap_.begin(), heap_.end());
    for (size_t j = 0; j < heap_.size(); ++j) {
      idx[j] = heap_[j].index;
      d2[j] = heap_[j].dist;
    }
  }

 private:
  struct Entry {
    float dist;
    uint64_t arrival;
    uint32_t index;
    bool operator<(const Entry& o) const {
      return dist < o.dist || (dist == o.dist && arrival < o.arrival);
    }
  };
  size_t capacity_ = 0;
  uint64_t arrived_ = 0;
  std::vector<Entry> heap_;
};

// From this many neighbours on, the heap replaces KNNResultSet's insertion.
constexpr int kHeapFrom = 48;

/// What the searches read of Neighbors::Impl.
struct TreeView {
  const Tree& tree;
  const FloatCloud& cloud;
  const detail::TreeShape& shape;
  const std::vector<uint32_t>& original;
};

/// k nearest of q from a radius search: every point strictly within sqrt(r2) in the search's
/// visiting order, the first k of them by (distance, visit) — what KNNResultSet keeps, ties
/// included, since the k-NN search visits the same nodes in the same order and skips only
/// subtrees strictly farther than its k-th. False when fewer than k lie within the radius.
bool knn_by_radius(const TreeView& v, const float* q, int kk, float r2, uint32_t* idx, float* d2) {
  thread_local detail::Ball ball;
  thread_local detail::FirstK first;
  ball.gather(v.shape, v.cloud, q, r2);
  if (!first.sort(ball.d2(), ball.size(), r2, kk)) return false;
  for (int j = 0; j < kk; ++j) {
    idx[j] = ball.pos()[first[size_t(j)]];
    d2[j] = ball.d2()[first[size_t(j)]];
  }
  return true;
}

// k nearest of q into idx / d2, nearest first; returns how many were found. From kHeapFrom
// neighbours on: a radius search with the previous query's k-th distance (queries run in leaf
// order, so the previous one is close by) widened by 20 %, widened again when it holds fewer
// than k points, else the heap. A radius search adds every point within it in O(1); the
// k-NN search's worst distance shrinks slowly at large k and admits thousands of points.
size_t knn_search(const TreeView& v, const float* q, int kk, uint32_t* idx, float* d2) {
  if (kk < kHeapFrom) return v.tree.knnSearch(q, size_t(kk), idx, d2);
  thread_local float last_r2 = 0;
  for (float r2 = last_r2 * 1.44f; r2 > 0 && r2 < last_r2 * 12.f; r2 *= 2.25f)
    if (knn_by_radius(v, q, kk, r2, idx, d2)) {
      last_r2 = d2[kk - 1];
      return size_t(kk);
    }
  thread_local HeapResultSet set;
  set.init(size_t(kk));
  v.tree.findNeighbors(set, q, nanoflann::SearchParams());
  const size_t found = set.size();
  set.sorted(idx, d2);
  if (found == size_t(kk)) last_r2 = d2[kk - 1];
  return found;
}

/// Row `out` of the tables from the kk nearest (leaf positions idx, squared distances d2) of
/// the point at leaf position p, self first: exact duplicates can put another point first, and
/// p then moves to column 0 (replacing the last when it is lost among more than kk copies).
void write_row(const std::vector<uint32_t>& original, uint32_t p, int kk, const uint32_t* idx,
               const float* d2, Eigen::Index out, IndexMatrix& indices,
               DistanceMatrix* sq_distances) {
  const int self = int(std::find(idx, idx + kk, p) - idx);
  const int skip = std::min(self, kk - 1);  // the column that p's own entry leaves
  indices(out, 0) = int32_t(original[p]);
  for (int j = 0, col = 1; j < kk && col < kk; ++j)
    if (j != skip) indices(out, col++) = int32_t(original[idx[j]]);
  if (!sq_distances) return;
  (*sq_distances)(out, 0) = 0.f;
  for (int j = 0, col = 1; j < kk && col < kk; ++j)
    if (j != skip) (*sq_distances)(out, col++) = d2[j];
}

// One kNN query of the point at leaf position p, self first; writes row `out` of the tables.
void query_row(const TreeView& v, int64_t p, int kk, Eigen::Index out, IndexMatrix& indices,
               DistanceMatrix* sq_distances) {
  thread_local std::vector<uint32_t> idx;
  thread_local std::vector<float> d2;
  idx.resize(kk);
  d2.resize(kk);
  knn_search(v, &v.cloud.xyz[3 * p], kk, idx.data(), d2.data());
  write_row(v.original, uint32_t(p), kk, idx.data(), d2.data(), out, indices, sq_distances);
}

// From this many neighbours on, knn_all searches one leaf at a time (leaf_batch.hpp); below it
// a leaf's shared candidates save no time over nanoflann's own k-NN search (measured at k = 18;
// docs/design/decisions.md#k-nn-one-leaf-at-a-time).
constexpr int kLeafBatchFrom = 24;

/// knn_all one leaf at a time: the rows of leaf `leaf`'s points; `radius` carries each thread's
/// guess of the k-th distance from leaf to leaf (0: none yet, taken from a search of the leaf's
/// first point).
void leaf_rows(const TreeView& impl, size_t leaf, int kk, float& radius, IndexMatrix& indices,
               DistanceMatrix* sq_distances);
}  // namespace

void Neighbors::knn_all(int k, IndexMatrix& indices, DistanceMatrix* sq_distances,
                        const RunContext& run) const {
  if (k < 1) throw InvalidOptions("Neighbors::knn_all: k must be >= 1");
  const Eigen::Index n = size();
  const int kk = int(std::min<Eigen::Index>(k, n));
  detail::resize_fresh(indices, n, kk);  // may hold an earlier table (see resize_fresh)
  if (sq_distances) detail::resize_fresh(*sq_distances, n, kk);
  detail::Progress progress(run.progress);
  if (run.progress) progress.stage("neighbours", 0, 1);
  const std::vector<uint32_t>& original = impl_->original;
  detail::Progress* shown = run.progress ? &progress : nullptr;
  const TreeView view{*impl_->tree, impl_->cloud, impl_->shape, original};
  if (kk >= kLeafBatchFrom) {
    const int64_t leaves = int64_t(impl_->shape.leaf_start.size()) - 1;
    std::vector<float> radius(size_t(detail::thread_count(run.threads)), 0.f);
    detail::parallel_for(leaves, run.threads, shown, [&](int64_t leaf) {
      leaf_rows(view, size_t(leaf), kk, radius[size_t(omp_get_thread_num())], indices,
                sq_distances);
    });
    return;
  }
  // Queries in leaf order (p): consecutive queries walk the same nodes and leaves.
  detail::parallel_for(n, run.threads, shown, [&](int64_t p) {
    query_row(view, p, kk, Eigen::Index(original[size_t(p)]), indices, sq_distances);
  });
}

namespace {
void leaf_rows(const TreeView& impl, size_t leaf, int kk, float& radius, IndexMatrix& indices,
               DistanceMatrix* sq_distances) {
  thread_local detail::LeafBatch batch;
  const uint32_t a = impl.shape.leaf_start[leaf], b = impl.shape.leaf_start[leaf + 1];
  if (!(radius > 0)) {
    thread_local std::vector<uint32_t> idx;
    thread_local std::vector<float> d2;
    idx.resize(size_t(kk));
    d2.resize(size_t(kk));
    knn_search(impl, &impl.cloud.xyz[3 * size_t(a)], kk, idx.data(), d2.data());
    radius = std::sqrt(d2[size_t(kk) - 1]) * detail::LeafBatch::kNextGuess;
  }
  if (radius > 0 && batch.run(impl.cloud, impl.shape, a, b, kk, radius)) {
    for (uint32_t p = a; p < b; ++p)
      write_row(impl.original, p, kk, batch.indices(p - a), batch.distances(p - a),
                Eigen::Index(impl.original[p]), indices, sq_distances);
    return;
  }
  radius = 0;  // start afresh at the next leaf
  for (uint32_t p = a; p < b; ++p)
    query_row(impl, p, kk, Eigen::Index(impl.original[p]), indices, sq_distances);
}
}  // namespace

void Neighbors::knn_rows(int k, const std::vector<int64_t>& rows, IndexMatrix& indices,
                         DistanceMatrix* sq_distances, const RunContext& run) const {
  if (k < 1) throw InvalidOptions("Neighbors::knn_rows: k must be >= 1");
  const Eigen::Index n = size();
  const int kk = int(std::min<Eigen::Index>(k, n));
  const Eigen::Index r = Eigen::Index(rows.size());
  // Input index -> leaf position (the inverse of `original`), for the requested rows only.
  std::vector<int64_t> leaf(rows.size(), -1);
  {
    std::vector<int64_t> pos(size_t(n), -1);
    for (size_t p = 0; p < size_t(n); ++p) pos[impl_->original[p]] = int64_t(p);
    for (size_t i = 0; i < rows.size(); ++i) {
      if (rows[i] < 0 || rows[i] >= n)
        throw InvalidOptions("Neighbors::knn_rows: row out of range");
      leaf[i] = pos[size_t(rows[i])];
    }
  }
  detail::resize_fresh(indices, r, kk);
  if (sq_distances) detail::resize_fresh(*sq_distances, r, kk);
  detail::Progress progress(run.progress);
  if (run.progress) progress.stage("neighbours", 0, 1);
  const TreeView view{*impl_->tree, impl_->cloud, impl_->shape, impl_->original};
  detail::parallel_for(r, run.threads, run.progress ? &progress : nullptr, [&](int64_t i) {
    query_row(view, leaf[size_t(i)], kk, Eigen::Index(i), indices, sq_distances);
  });
}

void Neighbors::knn(const Eigen::Vector3d& query, int k, std::vector<int32_t>& indices,
                    std::vector<float>& sq_distances) const {
  const size_t kk = size_t(std::max<Eigen::Index>(0, std::min<Eigen::Index>(k, size())));
  const float q[3] = {float(query[0] - impl_->centre[0]), float(query[1] - impl_->centre[1]),
                      float(query[2] - impl_->centre[2])};
  std::vector<uint32_t> idx(kk);
  sq_distances.resize(kk);
  const size_t found = kk ? impl_->tree->knnSearch(q, kk, idx.data(), sq_distances.data()) : 0;
  indices.resize(found);
  for (size_t j = 0; j < found; ++j) indices[j] = int32_t(impl_->original[idx[j]]);
  sq_distances.resize(found);
}

void Neighbors::radius(const Eigen::Vector3d& query, double radius,
                       std::vector<std::pair<int32_t, float>>& out) const {
  const float q[3] = {float(query[0] - impl_->centre[0]), float(query[1] - impl_->centre[1]),
                      float(query[2] - impl_->centre[2])};
  std::vector<std::pair<uint32_t, float>> res;
  const float r2 = float(radius * radius);
  impl_->tree->radiusSearch(q, r2, res, nanoflann::SearchParams(32, 0.f, true));
  out.clear();
  out.reserve(res.size());
  for (auto& p : res) out.emplace_back(int32_t(impl_->original[p.first]), p.second);
}

}  // namespace nhnet
