// The k nearest neighbours of one kd-tree leaf's points from one shared radius search
// (leaf_batch.hpp), and the tree's shape that orders their equal distances (kdtree.hpp).
#include "neighbors/leaf_batch.hpp"

#include <algorithm>
#include <cmath>

namespace nhnet::detail {

namespace {

int32_t add_node(const Tree::Node* node, TreeShape& shape, uint32_t& first) {
  const int32_t id = int32_t(shape.nodes.size());
  shape.nodes.emplace_back();
  if (node->child1 == nullptr && node->child2 == nullptr) {
    first = uint32_t(node->node_type.lr.left);
    shape.leaf_start.push_back(first);
    shape.nodes[size_t(id)].boundary = first;
    shape.nodes[size_t(id)].end = uint32_t(node->node_type.lr.right);
    return id;
  }
  uint32_t first2 = 0;
  const int32_t c1 = add_node(node->child1, shape, first);
  const int32_t c2 = add_node(node->child2, shape, first2);
  TreeShape::Node& out = shape.nodes[size_t(id)];
  out.child1 = c1;
  out.child2 = c2;
  out.divfeat = node->node_type.sub.divfeat;
  out.divlow = node->node_type.sub.divlow;
  out.divhigh = node->node_type.sub.divhigh;
  out.boundary = first2;
  return id;
}

/// The mean of positions [a, b) into centre, and the largest distance from it to one of them.
double leaf_ball(const FloatCloud& cloud, uint32_t a, uint32_t b, float* centre) {
  double sum[3] = {0, 0, 0};
  for (uint32_t p = a; p < b; ++p)
    for (int d = 0; d < 3; ++d) sum[d] += cloud.xyz[3 * size_t(p) + d];
  for (int d = 0; d < 3; ++d) centre[d] = float(sum[d] / double(b - a));
  double rho2 = 0;
  for (uint32_t p = a; p < b; ++p) {
    double s = 0;
    for (int d = 0; d < 3; ++d) {
      const double v = double(cloud.xyz[3 * size_t(p) + d]) - double(centre[d]);
      s += v * v;
    }
    rho2 = std::max(rho2, s);
  }
  return std::sqrt(rho2);
}

constexpr int kWidenings = 8;          // then the caller searches point by point
constexpr float kWiden = 1.5f;         // radius factor per widening
constexpr double kMargin = 1e-3;       // relative, on the candidates' radius: float rounding
constexpr double kBoundMargin = 1e-4;  // relative, on next_bound's squared distance: the same

}  // namespace

TreeShape tree_shape(const Tree& tree, uint32_t points) {
  TreeShape shape;
  uint32_t first = 0;
  if (tree.root_node) add_node(tree.root_node, shape, first);
  shape.leaf_start.push_back(points);
  return shape;
}

bool visits_before(const TreeShape& shape, const float* q, uint32_t a, uint32_t b) {
  int32_t id = 0;
  while (shape.nodes[size_t(id)].child1 >= 0) {
    const TreeShape::Node& node = shape.nodes[size_t(id)];
    const bool a2 = a >= node.boundary, b2 = b >= node.boundary;
    if (a2 != b2) {  // split here: nanoflann enters child1 first iff (diff1 + diff2) < 0
      const float val = q[node.divfeat];
      const float diff1 = val - node.divlow, diff2 = val - node.divhigh;
      return (diff1 + diff2) < 0 ? !a2 : a2;
    }
    id = a2 ? node.child2 : node.child1;
  }
  return a < b;  // one leaf: in position order
}

namespace {

/// The square of a bound on query q's kk-th distance from the previous query's (at qp, its
/// kk-th squared distance far2): the previous query's kk nearest are candidates, and within
/// sqrt(far2) + |q - qp| of q. Widened by kBoundMargin for the float distances; at most r2.
float next_bound(const float* q, const float* qp, float far2, float r2) {
  double s = 0;
  for (int d = 0; d < 3; ++d) s += (double(q[d]) - qp[d]) * (double(q[d]) - qp[d]);
  const double b = std::sqrt(double(far2)) + std::sqrt(s);
  return float(std::min(double(r2), b * b * (1 + kBoundMargin)));
}

}  // namespace

bool LeafBatch::run(const FloatCloud& cloud, const TreeShape& shape, uint32_t a, uint32_t b, int kk,
                    float& radius) {
  kk_ = kk;
  idx_.resize(size_t(b - a) * size_t(kk));
  d2_.resize(idx_.size());
  float centre[3];
  const double rho = leaf_ball(cloud, a, b, centre);
  for (int attempt = 0; attempt < kWidenings; ++attempt, radius *= kWiden) {
    const double reach = (double(radius) + rho) * (1 + kMargin);
    ball_.gather(shape, cloud, centre, float(reach * reach));
    dist_.resize(ball_.size());
    near_.resize(ball_.size());
    near_d_.resize(ball_.size());
    const float r2 = radius * radius;
    bool all = true;
    for (uint32_t p = a; p < b && all; ++p) {
      const float* q = &cloud.xyz[3 * size_t(p)];
      const float bound2 = p == a ? r2 : next_bound(q, q - 3, distances(p - a - 1)[kk - 1], r2);
      all = select(shape, q, r2, bound2, p - a);
    }
    if (!all) continue;
    float far = 0;
    for (size_t t = 0; t < size_t(b - a); ++t) far = std::max(far, distances(t)[kk - 1]);
    radius = std::sqrt(far) * kNextGuess;
    return true;
  }
  return false;
}

/// The candidates whose distance is below lim into near_ / near_d_, in their order; their
/// count. (Branch-free: every candidate is written, the count advances for those below.)
size_t LeafBatch::keep_below(float lim) {
  size_t c = 0;
  for (size_t j = 0; j < dist_.size(); ++j) {
    near_[c] = uint32_t(j);
    near_d_[c] = dist_[j];
    c += size_t(dist_[j] < lim);
  }
  return c;
}

/// Query q (the t-th of its leaf): its first kk candidates strictly within sqrt(r2) by
/// (distance, visit) into row t; false when fewer than kk lie within. Only the candidates
/// below bound2 (<= r2) are ordered when kk of them are: the kk nearest are then among them.
bool LeafBatch::select(const TreeShape& shape, const float* q, float r2, float bound2, size_t t) {
  const size_t n = ball_.size();
  const float *x = ball_.x(), *y = ball_.y(), *z = ball_.z();
  const uint32_t* pos = ball_.pos();
  // Squared distances as nanoflann's L2_Simple_Adaptor computes them (float, the query minus
  // the point, summed x, y, z in that order), so that equal distances stay equal; on columns,
  // so that the loop vectorises.
  for (size_t j = 0; j < n; ++j) {
    const float dx = q[0] - x[j], dy = q[1] - y[j], dz = q[2] - z[j];
    float d = 0.f;
    d += dx * dx;
    d += dy * dy;
    d += dz * dz;
    dist_[j] = d;
  }
  size_t c = keep_below(bound2);
  if (c < size_t(kk_) && bound2 < r2) c = keep_below(bound2 = r2);
  if (!order_.sort(near_d_.data(), c, bound2, kk_)) return false;
  order_.order_ties(near_d_.data(), kk_, [&](uint32_t u, uint32_t v) {
    return visits_before(shape, q, pos[near_[u]], pos[near_[v]]);
  });
  uint32_t* idx = idx_.data() + t * size_t(kk_);
  float* d2 = d2_.data() + t * size_t(kk_);
  for (int j = 0; j < kk_; ++j) {
    const uint32_t m = order_[size_t(j)];
    idx[j] = pos[near_[m]];
    d2[j] = near_d_[m];
  }
  return true;
}

}  // namespace nhnet::detail
