// Degree-2 osculating jet normals (geometry/jet.hpp): least squares on scaled tangent
// coordinates, so the 6 x 6 normal equations are well conditioned at any point spacing.
#include "nhnet/geometry/jet.hpp"

#include "geometry/tangent_frame.hpp"
#include "nhnet/errors.hpp"
#include "util/parallel.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include <cmath>
#include <limits>
#include <vector>

namespace nhnet {

namespace {

/// The jet normal of point i from its first k neighbours, or NaN.
Eigen::Vector3d jet_row(const Points& points, const int32_t* idx, int k, const Eigen::Vector3d& n,
                        Eigen::Index i) {
  const Eigen::Vector3d nan = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  if (!n.allFinite()) return nan;
  Eigen::Vector3d a, b;
  detail::tangent_axes(n, a, b);
  const Eigen::Vector3d p = points.row(i).transpose();
  thread_local std::vector<Eigen::Vector3d> offsets;  // the neighbours read once (per thread)
  offsets.resize(size_t(k));
  double s2 = 0;
  for (int j = 0; j < k; ++j) {
    const Eigen::Vector3d q = offsets[size_t(j)] = points.row(idx[j]).transpose() - p;
    s2 += q.dot(a) * q.dot(a) + q.dot(b) * q.dot(b);
  }
  const double s = std::sqrt(s2 / k);
  if (!(s > 0)) return nan;
  // The scale folded into the axes: (q / s) . a as q . (a / s), three products a point fewer
  // than scaling q (and no divisions).
  const Eigen::Vector3d as = a / s, bs = b / s, ns = n / s;
  detail::JetSystem sys;
  for (int j = 0; j < k; ++j) {
    const Eigen::Vector3d& q = offsets[size_t(j)];
    sys.add(q.dot(as), q.dot(bs), q.dot(ns));
  }
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(sys.ata());
  // A pivot far below the largest: the neighbours do not span a quadric (collinear, too few).
  const auto d = ldlt.vectorD().cwiseAbs();
  if (ldlt.info() != Eigen::Success || !(d.minCoeff() > 1e-10 * d.maxCoeff())) return nan;
  const Eigen::Matrix<double, 6, 1> c = ldlt.solve(sys.atb);
  const Eigen::Vector3d out = n - c[1] * a - c[2] * b;
  return out.allFinite() ? Eigen::Vector3d(out.normalized()) : nan;
}

}  // namespace

Normals jet_normals(const Points& points, const IndexMatrix& knn, const Normals& frame,
                    const JetOptions& options, const RunContext& run) {
  const Eigen::Index n = points.rows();
  if (knn.rows() != n || frame.rows() != n)
    throw InvalidOptions("jet_normals: knn and frame must have one row per point");
  const int k =
      options.k > 0 ? int(std::min<Eigen::Index>(options.k, knn.cols())) : int(knn.cols());
  if (k < 6) throw InvalidOptions("jet_normals: k must be at least 6");
  Normals out(n, 3);
  detail::Progress progress(run.progress);
  if (run.progress) progress.stage("jet", 0, 1);
  detail::parallel_for(n, run.threads, run.progress ? &progress : nullptr, [&](int64_t i) {
    out.row(i) = jet_row(points, &knn(i, 0), k, frame.row(i).transpose(), i).transpose();
  });
  return out;
}

}  // namespace nhnet
