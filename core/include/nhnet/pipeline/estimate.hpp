// The normal estimation pipeline: the one call every front end (CLI, PCL class, plugins,
// Python) makes. Geometry stage of the paper (Sec. 4): PCA for smooth points, MFPS for points
// near sharp features, with neighbourhood sizes chosen from the cloud's own noise level.
#pragma once

#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace nhnet {

class NhNetModel;

enum class Method {
  Pca,   ///< plain PCA over the k nearest neighbours
  Mfps,  ///< PCA for smooth points + multi-scale fitting patch selection near features
  NhNet,  ///< MFPS refined by the trained NH-Net (paper Sec. 5; needs libtorch, nhnet_model.hpp)
};

/// Parses "pca" / "mfps" / "nhnet"; throws InvalidOptions otherwise.
Method method_from_string(const std::string& name);
const char* to_string(Method method);

struct EstimateOptions {
  /// Which estimator to run.
  Method method = Method::Mfps;
  /// PCA neighbourhood size (self included) for --method pca and for MFPS smooth points;
  /// 0 = chosen from the estimated noise level (see scales.hpp).
  int k = 0;
  /// MFPS patch sizes; empty = chosen from the estimated noise level. Paper: {50, 100, 150}.
  std::vector<int> scales;
  /// Seed of the random plane samples of MFPS (results are deterministic for a given seed and
  /// independent of the thread count).
  uint64_t seed = 1;
  /// MFPS plane search (advanced; see mfps.hpp): random 4-point planes per patch, members each
  /// is scored on (0 = all), best samples re-scored on the whole patch, IRLS refinement steps.
  int mfps_samples = 40;
  int mfps_score_subset = 48;
  int mfps_rescore = 3;
  int mfps_refine_iterations = 3;
  /// MFPS selection (see mfps.hpp): width factor of the point term of Eq. 4, the two-face
  /// posterior exponent (0 = the paper's argmax) and the edge-geometry posterior's noise width
  /// (0 = off). Defaults measured on the training split (tools/README.md).
  double mfps_point_sigma_factor = 4;
  double mfps_posterior_beta = 12;
  double mfps_edge_sigma_factor = 1;
  /// MFPS PCA blend (see mfps.hpp): candidates move towards their PCA normal where the
  /// selection is likely wrong. NH-Net's descriptors set their own (DescriptorOptions).
  bool mfps_pca_blend = true;
  /// Diagnostics for fitting the blend: fill EstimateResult::mfps_blend_*.
  bool mfps_record_blend = false;
  /// NH-Net model file (TorchScript from nhnet-export); empty = the shipped model
  /// (default_model_path() in nhnet_model.hpp).
  std::string model;
  /// NH-Net device: "auto" (CUDA if available, else CPU), "cpu" or "cuda".
  std::string device = "auto";
  /// NH-Net: an already loaded model (nhnet_model.hpp); when set, `model` and `device` are not
  /// used. Lets a front end check the model before reading any input and reuse it across files.
  std::shared_ptr<const NhNetModel> loaded_model;
  /// NH-Net block size: points whose descriptors are computed and run through the model at once.
  int nhnet_batch = 4096;
  /// Spatial tiles (not in the paper; tiling.cpp): a cloud with more finite points than this is
  /// processed in tiles of at most this many points, each with a halo of the points around it,
  /// so memory is bounded by one tile whatever the cloud's size; results equal the untiled
  /// run's up to rounding (tested). 0 = never tile.
  int64_t tile_points = 1000000;
  /// Halo width around each tile, in radii of the largest neighbourhood the stages use (MFPS
  /// patches reach two radii, NH-Net's descriptors of MFPS normals three; 4 leaves a margin).
  double tile_halo = 4;
  /// Advanced, set by the tiling for each tile: noise ratio and point spacing (input units)
  /// measured on the whole cloud. When known_spacing > 0 the noise probe is skipped and these
  /// choose the neighbourhood sizes, so every tile uses the whole cloud's sizes.
  double known_noise_ratio = 0;
  double known_spacing = 0;
  /// Advanced, set by the tiling: the whole cloud's candidate threshold on the surface variation
  /// (FeatureDetection::absolute_threshold); < 0 = chosen from this cloud's histogram.
  double known_variation_threshold = -1;
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
  /// Points classified as candidates near sharp features (MFPS only).
  int64_t candidates = 0;
  /// N flags (MFPS and NH-Net; empty for PCA): 1 = the point was a candidate.
  std::vector<uint8_t> candidate;
  /// Spatial tiles the cloud was processed in (1 = untiled; see tile_points).
  int tiles = 1;
  /// Estimated noise level: residual bandwidth / average point spacing (dimensionless).
  double noise_ratio = 0;
  /// Average spacing of the cloud (mean distance to the nearest other point), input units.
  double spacing = 0;
  /// PCA neighbourhood size that was used.
  int k_used = 0;
  /// MFPS patch sizes that were used (empty for PCA).
  std::vector<int> scales_used;
  /// With mfps_record_blend: input rows of the candidates that have blend features, the
  /// features (rows x kMfpsBlendFeatures, mfps.hpp) and those rows' normals before the blend
  /// (rows x 3).
  std::vector<int64_t> mfps_blend_rows;
  Eigen::MatrixXd mfps_blend_features;
  Normals mfps_unblended;
  /// NH-Net only: the device the model ran on ("cpu" / "cuda") and the descriptor
  /// neighbourhood size.
  std::string device_used;
  int descriptor_k = 0;
  /// Non-fatal notes for the user (clamped neighbourhoods, non-finite points, ...).
  std::vector<std::string> warnings;
};

/// Estimates unoriented normals for `points` (N x 3). Non-finite points are skipped and reported
/// as failed; they never influence their neighbours. Throws InvalidOptions for bad options,
/// UnprocessableInput when fewer than 3 finite points remain, Cancelled when the progress
/// callback returns false.
EstimateResult estimate_normals(const Points& points, const EstimateOptions& options = {});

}  // namespace nhnet
