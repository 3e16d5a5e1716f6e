// Internal: the radial candidate of one point from its neighbourhood's plane fit (fit_plane's
// centroid, eigenvalues and principal direction), shared by radial_normals and pca_normals (which
// gives it from the planes it fits anyway: PcaOptions::radial).
#pragma once

#include "nhnet/geometry/radial.hpp"

namespace nhnet::detail {

/// A RadialResult of n rows, uninitialised.
RadialResult radial_result(Eigen::Index n);

/// Row i of `out` (geometry/radial.hpp) for the point p and its neighbourhood's centroid c,
/// covariance eigenvalues ev (ascending) and principal direction axis.
void radial_from_plane(const Eigen::Vector3d& p, const Eigen::Vector3d& c,
                       const Eigen::Vector3d& ev, const Eigen::Vector3d& axis, Eigen::Index i,
                       RadialResult& out);

}  // namespace nhnet::detail
