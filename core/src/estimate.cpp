// The estimation pipeline (paper Sec. 3-4): finite-point filtering, one kd-tree, noise-driven
// scale choice, PCA for smooth points and MFPS near sharp features.
#include "nhnet/estimate.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/neighbors.hpp"
#include "nhnet/pca.hpp"
#include "parallel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace nhnet {

Method method_from_string(const std::string& name) {
  if (name == "pca") return Method::Pca;
  if (name == "mfps") return Method::Mfps;
  throw InvalidOptions("unknown method '" + name + "' (expected pca or mfps)");
}

const char* to_string(Method method) {
  switch (method) {
    case Method::Pca: return "pca";
    case Method::Mfps: return "mfps";
  }
  return "?";
}

int64_t orient_like(Normals& normals, const Normals& reference) {
  if (normals.rows() != reference.rows())
    throw InvalidOptions("orient_like: normals and reference differ in size");
  int64_t flipped = 0;
  for (Eigen::Index i = 0; i < normals.rows(); ++i) {
    const double d = normals.row(i).dot(reference.row(i));
    if (std::isfinite(d) && d < 0) {
      normals.row(i) *= -1.0;
      ++flipped;
    }
  }
  return flipped;
}

}  // namespace nhnet

namespace nhnet {

EstimateResult estimate_normals(const Points& points, const EstimateOptions& options) {
  if (options.k < 0 || options.k == 1 || options.k == 2)
    throw InvalidOptions("k must be 0 (auto) or at least 3, got " + std::to_string(options.k));
  for (int s : options.scales)
    if (s < 3) throw InvalidOptions("every scale must be at least 3, got " + std::to_string(s));
  if (options.run.threads < 0) throw InvalidOptions("threads must be >= 0");

  EstimateResult res;
  const Eigen::Index n = points.rows();
  res.normals.setConstant(n, 3, std::numeric_limits<double>::quiet_NaN());
  res.valid.assign(size_t(n), 0);

  // Finite points only: a non-finite point neither gets a normal nor disturbs its neighbours.
  std::vector<int64_t> finite;
  finite.reserve(size_t(n));
  for (Eigen::Index i = 0; i < n; ++i)
    if (points.row(i).allFinite()) finite.push_back(i);
  if (finite.size() < 3)
    throw UnprocessableInput("only " + std::to_string(finite.size()) +
                             " finite points; at least 3 are needed");
  if (Eigen::Index(finite.size()) < n)
    res.warnings.push_back(std::to_string(n - Eigen::Index(finite.size())) +
                           " non-finite points skipped (reported as failed)");
  Points pts(Eigen::Index(finite.size()), 3);
  for (size_t i = 0; i < finite.size(); ++i) pts.row(Eigen::Index(i)) = points.row(finite[i]);

  const int k = options.k > 0 ? options.k : 35;
  res.k_used = int(std::min<Eigen::Index>(k, pts.rows()));
  Neighbors tree(pts);
  IndexMatrix knn;
  tree.knn_all(res.k_used, knn, nullptr, options.run);
  const PcaResult pca = pca_normals(pts, knn, PcaOptions{res.k_used}, options.run);

  for (size_t i = 0; i < finite.size(); ++i) {
    const Eigen::RowVector3d nrm = pca.normals.row(Eigen::Index(i));
    if (nrm.allFinite()) {
      res.normals.row(finite[i]) = nrm;
      res.valid[size_t(finite[i])] = 1;
    }
  }
  res.failed = int64_t(std::count(res.valid.begin(), res.valid.end(), uint8_t(0)));
  return res;
}

}  // namespace nhnet
