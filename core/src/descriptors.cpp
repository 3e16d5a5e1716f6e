// The multi-scale point descriptor (paper Eq. 7); see descriptors.hpp.
#include "nhnet/descriptors.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/neighbors.hpp"
#include "parallel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace nhnet {

namespace {
RunContext narrow(const RunContext& run, double begin, double end) {
  RunContext r;
  r.threads = run.threads;
  if (run.progress) {
    ProgressCallback cb = run.progress;
    r.progress = [cb, begin, end](double f, const std::string& stage) {
      return cb(begin + (end - begin) * f, stage);
    };
  }
  return r;
}
}  // namespace

int descriptor_size(const DescriptorOptions& options) {
  const int f = 1 + int(options.filter.sigma_s.size() * options.filter.sigma_r.size());
  return 3 * f + f * options.map.size * options.map.size;
}

void compute_descriptors(const Points& points, const Normals& normals, const IndexMatrix& knn,
                         int k, const DescriptorOptions& options, DescriptorMatrix& features,
                         Rotations& rotations, const RunContext& run) {
  const FeatureNormals filtered =
      bilateral_filter(points, normals, knn, k, options.filter, narrow(run, 0, 0.4));
  CanonicalFrames frames = canonical_frames(points, knn, k, filtered, narrow(run, 0.4, 0.5));
  const HeightMaps maps = height_maps(points, knn, k, frames, options.map, narrow(run, 0.5, 1));
  const Eigen::Index n = points.rows(), nf = filtered.cols();
  features.resize(n, nf + maps.cols());
  features.leftCols(nf) = frames.rotated.cast<float>();
  features.rightCols(maps.cols()) = maps;
  rotations = std::move(frames.rotations);
}

Descriptors describe(const Points& points, const DescriptorOptions& options) {
  if (!(options.neighborhood_factor > 0))
    throw InvalidOptions("descriptor neighborhood factor must be > 0");
  Descriptors out;
  EstimateOptions eo = options.estimate;
  eo.method = Method::Mfps;
  eo.run = narrow(options.estimate.run, 0, 0.7);
  out.geometry = estimate_normals(points, eo);
  const Eigen::Index n = points.rows();
  const int d = descriptor_size(options);
  out.features.setConstant(n, d, std::numeric_limits<float>::quiet_NaN());
  out.rotations.setConstant(n, 9, std::numeric_limits<double>::quiet_NaN());

  std::vector<Eigen::Index> rows;
  for (Eigen::Index i = 0; i < n; ++i)
    if (out.geometry.valid[size_t(i)]) rows.push_back(i);
  const Eigen::Index m = Eigen::Index(rows.size());
  if (m <= options.filter.spacing_k) {
    out.geometry.warnings.push_back("too few points with a normal for descriptors");
    return out;
  }
  Points pts(m, 3);
  Normals nrm(m, 3);
  for (Eigen::Index i = 0; i < m; ++i) {
    pts.row(i) = points.row(rows[size_t(i)]);
    nrm.row(i) = out.geometry.normals.row(rows[size_t(i)]);
  }
  const int kmin = out.geometry.scales_used.empty()
                       ? 50
                       : *std::min_element(out.geometry.scales_used.begin(),
                                           out.geometry.scales_used.end());
  const int k = int(std::min<Eigen::Index>(
      m, std::max(options.filter.spacing_k + 1,
                  int(std::ceil(options.neighborhood_factor * kmin - 1e-9)))));
  out.k_used = k;
  const RunContext& run = options.estimate.run;
  Neighbors tree(pts);
  IndexMatrix knn;
  tree.knn_all(k, knn, nullptr, narrow(run, 0.7, 0.8));
  DescriptorMatrix feat;
  Rotations rot;
  compute_descriptors(pts, nrm, knn, k, options, feat, rot, narrow(run, 0.8, 1));
  for (Eigen::Index i = 0; i < m; ++i) {
    out.features.row(rows[size_t(i)]) = feat.row(i);
    out.rotations.row(rows[size_t(i)]) = rot.row(i);
  }
  return out;
}

}  // namespace nhnet
