// The PCA blend of MFPS (MfpsOptions::pca_blend): not the paper's. A logistic weight, fitted by
// tools/fit_mfps_blend.py, of a quadratic form of features of the two-face selection; each
// candidate with a rival is rotated towards its PCA normal by that weight. Within about one
// noise sigma of an edge the face a point came from cannot be told, and the large-k PCA plane
// (close to the bisector) is then the lower-RMS answer; the weight learns where.
#include "geometry/mfps_blend.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace nhnet::detail {

namespace {

/// Coefficients of the PCA blend (MfpsOptions::pca_blend): the weight is logistic in the
/// features listed at kMfpsBlendFeatures (mfps.hpp; the first is the intercept) and in every
/// product f_a f_b of the others (a <= b), in that order. Fitted by tools/fit_mfps_blend.py on
/// the training split only (16 CAD models x noise 0, 0.1, 0.3, 0.6 %), minimising the mean over
/// clouds of each cloud's mean squared angle error.
constexpr int kBlendTerms = kMfpsBlendFeatures + (kMfpsBlendFeatures - 1) * kMfpsBlendFeatures / 2;
constexpr std::array<double, kBlendTerms> kBlendCoefficients = {
    -10.1513, 9.9937,   9.9467,  12.9313, 10.8916, 0.7740,   -5.0653,  3.7326,   -17.1129, 4.5568,
    -6.6447,  -10.1199, -2.9107, 7.3286,  2.5403,  3.6367,   1.1171,   -3.1667,  -2.1574,  4.8027,
    -3.2419,  21.8807,  2.1296,  -5.0413, -4.7616, -8.9267,  -10.9376, -0.1804,  -3.9886,  18.3819,
    -13.3190, 0.6775,   10.8244, 7.1389,  1.8630,  -7.0517,  -4.5196,  -9.2979,  16.8540,  -9.0520,
    -4.4069,  -12.1928, 5.6721,  -1.7275, -6.2057, 0.5574,   17.8402,  -13.5824, 9.7896,   -7.1143,
    -7.1633,  2.8672,   3.8743,  4.4842,  -8.2935, -25.4468, 4.7612,   3.6603,   -1.3430,  -2.9200,
    -1.9569,  -7.7737,  7.4409,  0.7988,  9.1016,  -9.8816,  2.2430,   9.8905,   -34.1429, 20.6593,
    10.9414,  -12.3863, 24.0922, -3.1473, 7.4772,  1.7031,   2.7787,   -1.5789};

/// Weight of the PCA normal in the final normal of a candidate.
double blend_weight(const BlendFeatures& f) {
  double z = 0;
  int term = 0;
  for (int a = 0; a < kMfpsBlendFeatures; ++a)
    z += kBlendCoefficients[size_t(term++)] * f[size_t(a)];
  for (int a = 1; a < kMfpsBlendFeatures; ++a)
    for (int b = a; b < kMfpsBlendFeatures; ++b)
      z += kBlendCoefficients[size_t(term++)] * f[size_t(a)] * f[size_t(b)];
  return 1.0 / (1.0 + std::exp(-std::clamp(z, -50.0, 50.0)));
}

/// Unoriented angle between unit vectors, radians.
double line_angle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::min(1.0, std::abs(a.dot(b))));
}

/// Keeps the features and the normals before the blend in `res` (for fitting the blend).
void record_features(const std::vector<BlendFeatures>& features, MfpsResult& res) {
  res.unblended_normals = res.normals;
  res.blend_features.resize(Eigen::Index(features.size()), kMfpsBlendFeatures);
  for (size_t t = 0; t < features.size(); ++t)
    for (int q = 0; q < kMfpsBlendFeatures; ++q)
      res.blend_features(Eigen::Index(t), q) = features[t][size_t(q)];
}

}  // namespace

double inconsistency(const Normals& normals, const IndexMatrix& knn, Eigen::Index i, int k) {
  const int kk = int(std::min<Eigen::Index>(k, knn.cols()));
  const Eigen::Vector3d ni = normals.row(i).transpose();
  double sum = 0;
  int used = 0;
  for (int t = 0; t < kk; ++t) {
    const Eigen::Vector3d nj = normals.row(knn(i, t)).transpose();
    if (!nj.allFinite()) continue;
    sum += std::abs(ni.dot(nj));
    ++used;
  }
  return used ? 1.0 - sum / used : 0.0;
}

Eigen::Vector3d slerp_towards(const Eigen::Vector3d& a, Eigen::Vector3d b, double t) {
  if (b.dot(a) < 0) b = -b;
  const double theta = std::acos(std::clamp(a.dot(b), -1.0, 1.0));
  if (!(theta > 1e-9)) return a;
  const Eigen::Vector3d v =
      (std::sin((1 - t) * theta) * a + std::sin(t * theta) * b) / std::sin(theta);
  return v.allFinite() && v.norm() > 0.5 ? Eigen::Vector3d(v.normalized()) : a;
}

BlendFeatures blend_features(const TwoFaceChoice& choice, const Eigen::Vector3d& pca,
                             double sigma) {
  const double p = choice.p, p_score = choice.p_score, geo = choice.p_edge;
  const double theta = line_angle(choice.winner, choice.rival);
  const double a_pca_win = line_angle(pca, choice.winner);
  BlendFeatures f{};
  f[0] = 1;                               // intercept
  f[1] = 4 * p * (1 - p);                 // uncertainty of the final posterior
  f[2] = theta;                           // winner-rival angle (rad)
  f[3] = line_angle(pca, choice.normal);  // PCA vs this normal (rad)
  f[4] = std::min(choice.line_distance / (0.5 * sigma), 10.0) / 10;  // to the edge line
  f[5] = 4 * p_score * (1 - p_score);                        // uncertainty of the score posterior
  f[6] = geo >= 0 ? std::abs(2 * geo - 1) : 0;               // confidence of the edge posterior
  f[7] = a_pca_win + line_angle(pca, choice.rival) - theta;  // PCA off the winner-rival arc (rad)
  f[10] = std::log(std::max(choice.score, 1e-6));            // winner's score D (Eq. 4)
  f[11] = a_pca_win;                                         // PCA vs winner (rad)
  for (double& v : f)
    if (!std::isfinite(v)) v = 0;
  return f;
}

void blend_towards_pca(BlendCandidates candidates, const IndexMatrix& knn,
                       const Normals& base_normals, const MfpsOptions& options, MfpsResult& res) {
  std::vector<BlendFeatures>& features = candidates.features;
  // The neighbourhood features read the normals before any blending (all of them first, then
  // the blend), so the result does not depend on the order in which points are blended.
  for (size_t t = 0; t < candidates.rows.size(); ++t) {
    const Eigen::Index i = candidates.rows[t];
    features[t][8] = inconsistency(res.normals, knn, i, kBlendNeighbours);
    features[t][9] = inconsistency(base_normals, knn, i, kBlendNeighbours);
  }
  std::vector<double> weights(features.size());
  for (size_t t = 0; t < features.size(); ++t) weights[t] = blend_weight(features[t]);
  if (options.record_blend_features) record_features(features, res);
  if (options.pca_blend)
    for (size_t t = 0; t < candidates.rows.size(); ++t) {
      const Eigen::Index i = candidates.rows[t];
      res.normals.row(i) =
          slerp_towards(res.normals.row(i).transpose(), base_normals.row(i).transpose(), weights[t])
              .transpose();
    }
  if (options.record_blend_features || options.keep_blend_weights) {
    res.blend_weights = std::move(weights);
    res.blend_rows = std::move(candidates.rows);
  }
}

}  // namespace nhnet::detail
