// The multi-scale point descriptor (paper Eq. 7); see descriptors.hpp.
#include "nhnet/learned/descriptors.hpp"

#include "nhnet/errors.hpp"
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

}  // namespace nhnet
