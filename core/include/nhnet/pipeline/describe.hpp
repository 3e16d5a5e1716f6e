// The descriptor chain of a whole cloud (paper Sec. 5.1): the geometry stage (MFPS normals,
// estimate.hpp), then the multi-scale point descriptor of every point that got a normal
// (learned/descriptors.hpp). Training (through the Python bindings) and inference (NH-Net in
// estimate_normals) both take their descriptors from here, so they agree.
#pragma once

#include "nhnet/learned/descriptors.hpp"
#include "nhnet/pipeline/estimate.hpp"

#include <vector>

namespace nhnet {

struct DescribeOptions {
  /// The descriptor itself (filter widths, height maps, neighbourhood factor).
  DescriptorOptions descriptor;
  /// Geometry stage (MFPS; `method` and `mfps.pca_blend` are ignored) and threads / progress.
  EstimateOptions estimate;
  /// MFPS PCA blend of the geometry stage. Off: the shipped models (v6, v7) were trained on MFPS
  /// normals without it, and training and inference both come through here, so they agree.
  bool mfps_pca_blend = false;
};

struct Descriptors {
  /// N x D descriptors (NaN rows where valid == 0).
  DescriptorMatrix features;
  /// N x 9 canonical rotations (world -> frame), row-major 3 x 3.
  Rotations rotations;
  /// The geometry stage's result: MFPS normals, valid flags, spacing, scales.
  EstimateResult geometry;
  /// Descriptor neighbourhood size that was used.
  int k_used = 0;
};

/// What the descriptors of a cloud need, computed once: the geometry stage's result (MFPS
/// normals), the input rows that have a normal, those points, normals and their k-NN table.
struct DescriptorInput {
  EstimateResult geometry;
  /// Input rows of the points with a normal: the described ones first.
  std::vector<Eigen::Index> rows;
  /// Those points and their normals, in the order of `rows`.
  Points points;
  Normals normals;
  /// described x K neighbour table (indices into `points`, K >= k: the first k columns are the k
  /// nearest) of the first `described` points.
  IndexMatrix knn;
  int k = 0;
  /// How many of the leading points are described (all of them unless a caller chose some).
  Eigen::Index described = 0;
};

/// Runs the geometry stage (estimate_normals, MFPS) and builds the neighbour table of the points
/// with a normal (k = descriptor_k(smallest MFPS scale)). Fewer than spacing_k + 1 such points
/// leave `rows` empty (with a warning).
DescriptorInput prepare_descriptors(const Points& points, const DescribeOptions& options);

/// The whole chain for a cloud: MFPS normals (estimate_normals), then the descriptors of every
/// point with a valid normal. Throws like estimate_normals.
Descriptors describe(const Points& points, const DescribeOptions& options = {});

}  // namespace nhnet
