// Multi-scale bilateral normal filtering (paper Eq. 5); see bilateral_filter.hpp.
#include "nhnet/learned/bilateral_filter.hpp"

#include "nhnet/errors.hpp"
#include "util/parallel.hpp"

#include <cmath>
#include <limits>
#include <string>

namespace nhnet {

FeatureNormals bilateral_filter(const Points& points, const Normals& normals,
                                const IndexMatrix& knn, int k,
                                const BilateralFilterOptions& options, const RunContext& run,
                                Eigen::Index first) {
  const Eigen::Index n = knn.rows();
  if (normals.rows() != points.rows() || first < 0 || first + n > points.rows())
    throw InvalidOptions("bilateral_filter: points, normals and neighbour table differ in size");
  if (k < 2 || k > knn.cols())
    throw InvalidOptions("bilateral_filter: k must be in [2, " + std::to_string(knn.cols()) + "]");
  if (options.spacing_k < 1 || options.spacing_k >= k)
    throw InvalidOptions("bilateral_filter: spacing_k must be in [1, k)");
  for (double s : options.sigma_s)
    if (!(s > 0)) throw InvalidOptions("bilateral_filter: every sigma_s must be > 0");
  for (double s : options.sigma_r)
    if (!(s > 0)) throw InvalidOptions("bilateral_filter: every sigma_r must be > 0");
  const int ns = int(options.sigma_s.size()), nr = int(options.sigma_r.size());
  const int f = 1 + ns * nr;
  FeatureNormals out(n, 3 * f);
  detail::Progress progress(run.progress);
  if (run.progress) progress.stage("bilateral filter", 0, 1);
  detail::parallel_for(n, run.threads, run.progress ? &progress : nullptr, [&](int64_t i) {
    const Eigen::Vector3d ni = normals.row(first + i).transpose();
    if (!ni.allFinite()) {
      out.row(i).setConstant(std::numeric_limits<double>::quiet_NaN());
      return;
    }
    const Eigen::Vector3d pi = points.row(first + i).transpose();
    double spacing = 0;
    for (int c = 1; c <= options.spacing_k; ++c)
      spacing += (points.row(knn(i, c)).transpose() - pi).norm();
    spacing /= options.spacing_k;
    out.block<1, 3>(i, 0) = ni.transpose();
    for (int a = 0; a < ns; ++a) {
      const double s = options.sigma_s[size_t(a)] * spacing;
      const double inv_s = s > 0 ? 1.0 / (2 * s * s) : 0.0;
      for (int b = 0; b < nr; ++b) {
        const double r = options.sigma_r[size_t(b)];
        const double inv_r = 1.0 / (2 * r * r);
        Eigen::Vector3d acc = Eigen::Vector3d::Zero();
        for (int c = 0; c < k; ++c) {
          const int32_t j = knn(i, c);
          Eigen::Vector3d nj = normals.row(j).transpose();
          if (!nj.allFinite()) continue;
          double dot = ni.dot(nj);
          if (dot < 0) {
            nj = -nj;
            dot = -dot;
          }
          const double d2 = (points.row(j).transpose() - pi).squaredNorm();
          const double dn2 = std::max(0.0, 2.0 * (1.0 - dot));
          acc += std::exp(-d2 * inv_s - dn2 * inv_r) * nj;
        }
        const double len = acc.norm();
        out.block<1, 3>(i, 3 * (1 + a * nr + b)) =
            (len > 0 ? Eigen::Vector3d(acc / len) : ni).transpose();
      }
    }
  });
  return out;
}

}  // namespace nhnet
