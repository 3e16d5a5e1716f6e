// The multi-scale point descriptor MPD (paper Sec. 5.1, Eq. 7) as one fixed-size float vector per
// point: the F = 9 normals of the bilateral filter (Eq. 5) rotated into the point's canonical
// frame, followed by their F height maps (Eq. 6). Layout of a row (D = 3 F + F m^2 = 468 with
// the paper's values): [f_1x f_1y f_1z ... f_Fx f_Fy f_Fz | map_1[0][0] ... map_F[m-1][m-1]].
// The descriptor's neighbourhood follows the noise-driven scale rule of MFPS: k = ceil(1.5 Kmin)
// with Kmin the smallest MFPS scale chosen for the cloud (authors: 1.5 * 50 = 75), so patches are
// comparable at every noise level. The same call feeds training (Python bindings) and inference.
#pragma once

#include "nhnet/learned/bilateral_filter.hpp"
#include "nhnet/learned/canonical_frame.hpp"
#include "nhnet/pipeline/estimate.hpp"
#include "nhnet/learned/height_map.hpp"
#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

#include <string>
#include <vector>

namespace nhnet {

/// Bumped whenever the descriptor's definition changes; models record the version they saw.
constexpr int kDescriptorVersion = 1;
/// Name of the height normalisation (recorded in models, checked by the loader).
constexpr const char* kHeightNormalisation = "cell";

using DescriptorMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct DescriptorOptions {
  /// Bilateral filter widths (paper values by default).
  BilateralFilterOptions filter;
  /// Height-map grid (paper: 7 x 7).
  HeightMapOptions map;
  /// Descriptor neighbourhood = ceil(factor * smallest MFPS scale). Authors' code: 1.5.
  double neighborhood_factor = 1.5;
  /// Geometry stage (MFPS; `method` and `mfps_pca_blend` are ignored) and threads / progress.
  EstimateOptions estimate;
  /// MFPS PCA blend of the geometry stage. Off: the shipped model (v6) was trained on MFPS
  /// normals without it, and training and inference both come through here, so they agree.
  bool mfps_pca_blend = false;
};

/// Number of floats per point for these options.
int descriptor_size(const DescriptorOptions& options = {});

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

/// Descriptors of points that already have normals: `points` and `normals` (N x 3, all rows
/// finite), `knn` the neighbour table (M x K, K >= k) of points `first` .. `first` + M - 1, so
/// a cloud can be described block by block. Writes M x D features and the M rotations.
void compute_descriptors(const Points& points, const Normals& normals, const IndexMatrix& knn,
                         int k, const DescriptorOptions& options, DescriptorMatrix& features,
                         Rotations& rotations, const RunContext& run = {},
                         Eigen::Index first = 0);

/// What the descriptors of a cloud need, computed once: the geometry stage's result (MFPS
/// normals), the input rows that have a normal, those points, normals and their k-NN table.
struct DescriptorInput {
  EstimateResult geometry;
  std::vector<Eigen::Index> rows;
  Points points;
  Normals normals;
  IndexMatrix knn;
  int k = 0;
};

/// Runs the geometry stage (estimate_normals, MFPS) and builds the neighbour table of the points
/// with a normal (k = ceil(factor * smallest MFPS scale)). Fewer than spacing_k + 1 such points
/// leave `rows` empty (with a warning).
DescriptorInput prepare_descriptors(const Points& points, const DescriptorOptions& options);

/// The whole chain for a cloud: MFPS normals (estimate_normals), then the descriptors of every
/// point with a valid normal. Throws like estimate_normals.
Descriptors describe(const Points& points, const DescriptorOptions& options = {});

}  // namespace nhnet
