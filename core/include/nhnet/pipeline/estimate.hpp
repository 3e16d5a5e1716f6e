// The normal estimation pipeline: the one call every front end (CLI, PCL class, plugins,
// Python) makes. Geometry stage of the paper (Sec. 4): PCA for smooth points, MFPS for points
// near sharp features, with neighbourhood sizes chosen from the cloud's own noise level.
#pragma once

#include "nhnet/geometry/mfps.hpp"
#include "nhnet/learned/nhnet_model.hpp"
#include "nhnet/orient/orient.hpp"
#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace nhnet {

enum class Method {
  Pca,    ///< plain PCA over the k nearest neighbours
  Mfps,   ///< PCA for smooth points + multi-scale fitting patch selection near features
  NhNet,  ///< MFPS refined by the trained NH-Net (paper Sec. 5; needs libtorch, nhnet_model.hpp)
};

/// The plugins' default for EstimateOptions::confidence (the CLI's, Python's and the library's is
/// the struct's, off: an extra output). MeshLab keeps it as vertex quality, which Screened
/// Poisson takes as a confidence, and CloudCompare as a scalar field: on.
constexpr bool kPluginConfidence = true;

/// Parses "pca" / "mfps" / "nhnet"; throws InvalidOptions otherwise.
Method method_from_string(const std::string& name);
const char* to_string(Method method);

/// Parses "all" / "moved" / "auto" (ModelOptions::refine); throws InvalidOptions otherwise.
Refine refine_from_string(const std::string& name);
const char* to_string(Refine refine);

/// Parses a cell-mean setting (CellMeanOptions::noise_ratio): "auto" = the default ratio, "off" =
/// 0, else the noise ratio from which (a number > 0); throws InvalidOptions whose message starts
/// "must be" (the caller prefixes its option's name).
double cell_means_from_string(const std::string& text);

/// Whether the network runs on every point (else only where MFPS moved the normal) under
/// `options` for a cloud of this noise ratio.
bool network_everywhere(const ModelOptions& options, double noise_ratio);

/// Every front end's default method: NhNet when it can run (this build links libtorch and the
/// shipped model file, default_model_path(), is there), else Mfps, with `fallback_why` (when
/// given) set to why NH-Net could not run ("" when it can).
Method default_method(std::string* fallback_why = nullptr);

/// Spatial tiles (not in the paper; tiling.cpp): a cloud with more finite points than `points`
/// whose estimate in one piece would need more than `memory` bytes is processed in tiles of at
/// most `points` points, each with a halo of the points around it, so memory is bounded by one
/// tile whatever the cloud's size; results equal the untiled run's up to rounding (tested).
struct TileOptions {
  /// Most points per tile; 0 = never tile.
  int64_t points = 1000000;
  /// In memory: a cloud over `points` stays in one piece while the untiled estimate's peak,
  /// estimated from the method and the noise-driven neighbourhood size (untiled_bytes() in
  /// tiling.cpp), fits in this many bytes: in one piece it is faster (3M clean points, mfps:
  /// a third less time, docs/design/decisions.md#tiles-only-beyond-a-memory-budget). 3 GiB keeps
  /// every 10M-point cloud tiled (at least 392 bytes a point in one piece). 0 = tile every cloud
  /// over `points` (what an explicit --tile-points asks for). Streamed runs always tile.
  int64_t memory = int64_t(3) << 30;
  /// Halo width around each tile, in radii of the largest neighbourhood the stages use: NH-Net's
  /// descriptors of MFPS normals reach 3; MFPS's kernel widths average residuals of patches up
  /// to about 4 radii away, of which 4 cuts only the farthest (tiled = untiled up to rounding,
  /// tested). In memory PCA takes halo - 2 (its one radius plus that margin, at least a third of
  /// halo); streamed and distributed tiles take halo.
  double halo = 4;
};

/// Dense noisy clouds through cell means (not in the paper; pipeline/cell_means.cpp, issue 23):
/// where the noise is as large as the point spacing, the noise-driven neighbourhoods reach
/// hundreds of points and every stage's cost grows with them. The estimate then runs on the means
/// of the points in cubes a few noise deviations wide (each mean averages the noise of its
/// points, as a large neighbourhood would) and every point takes its nearest mean's normal, so
/// the time per point stays flat across noise levels. 1M-point clouds at 0.6 % noise: RMS level
/// or lower, 4-5x less estimate time
/// (docs/design/decisions.md#cell-means-for-dense-noisy-clouds-issue-23).
struct CellMeanOptions {
  /// Noise ratio (EstimateResult::noise_ratio) from which a cloud goes through cell means; 0 =
  /// never. From 1.12 the means were as accurate as the points or more on 1M-point test clouds
  /// (RMS -27 % to +3 %), from 1.0 to 1.09 2-6 % worse (docs/design/decisions.md).
  double noise_ratio = 1.12;
  /// Cube edge and radius of each mean's ball, in standard deviations of the noise (noise
  /// ratio x spacing).
  double edge = 3;
  /// Clouds with fewer finite points are estimated themselves (the decision's noise probe
  /// would cost a second one; small clouds are fast at any k).
  int64_t min_points = 200000;
};

/// Everything estimate_normals() takes: the method and its neighbourhood size, then one options
/// struct per stage, each with its defaults in its own header. Every front end (CLI, Python, PCL
/// class, plugins) starts from these defaults.
struct EstimateOptions {
  /// Which estimator to run.
  Method method = Method::Mfps;
  /// PCA neighbourhood size (self included) for --method pca and for MFPS smooth points;
  /// 0 = chosen from the estimated noise level (see scales.hpp).
  int k = 0;
  /// MFPS (mfps.hpp): patch sizes (empty = chosen from the noise level), plane search,
  /// selection, PCA blend and the seed of its random plane samples (results are deterministic
  /// for a given seed and independent of the thread count). NH-Net's descriptors set their own
  /// blend (DescribeOptions, describe.hpp).
  MfpsOptions mfps;
  /// NH-Net (nhnet_model.hpp): model file, device, an already loaded model, block size.
  ModelOptions model;
  /// Spatial tiles (TileOptions above).
  TileOptions tiles;
  /// Dense noisy clouds through cell means (CellMeanOptions above); only with automatic sizes
  /// (k and MFPS scales 0 / empty).
  CellMeanOptions cell_means;
  /// Also return each point's this many nearest rows (EstimateResult::neighbours), for an MST
  /// orientation to reuse instead of searching again (shared_neighbours(), orient.hpp); 0 =
  /// none. Returned only by a run in one piece over distinct finite points, not through cell
  /// means.
  int neighbours = 0;
  /// Also return each normal's confidence (EstimateResult::confidence; learned/confidence.hpp):
  /// a second, small neighbour search over the result, about 1-5 % more time.
  bool confidence = false;
  /// Threads (0 = all cores) and progress/cancel callback.
  RunContext run;
};

struct EstimateResult {
  /// N x 3 unit normals, unoriented (sign arbitrary); NaN rows for points that failed.
  Normals normals;
  /// N flags: 1 = normal computed, 0 = failed (non-finite input point or degenerate patch).
  std::vector<uint8_t> valid;
  /// Number of zeros in `valid`.
  int64_t failed = 0;
  /// N surface variations lambda_min / (lambda_1 + lambda_2 + lambda_3) of each point's PCA
  /// neighbourhood (k_used points), in [0, 1/3]: what PCL calls "curvature". NaN where failed.
  Eigen::VectorXd curvature;
  /// With EstimateOptions::confidence: N confidences in [0, 1], the chance that the normal is
  /// within 30 degrees of the true one, judged from its neighbourhood (learned/confidence.hpp);
  /// NaN where failed. Empty otherwise.
  Eigen::VectorXd confidence;
  /// Points classified as candidates near sharp features (MFPS only).
  int64_t candidates = 0;
  /// N flags (MFPS and NH-Net; empty for PCA): 1 = the point was a candidate.
  std::vector<uint8_t> candidate;
  /// Spatial tiles the cloud was processed in (1 = untiled; see tile_points).
  int tiles = 1;
  /// Cell means the estimate ran on (CellMeanOptions; each point has its nearest mean's normal,
  /// curvature and candidate flag; k_used and scales_used are the means'); 0 = the points
  /// themselves.
  int64_t cell_means = 0;
  /// Estimated noise level: residual bandwidth / average point spacing (dimensionless).
  double noise_ratio = 0;
  /// Average spacing of the cloud (mean distance to the nearest other point), input units.
  double spacing = 0;
  /// PCA neighbourhood size that was used.
  int k_used = 0;
  /// MFPS patch sizes that were used (empty for PCA).
  std::vector<int> scales_used;
  /// With mfps.record_blend_features: input rows of the candidates that have blend features, the
  /// features (rows x kMfpsBlendFeatures, mfps.hpp) and those rows' normals before the blend
  /// (rows x 3).
  std::vector<int64_t> mfps_blend_rows;
  Eigen::MatrixXd mfps_blend_features;
  Normals mfps_unblended;
  /// NH-Net only: the device the model ran on ("cpu" / "cuda"), its arithmetic ("float32" /
  /// "bfloat16": ModelOptions::precision resolved, "auto" made concrete) and the descriptor
  /// neighbourhood size.
  std::string device_used;
  std::string precision_used;
  int descriptor_k = 0;
  /// Non-fatal notes for the user (clamped neighbourhoods, non-finite points, ...).
  std::vector<std::string> warnings;
  /// With EstimateOptions::neighbours: N x min(neighbours, N) input rows of each point's nearest
  /// points, itself first, nearest first (for OrientOptions::neighbours); empty when the cloud
  /// was tiled or holds non-finite points or exact duplicates.
  IndexMatrix neighbours;
};

/// Moves res.neighbours (EstimateOptions::neighbours) into orient.neighbours, for
/// orient_normals() of the same points to reuse; leaves `orient` as it is when there is none.
void hand_neighbours(EstimateResult& res, OrientOptions& orient);

/// Estimates unoriented normals for `points` (N x 3). Non-finite points are skipped and reported
/// as failed; they never influence their neighbours. Throws InvalidOptions for bad options,
/// UnprocessableInput when fewer than 3 finite points remain, Cancelled when the progress
/// callback returns false.
EstimateResult estimate_normals(const Points& points, const EstimateOptions& options = {});

}  // namespace nhnet
