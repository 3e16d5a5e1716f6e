// The multi-scale point descriptor MPD (paper Sec. 5.1, Eq. 7) as one fixed-size float vector per
// point: the F = 9 normals of the bilateral filter (Eq. 5) rotated into the point's canonical
// frame, followed by their F height maps (Eq. 6). Layout of a row (D = 3 F + F m^2 = 468 with
// the paper's values): [f_1x f_1y f_1z ... f_Fx f_Fy f_Fz | map_1[0][0] ... map_F[m-1][m-1]].
// The descriptor's neighbourhood follows the noise-driven scale rule of MFPS: k = ceil(1.5 Kmin)
// with Kmin the smallest MFPS scale chosen for the cloud (authors: 1.5 * 50 = 75), so patches are
// comparable at every noise level. The same call feeds training (Python bindings) and inference.
#pragma once

#include "nhnet/bilateral_filter.hpp"
#include "nhnet/canonical_frame.hpp"
#include "nhnet/estimate.hpp"
#include "nhnet/height_map.hpp"
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
  /// Geometry stage (MFPS; `method` is ignored) and threads / progress.
  EstimateOptions estimate;
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
/// finite), `knn` their neighbour table with at least `k` columns. Writes N x D features and the
/// rotations.
void compute_descriptors(const Points& points, const Normals& normals, const IndexMatrix& knn,
                         int k, const DescriptorOptions& options, DescriptorMatrix& features,
                         Rotations& rotations, const RunContext& run = {});

/// The whole chain for a cloud: MFPS normals (estimate_normals), then the descriptors of every
/// point with a valid normal. Throws like estimate_normals.
Descriptors describe(const Points& points, const DescriptorOptions& options = {});

}  // namespace nhnet
