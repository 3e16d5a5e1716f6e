// Radial normals (geometry/radial.hpp): one covariance per neighbourhood, PCA's fit_plane (Eq. 1);
// pca_normals gives them from its own planes when asked (PcaOptions::radial).
#include "nhnet/geometry/radial.hpp"

#include "geometry/radial_row.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/geometry/pca.hpp"
#include "util/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace nhnet {

/// An offset below this fraction of the spread is rounding (tools/fit_candidate_mix.py: same).
constexpr double kOnAxis = 1e-9;

namespace detail {

RadialResult radial_result(Eigen::Index n) {
  return {Normals(n, 3), Eigen::VectorXd(n), Eigen::VectorXd(n)};
}

void radial_from_plane(const Eigen::Vector3d& p, const Eigen::Vector3d& c,
                       const Eigen::Vector3d& ev, const Eigen::Vector3d& axis, Eigen::Index i,
                       RadialResult& out) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Eigen::Vector3d w = ev.cwiseMax(0.0);
  const Eigen::Vector3d d = p - c;
  const Eigen::Vector3d r = d - d.dot(axis) * axis;
  const double length = r.norm(), spread = std::sqrt(w.sum());
  out.elongation[i] = w[2] > 0 ? w[1] / w[2] : nan;
  // On the axis up to rounding (a symmetric neighbourhood, a line): no direction to give.
  const bool ok = spread > 0 && length > kOnAxis * spread && r.allFinite();
  out.normals.row(i) =
      ok ? Eigen::RowVector3d((r / length).transpose()) : Eigen::RowVector3d::Constant(nan);
  out.offset[i] = ok ? length / spread : nan;
}

}  // namespace detail

namespace {

/// Radial normal, offset and elongation of point i from its first k neighbours.
void radial_row(const Points& points, const int32_t* idx, int k, Eigen::Index i,
                RadialResult& out) {
  Eigen::Vector3d c, ev, axis;
  fit_plane(points, idx, k, &c, &ev, &axis);  // the covariance over k, as PCA's
  detail::radial_from_plane(points.row(i).transpose(), c, ev, axis, i, out);
}

}  // namespace

RadialResult radial_normals(const Points& points, const IndexMatrix& knn,
                            const RadialOptions& options, const RunContext& run) {
  const Eigen::Index n = points.rows();
  if (knn.rows() != n) throw InvalidOptions("radial_normals: knn must have one row per point");
  const int k =
      options.k > 0 ? int(std::min<Eigen::Index>(options.k, knn.cols())) : int(knn.cols());
  if (k < 3) throw InvalidOptions("radial_normals: k must be at least 3");
  RadialResult out = detail::radial_result(n);
  detail::Progress progress(run.progress);
  if (run.progress) progress.stage("radial", 0, 1);
  detail::parallel_for(n, run.threads, run.progress ? &progress : nullptr,
                       [&](int64_t i) { radial_row(points, &knn(i, 0), k, i, out); });
  return out;
}

}  // namespace nhnet
