// Basic array types shared by every stage. Points are N x 3 arrays, one point per row.
#pragma once

#include <Eigen/Core>

#include <cstdint>

namespace nhnet {

/// N x 3 point coordinates, row-major (x y z of one point contiguous), double precision.
using Points = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

/// N x 3 normals, row-major. Unit length where valid; a failed point has a NaN row.
using Normals = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

/// N x K neighbour indices, row-major; row i lists the K nearest points of point i in ascending
/// distance, point i itself first.
using IndexMatrix = Eigen::Matrix<int32_t, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// N x K squared distances matching an IndexMatrix (float: they come from a float kd-tree).
using DistanceMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

}  // namespace nhnet
