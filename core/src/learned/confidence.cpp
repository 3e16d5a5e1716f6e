// Per-point confidence of a normal (learned/confidence.hpp; not in the paper, issue 57): eight
// neighbourhood-agreement features per point, then a fixed one-layer tanh network with a
// logistic output per method, weights in confidence_weights.inc (tools/fit_confidence.py).
#include "nhnet/learned/confidence.hpp"

#include "nhnet/neighbors/neighbors.hpp"
#include "util/parallel.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

namespace nhnet {

namespace {

constexpr int kInputs = 2 * kConfidenceFeatures - 1;  // features and their square roots but
                                                      // the noise level's

/// One fitted network: input standardisation, hidden layer, logistic output.
struct ConfidenceWeights {
  std::array<double, kInputs> mean, scale;
  std::array<std::array<double, kInputs>, kConfidenceHidden> w1;
  std::array<double, kConfidenceHidden> b1;
  std::array<double, kConfidenceHidden> w2;
  double b2;
};

#include "learned/confidence_weights.inc"

const ConfidenceWeights& weights_of(ConfidenceModel model) {
  switch (model) {
    case ConfidenceModel::Pca: return kPcaWeights;
    case ConfidenceModel::Mfps: return kMfpsWeights;
    case ConfidenceModel::NhNet: break;
  }
  return kNhNetWeights;
}

using Row = Eigen::Matrix<double, 1, kConfidenceFeatures>;

/// The features of one point from its neighbours' rows (`idx`, `k` of them, self first) among
/// `pts` / `nrm`.
Row point_features(const Points& pts, const Normals& nrm, const int32_t* idx, int k,
                   double variation, double log_noise) {
  const Eigen::Index self = idx[0];
  const Eigen::RowVector3d p = pts.row(self), n = nrm.row(self);
  const size_t m = size_t(k - 1);
  std::array<double, kConfidenceNeighbours> dis{};
  Eigen::RowVector3d mean = Eigen::RowVector3d::Zero();
  double height = 0, dist = 0;
  double sum = 0;
  for (size_t j = 0; j < m; ++j) {
    const Eigen::RowVector3d off = pts.row(idx[j + 1]) - p;
    dis[j] = 1 - std::abs(n.dot(nrm.row(idx[j + 1])));
    sum += dis[j];
    height += std::abs(off.dot(n));
    dist += off.norm();
    mean += off;
  }
  Row f;
  f[0] = 3 * variation;
  f[1] = m ? sum / double(m) : 0;
  const auto end = dis.begin() + std::ptrdiff_t(m);
  f[2] = m ? *std::max_element(dis.begin(), end) : 0;
  if (m) std::nth_element(dis.begin(), dis.begin() + std::ptrdiff_t(m / 2), end);
  f[3] = m ? dis[m / 2] : 0;  // m is odd (kConfidenceNeighbours - 1): the median
  f[4] = height / std::max(dist, 1e-12);
  mean /= double(std::max<size_t>(m, 1));
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (size_t j = 0; j < m; ++j) {
    const Eigen::RowVector3d c = pts.row(idx[j + 1]) - p - mean;
    cov += c.transpose() * c;
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(cov);
  const Eigen::Vector3d lambda = eig.eigenvalues();  // ascending
  f[5] = 1 - std::abs(n.dot(eig.eigenvectors().col(0).transpose()));
  f[6] = 3 * lambda[0] / std::max(lambda.sum(), 1e-30);
  f[7] = log_noise;
  return f;
}

double network(const Row& f, const ConfidenceWeights& w) {
  std::array<double, kInputs> x;
  for (int i = 0; i < kConfidenceFeatures; ++i) x[size_t(i)] = f[i];
  for (int i = 0; i + 1 < kConfidenceFeatures; ++i)
    x[size_t(kConfidenceFeatures + i)] = std::sqrt(std::max(f[i], 0.0));
  for (int i = 0; i < kInputs; ++i)
    x[size_t(i)] = (x[size_t(i)] - w.mean[size_t(i)]) / w.scale[size_t(i)];
  double out = w.b2;
  for (int h = 0; h < kConfidenceHidden; ++h) {
    double a = w.b1[size_t(h)];
    for (int i = 0; i < kInputs; ++i) a += w.w1[size_t(h)][size_t(i)] * x[size_t(i)];
    out += w.w2[size_t(h)] * std::tanh(a);
  }
  return 1 / (1 + std::exp(out));  // the network scores the chance of an error over 30 degrees
}

/// Fills the rows of `out` listed in `rows` from a neighbour table over `pts` / `nrm` (`knn`
/// row r belongs to rows[r]; self first, moved there when a copy came first).
void fill_features(const Points& pts, const Normals& nrm, IndexMatrix& knn,
                   const std::vector<int64_t>& rows, const Eigen::VectorXd& curvature,
                   double noise_ratio, const RunContext& run, Eigen::MatrixXd& out) {
  const int k = int(std::min<Eigen::Index>(knn.cols(), kConfidenceNeighbours));
  const double log_noise = std::log(std::max(noise_ratio, 1e-4));
  detail::Progress progress(run.progress);
  if (run.progress) progress.stage("confidence", 0, 1);
  detail::parallel_for(pts.rows(), run.threads, run.progress ? &progress : nullptr, [&](int64_t r) {
    int32_t* idx = knn.row(r).data();
    int32_t* self = std::find(idx, idx + k, int32_t(r));  // self first even among exact copies
    if (self != idx + k)
      std::iter_swap(idx, self);
    else
      idx[0] = int32_t(r);
    const Eigen::Index row = rows[size_t(r)];
    const double v = curvature.size() == out.rows() ? curvature[row] : 0;
    out.row(row) = point_features(pts, nrm, idx, k, std::isfinite(v) ? v : 0, log_noise);
  });
}

}  // namespace

Eigen::MatrixXd confidence_features(const Points& points, const Normals& normals,
                                    const Eigen::VectorXd& curvature, double noise_ratio,
                                    const RunContext& run, const IndexMatrix* neighbours) {
  const Eigen::Index n = points.rows();
  Eigen::MatrixXd out =
      Eigen::MatrixXd::Constant(n, kConfidenceFeatures, std::numeric_limits<double>::quiet_NaN());
  std::vector<int64_t> rows;  // the points with a normal
  for (Eigen::Index i = 0; i < n; ++i)
    if (normals.row(i).allFinite()) rows.push_back(i);
  if (rows.size() < 2) return out;
  if (neighbours && neighbours->rows() == n && Eigen::Index(rows.size()) == n &&
      neighbours->cols() >= std::min<Eigen::Index>(kConfidenceNeighbours, n)) {
    IndexMatrix knn = neighbours->leftCols(std::min<Eigen::Index>(kConfidenceNeighbours, n));
    fill_features(points, normals, knn, rows, curvature, noise_ratio, run, out);
    return out;
  }
  Points pts(Eigen::Index(rows.size()), 3);
  Normals nrm(Eigen::Index(rows.size()), 3);
  for (size_t r = 0; r < rows.size(); ++r) {
    pts.row(Eigen::Index(r)) = points.row(rows[r]);
    nrm.row(Eigen::Index(r)) = normals.row(rows[r]);
  }
  IndexMatrix knn;  // in the tree's leaf order: the batched search the other stages use
  Neighbors(pts).knn_all(kConfidenceNeighbours, knn, nullptr, detail::narrow(run, 0, 0.6));
  fill_features(pts, nrm, knn, rows, curvature, noise_ratio, detail::narrow(run, 0.6, 1), out);
  return out;
}

Eigen::VectorXd confidence_from_features(const Eigen::MatrixXd& features, ConfidenceModel model) {
  const ConfidenceWeights& w = weights_of(model);
  Eigen::VectorXd out(features.rows());
  detail::parallel_for(features.rows(), 0, nullptr, [&](int64_t i) {
    const Row f = features.row(i);
    out[i] = f.allFinite() ? network(f, w) : std::numeric_limits<double>::quiet_NaN();
  });
  return out;
}

int64_t count_low_confidence(const Eigen::VectorXd& confidence) {
  int64_t n = 0;
  for (Eigen::Index i = 0; i < confidence.size(); ++i) n += confidence[i] < kLowConfidence;
  return n;
}

}  // namespace nhnet
