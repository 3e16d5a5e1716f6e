// Internal: the float kd-tree behind Neighbors (nanoflann, coordinates in leaf order) and the
// shape of its nodes, shared by the per-query search (neighbors.cpp) and the search one leaf
// at a time (leaf_batch.cpp).
#pragma once

#include <nanoflann.hpp>

#include <cstdint>
#include <vector>

namespace nhnet::detail {

/// The tree's points, re-centred, as float; after the build in the tree's leaf order.
struct FloatCloud {
  std::vector<float> xyz;  // 3N
  size_t kdtree_get_point_count() const { return xyz.size() / 3; }
  float kdtree_get_pt(size_t i, size_t d) const { return xyz[3 * i + d]; }
  template <class BBOX>
  bool kdtree_get_bbox(BBOX&) const {
    return false;
  }
};

using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, FloatCloud>,
                                                 FloatCloud, 3, uint32_t>;

/// The tree's nodes in a flat array, and its leaves as ranges of leaf-order positions.
struct TreeShape {
  struct Node {
    int32_t child1 = -1, child2 = -1;  // -1: a leaf
    int32_t divfeat = 0;               // split axis
    float divlow = 0, divhigh = 0;     // the split values nanoflann compares the query with
    uint32_t boundary = 0;             // first position of child2's subtree; a leaf's first
    uint32_t end = 0;                  // a leaf: one past its last position
  };
  std::vector<Node> nodes;           // nodes[0]: the root
  std::vector<uint32_t> leaf_start;  // leaf l holds positions [leaf_start[l], leaf_start[l + 1])
};

/// The shape of a built tree whose index array is the identity (leaf order).
TreeShape tree_shape(const Tree& tree, uint32_t points);

/// True when nanoflann's depth-first search from query q (it enters first the child on q's
/// side of each split) reaches position a before position b: the order in which a search adds
/// its hits, and so the order of equal distances in every k-NN table.
bool visits_before(const TreeShape& shape, const float* q, uint32_t a, uint32_t b);

}  // namespace nhnet::detail
