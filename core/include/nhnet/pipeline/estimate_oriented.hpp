// Estimate, then orient: the flow of every front end (CLI, Python, CloudCompare, MeshLab) in one
// call. An MST orientation reuses the estimator's neighbour search (EstimateOptions::neighbours,
// OrientOptions::neighbours) instead of searching again; the signs are the same either way.
#pragma once

#include "nhnet/orient/orient.hpp"
#include "nhnet/pipeline/estimate.hpp"
#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

namespace nhnet {

struct OrientedResult {
  /// estimate_normals()'s result, its normals oriented (as estimated when orient.mode is None).
  EstimateResult estimate;
  /// orient_normals()'s counts (all zero when orient.mode is None).
  OrientResult orient;
};

/// Share of estimate_oriented()'s progress that the estimation takes: 0.85 before an
/// orientation that builds a neighbour graph (Mst, Up), else 1 (the others take no time).
double estimation_share(const OrientOptions& orient);

/// estimate_normals(points, estimate), then, unless orient.mode is None, orient_normals() of
/// its normals (`reference`: the input normals, for OrientMode::Keep). `run` (threads, progress
/// and cancel) replaces the run contexts of both options: the estimation reports up to
/// estimation_share(orient), the orientation the rest. Throws as the two calls do.
OrientedResult estimate_oriented(const Points& points, EstimateOptions estimate,
                                 OrientOptions orient, const RunContext& run,
                                 const Normals& reference = Normals());

}  // namespace nhnet
