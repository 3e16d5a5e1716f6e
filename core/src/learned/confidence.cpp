// Per-point confidence of a normal (learned/confidence.hpp; not in the paper, issue 57): eight
// neighbourhood-agreement features per point, then a fixed one-layer tanh network with a
// logistic output per method, weights in confidence_weights.inc (tools/fit_confidence.py).
#include "nhnet/learned/confidence.hpp"

#include "nhnet/neighbors/neighbors.hpp"
#include "util/fast_math.hpp"
#include "util/parallel.hpp"
#include "util/spatial_order.hpp"

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
  // The fitted plane's normal m and smallest eigenvalue (m' cov m); Eigen's solver where the
  // neighbours leave no unique plane.
  Eigen::Vector3d m3;
  if (!detail::smallest_eigenvector(cov, 1e-12, m3)) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
    eig.computeDirect(cov);
    m3 = eig.eigenvectors().col(0);
  }
  f[5] = 1 - std::abs(n.dot(m3.transpose()));
  f[6] = 3 * std::max(m3.dot(cov * m3), 0.0) / std::max(cov.trace(), 1e-30);
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
  std::array<double, kConfidenceHidden> a, t;
  for (int h = 0; h < kConfidenceHidden; ++h) {
    a[size_t(h)] = w.b1[size_t(h)];
    for (int i = 0; i < kInputs; ++i) a[size_t(h)] += w.w1[size_t(h)][size_t(i)] * x[size_t(i)];
  }
  detail::tanh_batch(a.data(), t.data(), a.size());  // libm's tanh was a third of the network
  double out = w.b2;
  for (int h = 0; h < kConfidenceHidden; ++h) out += w.w2[size_t(h)] * t[size_t(h)];
  return 1 / (1 + std::exp(out));  // the network scores the chance of an error over 30 degrees
}

/// The confidence of a row of features: the network's, NaN for a NaN row.
double score(const Row& f, const ConfidenceWeights& w) {
  return f.allFinite() ? network(f, w) : std::numeric_limits<double>::quiet_NaN();
}

/// The points with a normal copied in Morton order (util/spatial_order.hpp), for a search among
/// them: their neighbours then lie in nearby memory (13 % faster at 1M shuffled points). Row j of
/// pts / nrm is input row rows[j].
struct Ordered {
  std::vector<int64_t> rows;
  Points pts;
  Normals nrm;
};

Ordered ordered(const Points& points, const Normals& normals) {
  const Eigen::Index n = points.rows();
  Points with(n, 3);
  std::vector<int64_t> kept;
  for (Eigen::Index i = 0; i < n; ++i)
    if (normals.row(i).allFinite()) {
      with.row(Eigen::Index(kept.size())) = points.row(i);
      kept.push_back(i);
    }
  with.conservativeResize(Eigen::Index(kept.size()), 3);
  const std::vector<int64_t> along = detail::spatial_order(with);
  Ordered o;
  o.rows.resize(kept.size());
  o.pts.resize(Eigen::Index(kept.size()), 3);
  o.nrm.resize(Eigen::Index(kept.size()), 3);
  for (size_t j = 0; j < kept.size(); ++j) {
    o.rows[j] = kept[size_t(along[j])];
    o.pts.row(Eigen::Index(j)) = points.row(o.rows[j]);
    o.nrm.row(Eigen::Index(j)) = normals.row(o.rows[j]);
  }
  return o;
}

/// Calls sink(rows[j], features) for every j < pts.rows(): its neighbours are the first
/// kConfidenceNeighbours entries of knn row j (rows of pts; self first, or moved there when an
/// exact copy came first). `rows` empty: row j is input row j.
template <class Sink>
void each_features(const Points& pts, const Normals& nrm, const IndexMatrix& knn,
                   const std::vector<int64_t>& rows, const Eigen::VectorXd& curvature,
                   double noise_ratio, Eigen::Index n, const RunContext& run, Sink&& sink) {
  const int k = int(std::min<Eigen::Index>(knn.cols(), kConfidenceNeighbours));
  const double log_noise = std::log(std::max(noise_ratio, 1e-4));
  detail::Progress progress(run.progress);
  if (run.progress) progress.stage("confidence", 0, 1);
  detail::parallel_for(pts.rows(), run.threads, run.progress ? &progress : nullptr, [&](int64_t j) {
    const int64_t row = rows.empty() ? j : rows[size_t(j)];
    std::array<int32_t, kConfidenceNeighbours> idx;
    std::copy_n(knn.row(j).data(), k, idx.begin());
    int32_t* self = std::find(idx.data(), idx.data() + k, int32_t(j));
    if (self != idx.data() + k)  // self first even among exact copies
      std::iter_swap(idx.data(), self);
    else
      idx[0] = int32_t(j);
    const double v = curvature.size() == n ? curvature[row] : 0;
    sink(row, point_features(pts, nrm, idx.data(), k, std::isfinite(v) ? v : 0, log_noise));
  });
}

/// Calls sink(input row, features) for every point with a normal. Its neighbours: its row of
/// `neighbours` (input rows) when that table covers every row and every row has a normal, else
/// a batched search among those points.
template <class Sink>
void features_of(const Points& points, const Normals& normals, const Eigen::VectorXd& curvature,
                 double noise_ratio, const RunContext& run, const IndexMatrix* neighbours,
                 Sink&& sink) {
  const Eigen::Index n = points.rows();
  Eigen::Index with = 0;
  for (Eigen::Index i = 0; i < n; ++i) with += normals.row(i).allFinite();
  if (with < 2) return;
  if (neighbours && neighbours->rows() == n && with == n &&
      neighbours->cols() >= std::min<Eigen::Index>(kConfidenceNeighbours, n)) {
    each_features(points, normals, *neighbours, {}, curvature, noise_ratio, n, run, sink);
    return;
  }
  const Ordered o = ordered(points, normals);
  IndexMatrix knn;
  Neighbors(o.pts).knn_all(kConfidenceNeighbours, knn, nullptr, detail::narrow(run, 0, 0.6));
  each_features(o.pts, o.nrm, knn, o.rows, curvature, noise_ratio, n, detail::narrow(run, 0.6, 1),
                sink);
}

}  // namespace

Eigen::MatrixXd confidence_features(const Points& points, const Normals& normals,
                                    const Eigen::VectorXd& curvature, double noise_ratio,
                                    const RunContext& run, const IndexMatrix* neighbours) {
  Eigen::MatrixXd out = Eigen::MatrixXd::Constant(points.rows(), kConfidenceFeatures,
                                                  std::numeric_limits<double>::quiet_NaN());
  features_of(points, normals, curvature, noise_ratio, run, neighbours,
              [&](Eigen::Index row, const Row& f) { out.row(row) = f; });
  return out;
}

Eigen::VectorXd normal_confidence(const Points& points, const Normals& normals,
                                  const Eigen::VectorXd& curvature, double noise_ratio,
                                  ConfidenceModel model, const RunContext& run,
                                  const IndexMatrix* neighbours) {
  const ConfidenceWeights& w = weights_of(model);
  Eigen::VectorXd out =
      Eigen::VectorXd::Constant(points.rows(), std::numeric_limits<double>::quiet_NaN());
  features_of(points, normals, curvature, noise_ratio, run, neighbours,
              [&](Eigen::Index row, const Row& f) { out[row] = score(f, w); });
  return out;
}

Eigen::VectorXd confidence_from_features(const Eigen::MatrixXd& features, ConfidenceModel model) {
  const ConfidenceWeights& w = weights_of(model);
  Eigen::VectorXd out(features.rows());
  detail::parallel_for(features.rows(), 0, nullptr,
                       [&](int64_t i) { out[i] = score(features.row(i), w); });
  return out;
}

int64_t count_low_confidence(const Eigen::VectorXd& confidence) {
  int64_t n = 0;
  for (Eigen::Index i = 0; i < confidence.size(); ++i) n += confidence[i] < kLowConfidence;
  return n;
}

}  // namespace nhnet
