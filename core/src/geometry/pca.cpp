// PCA normals and surface variation (paper Sec. 4, first paragraph; Pauly et al. surface
// variation). Double-precision covariance around the neighbourhood centroid.
#include "nhnet/geometry/pca.hpp"

#include "geometry/radial_row.hpp"
#include "nhnet/errors.hpp"
#include "util/parallel.hpp"

#include <Eigen/Eigenvalues>

#include <cmath>
#include <limits>

namespace nhnet {

Eigen::Vector3d fit_plane(const Points& points, const int32_t* idx, int count,
                          Eigen::Vector3d* centroid, Eigen::Vector3d* eigenvalues,
                          Eigen::Vector3d* principal) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int j = 0; j < count; ++j) c += points.row(idx[j]).transpose();
  c /= double(std::max(count, 1));
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int j = 0; j < count; ++j) {
    const Eigen::Vector3d d = points.row(idx[j]).transpose() - c;
    cov.noalias() += d * d.transpose();
  }
  cov /= double(std::max(count, 1));
  if (centroid) *centroid = c;
  if (count < 3 || !cov.allFinite()) {
    if (eigenvalues) eigenvalues->setConstant(nan);
    if (principal) principal->setConstant(nan);
    return Eigen::Vector3d::Constant(nan);
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  if (eigenvalues) *eigenvalues = es.eigenvalues();
  if (principal) *principal = es.eigenvectors().col(2);
  // Rank < 2 (all points identical or collinear): the plane is undefined.
  const Eigen::Vector3d ev = es.eigenvalues();
  if (!(ev[1] > 1e-12 * std::max(ev[2], 1e-300))) return Eigen::Vector3d::Constant(nan);
  return es.eigenvectors().col(0).normalized();
}

PcaResult pca_normals(const Points& points, const IndexMatrix& knn, const PcaOptions& options,
                      const RunContext& run) {
  const Eigen::Index n = points.rows();
  if (knn.rows() != n) throw InvalidOptions("pca_normals: knn must have one row per point");
  const int k =
      options.k > 0 ? int(std::min<Eigen::Index>(options.k, knn.cols())) : int(knn.cols());
  if (k < 3) throw InvalidOptions("pca_normals: k must be at least 3");
  PcaResult r;
  r.normals.resize(n, 3);
  r.variation.resize(n);
  r.residual_rms.resize(n);
  if (options.centroids) r.centroid.resize(n, 3);
  if (options.radial) r.radial = detail::radial_result(n);
  r.k = k;
  detail::Progress progress(run.progress);
  if (run.progress) progress.stage("pca", 0, 1);
  detail::parallel_for(n, run.threads, run.progress ? &progress : nullptr, [&](int64_t i) {
    Eigen::Vector3d ev, c, axis;
    const Eigen::Vector3d nrm =
        fit_plane(points, &knn(i, 0), k, &c, &ev, options.radial ? &axis : nullptr);
    r.normals.row(i) = nrm.transpose();
    if (options.centroids) r.centroid.row(i) = c.transpose();
    if (options.radial)
      detail::radial_from_plane(points.row(i).transpose(), c, ev, axis, i, r.radial);
    const double s = ev.sum();
    r.variation[i] = (s > 0 && std::isfinite(s)) ? std::max(0.0, ev[0]) / s : 0.0;
    r.residual_rms[i] = std::sqrt(std::max(0.0, ev[0]));
  });
  return r;
}

}  // namespace nhnet
