// The multi-scale point descriptor (paper Eq. 7); see descriptors.hpp.
#include "nhnet/learned/descriptors.hpp"

#include "nhnet/errors.hpp"
#include "util/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace nhnet {

int descriptor_size(const DescriptorOptions& options) {
  const int f = 1 + int(options.filter.sigma_s.size() * options.filter.sigma_r.size());
  return 3 * f + f * options.map.size * options.map.size;
}

DescriptorOptions descriptor_options(int version) {
  if (version < kOldestDescriptorVersion || version > kDescriptorVersion)
    throw InvalidOptions("descriptor version must be " + std::to_string(kOldestDescriptorVersion) +
                         ".." + std::to_string(kDescriptorVersion) + ", got " +
                         std::to_string(version));
  DescriptorOptions options;
  if (version == 1) options.max_neighbours = 0;
  return options;
}

namespace {

/// The `keep` of the first k columns of `knn` (k > keep > near) the descriptor sees: the first
/// `near` (self and the spacing neighbours), then keep - near evenly spaced over the rest, the
/// k-th (the farthest) last.
std::vector<int> descriptor_columns(int k, int keep, int near) {
  std::vector<int> cols;
  for (int c = 0; c < near; ++c) cols.push_back(c);
  const int rest = keep - near, span = k - near;  // columns near .. k - 1
  for (int j = 1; j <= rest; ++j) cols.push_back(near + int(int64_t(j) * span / rest) - 1);
  return cols;
}

}  // namespace

void compute_descriptors(const Points& points, const Normals& normals, const IndexMatrix& knn,
                         int k, const DescriptorOptions& options, DescriptorMatrix& features,
                         Rotations& rotations, const RunContext& run, Eigen::Index first) {
  const int keep = options.max_neighbours, near = options.filter.spacing_k + 1;
  if (keep > near && k > keep) {  // version 2 on a large neighbourhood: the spread-out subset
    const std::vector<int> cols = descriptor_columns(k, keep, near);
    IndexMatrix seen(knn.rows(), Eigen::Index(cols.size()));
    for (Eigen::Index r = 0; r < seen.rows(); ++r)
      for (Eigen::Index c = 0; c < seen.cols(); ++c) seen(r, c) = knn(r, cols[size_t(c)]);
    compute_descriptors(points, normals, seen, int(cols.size()), options, features, rotations, run,
                        first);
    return;
  }
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

}  // namespace nhnet
