// Canonical frame of the normal tensor (paper Sec. 5.1); see canonical_frame.hpp.
#include "nhnet/learned/canonical_frame.hpp"

#include "nhnet/errors.hpp"
#include "util/parallel.hpp"

#include <Eigen/Geometry>

#include <Eigen/Eigenvalues>

#include <cmath>
#include <limits>

namespace nhnet {

CanonicalFrames canonical_frames(const Points& points, const IndexMatrix& knn, int k,
                                 const FeatureNormals& normals, const RunContext& run,
                                 Eigen::Index first) {
  if (normals.cols() < 3 || normals.cols() % 3 != 0)
    throw InvalidOptions("canonical_frames: normals must have 3 F columns");
  const Eigen::Index n = normals.rows();
  if (first < 0 || first + n > points.rows() || knn.rows() != n || k < 1 || k > knn.cols())
    throw InvalidOptions("canonical_frames: points, neighbour table and normals differ in size");
  const int f = int(normals.cols() / 3);
  CanonicalFrames out;
  out.rotations.resize(n, 9);
  out.rotated.resize(n, normals.cols());
  detail::Progress progress(run.progress);
  if (run.progress) progress.stage("canonical frames", 0, 1);
  detail::parallel_for(n, run.threads, run.progress ? &progress : nullptr, [&](int64_t i) {
    if (!normals.row(i).allFinite()) {
      out.rotations.row(i).setConstant(std::numeric_limits<double>::quiet_NaN());
      out.rotated.row(i).setConstant(std::numeric_limits<double>::quiet_NaN());
      return;
    }
    Eigen::Matrix3d t = Eigen::Matrix3d::Zero();
    for (int a = 0; a < f; ++a) {
      const Eigen::Vector3d v = normals.block<1, 3>(i, 3 * a).transpose();
      t += v * v.transpose();
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(t);
    Eigen::Vector3d e3 = es.eigenvectors().col(2);
    const Eigen::Vector3d pi = points.row(first + i).transpose();
    double r3 = 0, m1 = 0, m3 = 0;
    for (int c = 1; c < k; ++c) {
      const Eigen::Vector3d d = points.row(knn(i, c)).transpose() - pi;
      r3 = std::max(r3, d.squaredNorm());
      const double z = d.dot(e3);
      m1 += z;
      m3 += z * z * z;
    }
    const double rr = std::sqrt(r3);
    r3 *= rr;
    // e3 points away from the neighbours' centroid (to the convex side), else by their third
    // moment; an exactly flat patch keeps the solver's sign (its descriptor does not depend on it).
    if (m1 > 1e-9 * rr * k || (std::abs(m1) <= 1e-9 * rr * k && m3 > 1e-9 * r3 * k)) e3 = -e3;
    // Sign of e from the normals' third moment, else the offsets' (see the header).
    const auto orient = [&](Eigen::Vector3d e) {
      double m = 0;
      for (int a = 0; a < f; ++a) {
        Eigen::Vector3d v = normals.block<1, 3>(i, 3 * a).transpose();
        if (v.dot(e3) < 0) v = -v;
        const double y = v.dot(e);
        m += y * y * y;
      }
      if (std::abs(m) > 1e-6 * f) return m < 0 ? Eigen::Vector3d(-e) : e;
      double q = 0;
      for (int c = 1; c < k; ++c) {
        const double y = (points.row(knn(i, c)).transpose() - pi).dot(e);
        q += y * y * y;
      }
      return q < -1e-9 * r3 * k ? Eigen::Vector3d(-e) : e;
    };
    const Eigen::Vector3d e2 = orient(es.eigenvectors().col(1));
    const Eigen::Vector3d e1 = orient(es.eigenvectors().col(0));
    Eigen::Matrix3d r;
    r.row(0) = e1.transpose();
    r.row(1) = e2.transpose();
    r.row(2) = e3.transpose();
    for (int c = 0; c < 9; ++c) out.rotations(i, c) = r(c / 3, c % 3);
    for (int a = 0; a < f; ++a) {
      Eigen::Vector3d v = r * normals.block<1, 3>(i, 3 * a).transpose();
      if (v.z() < 0) v = -v;
      out.rotated.block<1, 3>(i, 3 * a) = v.transpose();
    }
  });
  return out;
}

}  // namespace nhnet
