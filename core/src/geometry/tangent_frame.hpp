// Internal: the tangent frame of a unit normal that the degree-2 jet fits share (geometry/jet.cpp
// and the learned fit, learned/learned_fit.cpp), so both fit their heights over the same axes.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cmath>

namespace nhnet::detail {

/// Unit tangent axes (a, b) of unit normal n: a is n x (x axis, or y when n is near x), b = n x a.
inline void tangent_axes(const Eigen::Vector3d& n, Eigen::Vector3d& a, Eigen::Vector3d& b) {
  a = n.cross(std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY())
          .normalized();
  b = n.cross(a);
}

}  // namespace nhnet::detail
