// Internal: the tangent frame of a unit normal and the normal equations that the degree-2 jet
// fits share (geometry/jet.cpp and the learned fit, learned/learned_fit.cpp), so both fit their
// heights over the same axes the same way.
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

/// The weighted least-squares system of the jet h = c0 + c1 u + c2 v + c3 u^2 + c4 uv + c5 v^2:
/// A^T W A and A^T W h. The full 6 x 6 outer product, which Eigen unrolls and vectorises: its
/// selfadjointView().rankUpdate() on one triangle goes through a generic kernel that costs more.
struct JetSystem {
  Eigen::Matrix<double, 6, 6> ata = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> atb = Eigen::Matrix<double, 6, 1>::Zero();

  /// Adds the point (u, v) of height h with weight w.
  void add(double u, double v, double h, double w = 1) {
    Eigen::Matrix<double, 6, 1> row;
    row << 1, u, v, u * u, u * v, v * v;
    ata.noalias() += row * (w * row).transpose();
    atb.noalias() += (w * h) * row;
  }
};

}  // namespace nhnet::detail
