// Internal: dense noisy clouds estimated through cell means (CellMeanOptions, estimate.hpp;
// cell_means.cpp), estimate_normals' first step.
#pragma once

#include "pipeline/estimator.hpp"

namespace nhnet::detail {

/// When options.cell_means applies to `points` (automatic sizes, enough finite points, noise
/// ratio at least its threshold): estimates them through cell means into `out` and returns true.
/// Otherwise returns false and, when it probed the noise, leaves the cloud's noise ratio and
/// spacing (input units) in `measured`, for estimate_points not to probe again.
bool through_cell_means(const Points& points, const EstimateOptions& options, EstimateResult& out,
                        TileOverrides& measured);

}  // namespace nhnet::detail
