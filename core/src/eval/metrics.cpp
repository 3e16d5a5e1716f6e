// Accuracy metrics (benchmark protocol): unoriented angle error acos(min(1, |n . g|)) in degrees,
// mean, RMS, PGP5, PGP10, share over 30 degrees.
#include "nhnet/eval/metrics.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/neighbors/neighbors.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace nhnet {

Eigen::VectorXd angle_errors_deg(const Normals& estimated, const Normals& ground_truth) {
  if (estimated.rows() != ground_truth.rows())
    throw InvalidOptions("angle errors: " + std::to_string(estimated.rows()) + " estimated vs " +
                         std::to_string(ground_truth.rows()) + " ground-truth normals");
  const double rad2deg = 180.0 / M_PI;
  Eigen::VectorXd e(estimated.rows());
  for (Eigen::Index i = 0; i < estimated.rows(); ++i) {
    const Eigen::Vector3d a = estimated.row(i).transpose(), b = ground_truth.row(i).transpose();
    const double na = a.norm(), nb = b.norm();
    if (!std::isfinite(na) || !std::isfinite(nb) || na == 0 || nb == 0) {
      e[i] = std::numeric_limits<double>::quiet_NaN();
      continue;
    }
    const double c = std::min(1.0, std::abs(a.dot(b)) / (na * nb));
    e[i] = std::acos(c) * rad2deg;
  }
  return e;
}

AngleStats angle_stats(const Eigen::VectorXd& errors_deg) {
  AngleStats s;
  double sum = 0, sum2 = 0;
  int64_t below5 = 0, below10 = 0, above30 = 0;
  for (Eigen::Index i = 0; i < errors_deg.size(); ++i) {
    const double e = errors_deg[i];
    if (!std::isfinite(e)) {
      ++s.invalid;
      continue;
    }
    ++s.count;
    sum += e;
    sum2 += e * e;
    below5 += e < 5.0;
    below10 += e < 10.0;
    above30 += e > 30.0;
  }
  if (s.count > 0) {
    const double c = double(s.count);
    s.mean = sum / c;
    s.rms = std::sqrt(sum2 / c);
    s.pgp5 = double(below5) / c;
    s.pgp10 = double(below10) / c;
    s.over30 = double(above30) / c;
  }
  return s;
}

AngleStats angle_stats(const Normals& estimated, const Normals& ground_truth) {
  return angle_stats(angle_errors_deg(estimated, ground_truth));
}

Eigen::VectorXd surface_distances(const Points& points, const Points& reference,
                                  const Normals& reference_normals) {
  if (reference.rows() == 0) throw InvalidOptions("surface distances: empty reference");
  const bool planes = reference_normals.rows() > 0;
  if (planes && reference_normals.rows() != reference.rows())
    throw InvalidOptions("surface distances: " + std::to_string(reference_normals.rows()) +
                         " normals for " + std::to_string(reference.rows()) + " reference points");
  const Neighbors tree(reference);
  Eigen::VectorXd d(points.rows());
  std::vector<int32_t> idx;
  std::vector<float> d2;
  for (Eigen::Index i = 0; i < points.rows(); ++i) {
    const Eigen::Vector3d p = points.row(i).transpose();
    if (!p.allFinite()) {
      d[i] = std::numeric_limits<double>::quiet_NaN();
      continue;
    }
    tree.knn(p, 1, idx, d2);
    const Eigen::Vector3d off = p - reference.row(idx[0]).transpose();
    const Eigen::Vector3d n =
        planes ? reference_normals.row(idx[0]).transpose().normalized() : Eigen::Vector3d::Zero();
    d[i] = planes && n.allFinite() ? std::abs(off.dot(n)) : off.norm();
  }
  return d;
}

}  // namespace nhnet
