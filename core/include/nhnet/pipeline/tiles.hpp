// The tiled run's steps one at a time, for drivers that spread the tiles over processes or
// machines (not a paper stage; issue 25: the Python nhnet.distributed job on Dask). The same
// steps as the out-of-core run (stream.cpp, which calls them): a frame and a tile plan placed on
// a sample, the noise probe as rows collected tile by tile, the whole cloud's decisions (noise
// level, spacing, neighbourhood sizes, halo widths, MFPS's candidate threshold) taken once from
// those rows, then each tile (its own points first, then its halo) estimated with them, so that a
// point's normal does not depend on how the cloud was cut.
#pragma once

#include "nhnet/geometry/scales.hpp"
#include "nhnet/pipeline/estimate.hpp"
#include "nhnet/types.hpp"

#include <cstdint>
#include <vector>

namespace nhnet {

/// The tiles' frame: input coordinates re-centred and scaled by a power of two.
struct TileFrame {
  /// Centre of the cloud's bounding box (input units).
  Eigen::RowVector3d centre = Eigen::RowVector3d::Zero();
  /// Frame length = scale x input length (a power of two).
  double scale = 1;
};

/// The frame of a cloud whose finite points lie in the box [lo, hi]: centred on the box, scaled
/// by a power of two into [-2, 2).
TileFrame tile_frame(const Eigen::RowVector3d& lo, const Eigen::RowVector3d& hi);

/// The tile plan: a kd-tree of split planes (frame units) placed on a sample of the cloud.
struct TilePlan {
  /// Per node: split axis (0-2), -1 for a leaf.
  std::vector<int> axis;
  /// Per node: split coordinate; a point with coordinate < value goes left.
  std::vector<double> value;
  /// Per node: children (-1 for a leaf) and the leaf's tile number (-1 for a split).
  std::vector<int> left, right, leaf;
  /// Per tile: its cell (frame units, +-inf where unbounded).
  Points cell_lo, cell_hi;
};

/// ceil(finite / tile_points) tiles placed on `sample` (frame units) by the in-memory tiling's
/// splits (longest axis at the point-count quantile). Throws InvalidOptions for tile_points < 1.
TilePlan plan_tiles(const Points& sample, int64_t finite, int64_t tile_points);

/// The tile of each row of `points` (frame units, finite): a pure function of the coordinates.
std::vector<int32_t> route_tiles(const TilePlan& plan, const Points& points);

/// Noise-probe rows of one tile: squared distances to each probed point's nearest neighbours
/// (self first, frame units) and the residuals of the planes through them (R x 2,
/// probe_residuals: all K and the first kNoiseProbeSmallK).
struct TileProbeRows {
  DistanceMatrix d2;
  ProbeResiduals residual;
};

/// Rows between two probed points of a tile's own points: `rough` for the first pass (a
/// neighbourhood radius for the halo of the second), else the final probe's.
int64_t probe_step(int64_t finite, bool rough);

/// Probes a tile (frame units; its first `own` rows are its own points, the rest its halo):
/// every step-th own distinct point; without a halo (halo == 0) only those whose neighbourhood
/// lies inside the tile's cell [cell_lo, cell_hi]. Empty rows for tiles too small to probe.
TileProbeRows probe_tile(const Points& pts, int64_t own, int64_t step, double halo,
                         const Eigen::RowVector3d& cell_lo, const Eigen::RowVector3d& cell_hi,
                         int threads);

/// What every tile gets from the whole cloud (frame units).
struct TileDecisions {
  /// The probe's noise ratio and spacing, its neighbourhood radius at far_k neighbours.
  double noise_ratio = 0;
  double spacing = 0;
  double far_radius = 0;
  int far_k = 0;
  /// PCA size and MFPS scales (the options' k and scales win).
  int k_smooth = 0;
  std::vector<int> scales;
  /// Halo around a tile's box for the estimate (largest neighbourhood) and for the surface
  /// variation (smooth size): EstimateOptions::tiles.halo radii.
  double halo = 0;
  double variation_halo = 0;
  /// MFPS's candidate threshold (set_variation_threshold); < 0 = not chosen yet.
  double variation_threshold = -1;
  /// Every tile goes through cell means (CellMeanOptions: the cloud's noise ratio reaches its
  /// threshold): the halo then covers the means' largest neighbourhood, and no candidate
  /// threshold is needed (each tile's means choose their own).
  bool cell_means = false;
};

/// The whole cloud's decisions from the probe rows of every tile (rows with fewer columns than
/// the others cut the rest to their width) for `finite` points. Throws UnprocessableInput when
/// no rows were probed.
TileDecisions decide_tiles(const std::vector<TileProbeRows>& rows, const EstimateOptions& options,
                           int64_t finite);

/// Surface variations at the smooth size of a tile's own distinct points (every step-th), the
/// tile given with its variation halo (decisions.variation_halo).
Eigen::VectorXd tile_variation(const Points& pts, int64_t own, int k_smooth, int64_t step,
                               int threads);

/// Rows between two kept surface variations so that at most `sample` are kept.
int64_t variation_step(int64_t finite, int64_t sample);

/// MFPS's candidate threshold from the whole cloud's surface variations (feature_detection.hpp).
double variation_threshold(const Eigen::VectorXd& variation);

/// One tile (frame units: own points then halo) through the estimator with the whole cloud's
/// decisions (through its cell means when decisions.cell_means: the means' own sizes, measured
/// in the tile, so a point's normal depends a little on its tile there); rows of the result
/// match `pts`. Options are checked here.
EstimateResult estimate_tile(const Points& pts, const EstimateOptions& options,
                             const TileDecisions& decisions);

}  // namespace nhnet
