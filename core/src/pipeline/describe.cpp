// The descriptor chain of a whole cloud (paper Sec. 5.1; describe.hpp): the geometry stage, then
// the descriptor neighbourhoods and the descriptors of every point that got a normal.
#include "nhnet/pipeline/describe.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/neighbors/neighbors.hpp"
#include "pipeline/estimator.hpp"
#include "util/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace nhnet {

int descriptor_k(int kmin, const DescriptorOptions& options, Eigen::Index m) {
  return int(std::min<Eigen::Index>(
      m, std::max(options.filter.spacing_k + 1,
                  int(std::ceil(options.neighborhood_factor * kmin - 1e-9)))));
}

namespace detail {

EstimateOptions geometry_options(const EstimateOptions& options, bool pca_blend) {
  EstimateOptions eo = options;
  eo.method = Method::Mfps;
  eo.mfps.pca_blend = pca_blend;
  eo.run = narrow(options.run, 0, 0.9);
  return eo;
}

DescriptorInput descriptor_input(const Points& points, EstimateResult geometry,
                                 const DescriptorOptions& options, const RunContext& run,
                                 const std::vector<uint8_t>* only) {
  DescriptorInput in;
  in.geometry = std::move(geometry);
  const auto& valid = in.geometry.valid;
  for (Eigen::Index i = 0; i < points.rows(); ++i)
    if (valid[size_t(i)] && (!only || (*only)[size_t(i)])) in.rows.push_back(i);
  in.described = Eigen::Index(in.rows.size());
  if (only)  // the other points with a normal follow: neighbours, not described
    for (Eigen::Index i = 0; i < points.rows(); ++i)
      if (valid[size_t(i)] && !(*only)[size_t(i)]) in.rows.push_back(i);
  const Eigen::Index m = Eigen::Index(in.rows.size());
  if (m <= options.filter.spacing_k) {
    in.geometry.warnings.push_back("too few points with a normal for descriptors");
    in.rows.clear();
    in.described = 0;
    return in;
  }
  in.points.resize(m, 3);
  in.normals.resize(m, 3);
  for (Eigen::Index i = 0; i < m; ++i) {
    in.points.row(i) = points.row(in.rows[size_t(i)]);
    in.normals.row(i) = in.geometry.normals.row(in.rows[size_t(i)]);
  }
  const auto& sc = in.geometry.scales_used;
  in.k = descriptor_k(sc.empty() ? 50 : *std::min_element(sc.begin(), sc.end()), options, m);
  Neighbors tree(in.points);
  if (in.described == m) {
    tree.knn_all(in.k, in.knn, nullptr, run);
  } else {
    std::vector<int64_t> first(size_t(in.described));
    std::iota(first.begin(), first.end(), int64_t(0));
    tree.knn_rows(in.k, first, in.knn, nullptr, run);
  }
  return in;
}

}  // namespace detail

DescriptorInput prepare_descriptors(const Points& points, const DescribeOptions& options) {
  if (!(options.descriptor.neighborhood_factor > 0))
    throw InvalidOptions("descriptor neighborhood factor must be > 0");
  const EstimateOptions eo = detail::geometry_options(options.estimate, options.mfps_pca_blend);
  return detail::descriptor_input(points, estimate_normals(points, eo), options.descriptor,
                                  detail::narrow(options.estimate.run, 0.9, 1));
}

Descriptors describe(const Points& points, const DescribeOptions& options) {
  DescribeOptions o = options;
  o.estimate.run = detail::narrow(options.estimate.run, 0, 0.8);
  DescriptorInput in = prepare_descriptors(points, o);
  Descriptors out;
  const Eigen::Index n = points.rows();
  out.features.setConstant(n, descriptor_size(options.descriptor),
                           std::numeric_limits<float>::quiet_NaN());
  out.rotations.setConstant(n, 9, std::numeric_limits<double>::quiet_NaN());
  out.k_used = in.k;
  if (!in.rows.empty()) {
    DescriptorMatrix feat;
    Rotations rot;
    compute_descriptors(in.points, in.normals, in.knn, in.k, options.descriptor, feat, rot,
                        detail::narrow(options.estimate.run, 0.8, 1));
    for (size_t i = 0; i < in.rows.size(); ++i) {
      out.features.row(in.rows[i]) = feat.row(Eigen::Index(i));
      out.rotations.row(in.rows[i]) = rot.row(Eigen::Index(i));
    }
  }
  out.geometry = std::move(in.geometry);
  return out;
}

}  // namespace nhnet
