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
/// A^T W A and A^T W h. A^T W A has 15 distinct entries, the moments sum w u^a v^b for
/// a + b <= 4, so those are what add() sums (21 sums a point instead of the 42 of the outer
/// product); ata() lays them out.
struct JetSystem {
  /// sum w u^a v^b, in the order (a, b) = 00 10 01 20 11 02 30 21 12 03 40 31 22 13 04
  double moment[15] = {};
  Eigen::Matrix<double, 6, 1> atb = Eigen::Matrix<double, 6, 1>::Zero();

  /// Adds the point (u, v) of height h with weight w.
  void add(double u, double v, double h, double w = 1) {
    const double uu = u * u, uv = u * v, vv = v * v;
    const double t[15] = {1,      u,      v,       uu,      uv,      vv,      uu * u, uu * v,
                          u * vv, vv * v, uu * uu, uu * uv, uu * vv, uv * vv, vv * vv};
    for (int i = 0; i < 15; ++i) moment[i] += w * t[i];
    const double wh = w * h;
    for (int i = 0; i < 6; ++i) atb[i] += wh * t[i];
  }

  /// A^T W A from the moments: entry (i, j) is the moment of the sum of the exponents of
  /// monomials i and j (1, u, v, u^2, uv, v^2).
  Eigen::Matrix<double, 6, 6> ata() const {
    static constexpr int kAt[6][6] = {{0, 1, 2, 3, 4, 5},    {1, 3, 4, 6, 7, 8},
                                      {2, 4, 5, 7, 8, 9},    {3, 6, 7, 10, 11, 12},
                                      {4, 7, 8, 11, 12, 13}, {5, 8, 9, 12, 13, 14}};
    Eigen::Matrix<double, 6, 6> out;
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j) out(i, j) = moment[kAt[i][j]];
    return out;
  }
};

}  // namespace nhnet::detail
