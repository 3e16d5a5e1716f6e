// Every point within a radius, nanoflann's radius search on the flat tree (ball_search.hpp).
#include "neighbors/ball_search.hpp"

#include <algorithm>

namespace nhnet::detail {

void Ball::gather(const TreeShape& shape, const FloatCloud& cloud, const float* centre, float r2) {
  size_ = 0;
  if (shape.nodes.empty()) return;
  float dists[3] = {0.f, 0.f, 0.f};  // the centre is inside the root's cell (a cloud point)
  descend(shape, cloud, 0, 0.f, dists, centre, r2);
}

/// gather's descent from node `id`, `mindist` the squared distance from the centre to the
/// node's cell as nanoflann bounds it (per axis in `dists`): the nearer child first, the other
/// when its cell may reach within sqrt(r2).
void Ball::descend(const TreeShape& shape, const FloatCloud& cloud, int32_t id, float mindist,
                   float* dists, const float* centre, float r2) {
  const TreeShape::Node& node = shape.nodes[size_t(id)];
  if (node.child1 < 0) {
    add_leaf(cloud, node.boundary, node.end, centre, r2);
    return;
  }
  const int f = node.divfeat;
  const float diff1 = centre[f] - node.divlow, diff2 = centre[f] - node.divhigh;
  const bool low = (diff1 + diff2) < 0;
  const float cut = low ? diff2 * diff2 : diff1 * diff1;
  descend(shape, cloud, low ? node.child1 : node.child2, mindist, dists, centre, r2);
  const float saved = dists[f];
  mindist = mindist + cut - saved;
  dists[f] = cut;
  if (mindist <= r2)
    descend(shape, cloud, low ? node.child2 : node.child1, mindist, dists, centre, r2);
  dists[f] = saved;
}

/// The points of positions [a, b) within sqrt(r2) of centre appended (distances as
/// L2_Simple_Adaptor: float, centre minus point, x + y + z in that order; branch-free: every
/// point is written, the count advances for those within).
void Ball::add_leaf(const FloatCloud& cloud, uint32_t a, uint32_t b, const float* centre,
                    float r2) {
  if (size_ + (b - a) > pos_.size()) {
    const size_t grown = std::max(2 * pos_.size(), size_ + (b - a) + 256);
    for (auto* v : {&x_, &y_, &z_, &d2_}) v->resize(grown);
    pos_.resize(grown);
  }
  for (uint32_t p = a; p < b; ++p) {
    const float* v = &cloud.xyz[3 * size_t(p)];
    const float dx = centre[0] - v[0], dy = centre[1] - v[1], dz = centre[2] - v[2];
    float d = 0.f;
    d += dx * dx;
    d += dy * dy;
    d += dz * dz;
    pos_[size_] = p;
    x_[size_] = v[0];
    y_[size_] = v[1];
    z_[size_] = v[2];
    d2_[size_] = d;
    size_ += size_t(d < r2);
  }
}

}  // namespace nhnet::detail
