// The multi-scale point descriptor (paper Eq. 7); see descriptors.hpp.
#include "nhnet/learned/descriptors.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/neighbors/neighbors.hpp"
#include "util/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace nhnet {

int descriptor_size(const DescriptorOptions& options) {
  const int f = 1 + int(options.filter.sigma_s.size() * options.filter.sigma_r.size());
  return 3 * f + f * options.map.size * options.map.size;
}

void compute_descriptors(const Points& points, const Normals& normals, const IndexMatrix& knn,
                         int k, const DescriptorOptions& options, DescriptorMatrix& features,
                         Rotations& rotations, const RunContext& run, Eigen::Index first) {
  const FeatureNormals filtered =
      bilateral_filter(points, normals, knn, k, options.filter, detail::narrow(run, 0, 0.4), first);
  CanonicalFrames frames =
      canonical_frames(points, knn, k, filtered, detail::narrow(run, 0.4, 0.5), first);
  const HeightMaps maps =
      height_maps(points, knn, k, frames, options.map, detail::narrow(run, 0.5, 1), first);
  const Eigen::Index n = knn.rows(), nf = filtered.cols();
  detail::resize_fresh(features, n, nf + maps.cols());
  features.leftCols(nf) = frames.rotated.cast<float>();
  features.rightCols(maps.cols()) = maps;
  rotations = std::move(frames.rotations);
}

DescriptorInput prepare_descriptors(const Points& points, const DescriptorOptions& options) {
  if (!(options.neighborhood_factor > 0))
    throw InvalidOptions("descriptor neighborhood factor must be > 0");
  DescriptorInput in;
  EstimateOptions eo = options.estimate;
  eo.method = Method::Mfps;
  eo.mfps_pca_blend = options.mfps_pca_blend;
  eo.run = detail::narrow(options.estimate.run, 0, 0.9);
  in.geometry = estimate_normals(points, eo);
  const Eigen::Index n = points.rows();
  for (Eigen::Index i = 0; i < n; ++i)
    if (in.geometry.valid[size_t(i)]) in.rows.push_back(i);
  const Eigen::Index m = Eigen::Index(in.rows.size());
  if (m <= options.filter.spacing_k) {
    in.geometry.warnings.push_back("too few points with a normal for descriptors");
    in.rows.clear();
    return in;
  }
  in.points.resize(m, 3);
  in.normals.resize(m, 3);
  for (Eigen::Index i = 0; i < m; ++i) {
    in.points.row(i) = points.row(in.rows[size_t(i)]);
    in.normals.row(i) = in.geometry.normals.row(in.rows[size_t(i)]);
  }
  const auto& sc = in.geometry.scales_used;
  const int kmin = sc.empty() ? 50 : *std::min_element(sc.begin(), sc.end());
  in.k = int(std::min<Eigen::Index>(
      m, std::max(options.filter.spacing_k + 1,
                  int(std::ceil(options.neighborhood_factor * kmin - 1e-9)))));
  Neighbors tree(in.points);
  tree.knn_all(in.k, in.knn, nullptr, detail::narrow(options.estimate.run, 0.9, 1));
  return in;
}

Descriptors describe(const Points& points, const DescriptorOptions& options) {
  DescriptorOptions o = options;
  o.estimate.run = detail::narrow(options.estimate.run, 0, 0.8);
  DescriptorInput in = prepare_descriptors(points, o);
  Descriptors out;
  const Eigen::Index n = points.rows();
  out.features.setConstant(n, descriptor_size(options), std::numeric_limits<float>::quiet_NaN());
  out.rotations.setConstant(n, 9, std::numeric_limits<double>::quiet_NaN());
  out.k_used = in.k;
  if (!in.rows.empty()) {
    DescriptorMatrix feat;
    Rotations rot;
    compute_descriptors(in.points, in.normals, in.knn, in.k, options, feat, rot,
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
