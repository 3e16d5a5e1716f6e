// Multi-scale bilateral normal filtering (paper Eq. 5); see bilateral_filter.hpp.
#include "nhnet/learned/bilateral_filter.hpp"

#include "nhnet/errors.hpp"
#include "util/fast_math.hpp"
#include "util/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace nhnet {

namespace {

/// One point's neighbours with a finite normal, in table order (per thread, reused).
struct Scratch {
  Eigen::ArrayXd d2;                            // squared distances to p_i
  Eigen::ArrayXd dn2;                           // squared normal differences 2 (1 - |n_i . n_j|)
  Eigen::Matrix<double, Eigen::Dynamic, 3> nj;  // normals flipped to n_i's side
  Eigen::ArrayXd ws;                            // spatial weights of one sigma_s
  Eigen::ArrayXXd wr;                           // range weights, one column per sigma_r
  Eigen::Index count = 0;                       // neighbours kept (rows in use)

  void gather(const Points& points, const Normals& normals, const IndexMatrix& knn, int64_t i,
              int k, const Eigen::Vector3d& pi, const Eigen::Vector3d& ni) {
    d2.resize(k);
    dn2.resize(k);
    nj.resize(k, 3);
    int m = 0;  // rows 0 .. m-1 hold the neighbours kept
    for (int c = 0; c < k; ++c) {
      const int32_t j = knn(i, c);
      Eigen::Vector3d v = normals.row(j).transpose();
      if (!v.allFinite()) continue;
      double dot = ni.dot(v);
      if (dot < 0) {
        v = -v;
        dot = -dot;
      }
      d2[m] = (points.row(j).transpose() - pi).squaredNorm();
      dn2[m] = std::max(0.0, 2.0 * (1.0 - dot));
      nj.row(m) = v.transpose();
      ++m;
    }
    count = m;
  }
};

thread_local Scratch scratch;

}  // namespace

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
    // Per neighbour once (not once per width pair): its normal flipped to n_i's side, the squared
    // distance and the squared normal difference; the weights are exp(-d2 / 2s^2) exp(-dn2 / 2r^2),
    // |sigma_s| + |sigma_r| vectorised exponentials per neighbour instead of |sigma_s| |sigma_r|
    // (util/fast_math.hpp's batch exp: four lanes with AVX2, against Eigen's two).
    Scratch& sc = scratch;
    sc.gather(points, normals, knn, i, k, pi, ni);
    const Eigen::Index m = sc.count;
    sc.wr.resize(k, nr);
    for (int b = 0; b < nr; ++b) {
      const double r = options.sigma_r[size_t(b)];
      sc.wr.col(b).head(m) = sc.dn2.head(m) * (-1.0 / (2 * r * r));
      detail::exp_nonpositive_batch(sc.wr.col(b).data(), sc.wr.col(b).data(), size_t(m));
    }
    for (int a = 0; a < ns; ++a) {
      const double s = options.sigma_s[size_t(a)] * spacing;
      const double inv_s = s > 0 ? 1.0 / (2 * s * s) : 0.0;
      sc.ws.resize(k);
      sc.ws.head(m) = sc.d2.head(m) * -inv_s;
      detail::exp_nonpositive_batch(sc.ws.data(), sc.ws.data(), size_t(m));
      for (int b = 0; b < nr; ++b) {
        const Eigen::Vector3d acc =
            sc.nj.topRows(m).transpose() * (sc.ws.head(m) * sc.wr.col(b).head(m)).matrix();
        const double len = acc.norm();
        out.block<1, 3>(i, 3 * (1 + a * nr + b)) =
            (len > 0 ? Eigen::Vector3d(acc / len) : ni).transpose();
      }
    }
  });
  return out;
}

}  // namespace nhnet
