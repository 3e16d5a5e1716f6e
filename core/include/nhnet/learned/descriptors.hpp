// The multi-scale point descriptor MPD (paper Sec. 5.1, Eq. 7) as one fixed-size float vector per
// point: the F = 9 normals of the bilateral filter (Eq. 5) rotated into the point's canonical
// frame, followed by their F height maps (Eq. 6). Layout of a row (D = 3 F + F m^2 = 468 with
// the paper's values): [f_1x f_1y f_1z ... f_Fx f_Fy f_Fz | map_1[0][0] ... map_F[m-1][m-1]].
// The descriptor's neighbourhood follows the noise-driven scale rule of MFPS: k = ceil(1.5 Kmin)
// with Kmin the smallest MFPS scale chosen for the cloud (authors: 1.5 * 50 = 75), so patches are
// comparable at every noise level. Version 2 (not the paper's, issue 23) lets the three stages
// see at most `max_neighbours` of those k, spread over the whole neighbourhood, so a noisy cloud's
// large k no longer multiplies the descriptor's cost. The same call feeds training (Python
// bindings) and inference; the chain that runs the geometry stage first is pipeline/describe.hpp.
#pragma once

#include "nhnet/learned/bilateral_filter.hpp"
#include "nhnet/learned/canonical_frame.hpp"
#include "nhnet/learned/height_map.hpp"
#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

#include <string>
#include <vector>

namespace nhnet {

/// Bumped whenever the descriptor's definition changes; models record the version they saw and
/// the core computes every version from kOldestDescriptorVersion on (descriptor_options).
constexpr int kDescriptorVersion = 2;
constexpr int kOldestDescriptorVersion = 1;
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
  /// Neighbours each point's filter, frame and height maps see (version 2): the nearest
  /// filter.spacing_k + 1 of the k, then the rest evenly spaced out to the k-th, so the cost is
  /// flat in the noise-driven k while the map keeps its radius. 0: all k (version 1).
  int max_neighbours = 64;
};

/// The options of descriptor `version` (kOldestDescriptorVersion .. kDescriptorVersion): what a
/// model trained on that version needs. InvalidOptions for any other version.
DescriptorOptions descriptor_options(int version);

/// Number of floats per point for these options.
int descriptor_size(const DescriptorOptions& options = {});

/// Descriptors of points that already have normals: `points` and `normals` (N x 3, all rows
/// finite), `knn` the neighbour table (M x K, K >= k) of points `first` .. `first` + M - 1, so
/// a cloud can be described block by block. Writes M x D features and the M rotations.
void compute_descriptors(const Points& points, const Normals& normals, const IndexMatrix& knn,
                         int k, const DescriptorOptions& options, DescriptorMatrix& features,
                         Rotations& rotations, const RunContext& run = {}, Eigen::Index first = 0);

/// The descriptor neighbourhood size for a cloud of m points whose smallest MFPS scale is
/// `kmin`: ceil(neighborhood_factor x kmin), at least filter.spacing_k + 1, at most m.
int descriptor_k(int kmin, const DescriptorOptions& options, Eigen::Index m);

/// Smallest MFPS scale assumed when a cloud's normals came without MFPS scales.
constexpr int kDescriptorScaleWithoutMfps = 50;

/// descriptor_k of the smallest of the MFPS `scales` (each at most m; without scales,
/// kDescriptorScaleWithoutMfps): the one rule of the geometry stage's table depth and of the
/// descriptors' k, so the first serves the second.
int descriptor_k_of_scales(const std::vector<int>& scales, const DescriptorOptions& options,
                           Eigen::Index m);

}  // namespace nhnet
