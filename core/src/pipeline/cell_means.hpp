// Internal: dense noisy clouds estimated through cell means (CellMeanOptions, estimate.hpp;
// cell_means.cpp), estimate_normals' first step.
#pragma once

#include "pipeline/estimator.hpp"

#include "nhnet/orient/orient.hpp"

#include <cstdint>
#include <vector>

namespace nhnet::detail {

/// The means a cell-mean estimate ran on, kept for an orientation of the means
/// (orient_through_means) instead of the points.
struct MeansRun {
  /// The means (M x 3, in the frame of the canonical points) and their estimated normals.
  Points means;
  Normals normals;
  /// For every input row the nearest of its means with a normal (whose side its blended normal
  /// takes); -1 for rows without a normal.
  std::vector<int32_t> mean_of_row;
  /// Input length of one unit of the means' frame.
  double unit = 1;
};

/// Whether options.cell_means may apply to a cloud of `finite` points (on, automatic sizes,
/// enough points); it does when the cloud's noise ratio is at least its threshold too.
bool cell_means_apply(const EstimateOptions& options, int64_t finite);

/// When options.cell_means applies to `points` (automatic sizes, enough finite points, noise
/// ratio at least its threshold): estimates them through cell means into `out` and returns true.
/// Otherwise returns false and, when it probed the noise, leaves the cloud's noise ratio and
/// spacing (input units) in `measured` and its canonical points and tree in `prepared`, for
/// the estimate not to build them again. With `keep`, the means, their normals and each row's
/// mean are moved there.
bool through_cell_means(const Points& points, const EstimateOptions& options, EstimateResult& out,
                        TileOverrides& measured, Prepared& prepared, MeansRun* keep = nullptr);

/// A streamed or distributed tile (tiles.hpp: own points, then halo) through cell means with the
/// whole cloud's noise ratio and spacing (units of `points`): the means of the tile's cubes and
/// their estimate (their own probe: the tile's means, not the cloud's), each point from its
/// nearest means. False (nothing written) when the tile gives fewer than 3 means.
bool tile_through_cell_means(const Points& points, const EstimateOptions& options,
                             double noise_ratio, double spacing, EstimateResult& out);

/// estimate_normals, keeping the means in `keep` (when given) when it ran through them.
EstimateResult estimate_normals_keeping_means(const Points& points, const EstimateOptions& options,
                                              MeansRun* keep);

/// Orients the means of `run` (an MST or up orientation of the points would take 5-10 times
/// longer) and turns every row of `res` to its mean's oriented side. Counts: flipped and invalid
/// over the rows; unoriented, components and the flood fill's votes over the means.
OrientResult orient_through_means(MeansRun& run, EstimateResult& res, const OrientOptions& orient);

}  // namespace nhnet::detail
