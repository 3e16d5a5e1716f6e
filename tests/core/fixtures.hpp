// Analytic test fixtures with known normals: plane, sphere, cube (N x 3 points and normals).
#pragma once

#include "nhnet/neighbors/neighbors.hpp"
#include "nhnet/types.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <random>

namespace fixtures {

struct Fixture {
  nhnet::Points points;
  nhnet::Normals normals;
};

/// Unoriented angle between unit vectors, radians (atan2 form: exact near 0, as the core's).
inline double line_angle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), std::abs(a.dot(b)));
}

/// K nearest neighbours (self first) of every row of `points` (N x 3): an N x K table.
inline nhnet::IndexMatrix knn_table(const nhnet::Points& points, int k) {
  nhnet::IndexMatrix knn;
  nhnet::Neighbors(points).knn_all(k, knn, nullptr);
  return knn;
}

/// `points` with Gaussian noise of `sigma` (absolute units) on every coordinate.
inline nhnet::Points with_noise(const nhnet::Points& points, double sigma, unsigned seed) {
  nhnet::Points noisy = points;
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, sigma);
  for (Eigen::Index i = 0; i < noisy.rows(); ++i)
    noisy.row(i) += Eigen::RowVector3d(g(rng), g(rng), g(rng));
  return noisy;
}

/// Uniform samples of the unit square in the plane z = 0, normal +z.
inline Fixture plane(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Fixture f;
  f.points.resize(n, 3);
  f.normals.resize(n, 3);
  for (int i = 0; i < n; ++i) {
    f.points.row(i) << u(rng), u(rng), 0.0;
    f.normals.row(i) << 0, 0, 1;
  }
  return f;
}

/// Uniform samples of the unit sphere, outward normals.
inline Fixture sphere(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  Fixture f;
  f.points.resize(n, 3);
  f.normals.resize(n, 3);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d p(g(rng), g(rng), g(rng));
    p.normalize();
    f.points.row(i) = p.transpose();
    f.normals.row(i) = p.transpose();
  }
  return f;
}

/// Uniform samples of the surface of the cube [-1, 1]^3 with face normals, plus Gaussian noise
/// of standard deviation `noise` (absolute units) on every coordinate.
inline Fixture cube(int n, double noise, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> face(0, 5);
  std::normal_distribution<double> g(0.0, noise > 0 ? noise : 1.0);
  Fixture f;
  f.points.resize(n, 3);
  f.normals.resize(n, 3);
  for (int i = 0; i < n; ++i) {
    const int fc = face(rng);
    const int axis = fc / 2;
    const double side = (fc % 2) ? 1.0 : -1.0;
    Eigen::Vector3d p(u(rng), u(rng), u(rng));
    p[axis] = side;
    Eigen::Vector3d nrm = Eigen::Vector3d::Zero();
    nrm[axis] = side;
    if (noise > 0) p += Eigen::Vector3d(g(rng), g(rng), g(rng)) * 1.0;
    f.points.row(i) = p.transpose();
    f.normals.row(i) = nrm.transpose();
  }
  return f;
}

/// A closed slab [-1, 1]^2 x [-t, t] sampled uniformly by area (its six faces), outward face
/// normals, Gaussian noise `noise` (absolute units) on every coordinate: a thin wall when 2t is
/// a few point spacings.
inline Fixture slab(int n, double t, double noise, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> g(0.0, noise > 0 ? noise : 1.0);
  const double big = 4.0, small = 4.0 * t;  // area of a large face and of a side face
  std::discrete_distribution<int> face({big, big, small, small, small, small});
  Fixture f;
  f.points.resize(n, 3);
  f.normals.resize(n, 3);
  for (int i = 0; i < n; ++i) {
    const int fc = face(rng);
    Eigen::Vector3d q(u(rng), u(rng), u(rng) * t), nrm = Eigen::Vector3d::Zero();
    const double side = (fc % 2) ? 1.0 : -1.0;
    const int axis = fc < 2 ? 2 : (fc < 4 ? 0 : 1);
    q[axis] = axis == 2 ? side * t : side;
    nrm[axis] = side;
    if (noise > 0) q += Eigen::Vector3d(g(rng), g(rng), g(rng));
    f.points.row(i) = q.transpose();
    f.normals.row(i) = nrm.transpose();
  }
  return f;
}

/// `normals` with each row flipped with probability 1/2 (unoriented normals).
inline nhnet::Normals random_signs(nhnet::Normals normals, unsigned seed) {
  std::mt19937 rng(seed);
  std::bernoulli_distribution flip(0.5);
  for (Eigen::Index i = 0; i < normals.rows(); ++i)
    if (flip(rng)) normals.row(i) *= -1.0;
  return normals;
}

}  // namespace fixtures
