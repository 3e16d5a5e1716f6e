// Osculating jet normals (Cazals & Pouget 2005, degree 2; not the paper's): the height of the k
// nearest neighbours over the tangent plane of a frame normal n (PCA's) is fitted by least
// squares with h(u, v) = c0 + c1 u + c2 v + c3 u^2 + c4 u v + c5 v^2, and the point's normal is
// that of the fitted surface, n - c1 a - c2 b (a, b the tangent axes). The quadratic terms take
// up the curvature that tilts a plane fit on a curved or thin part, so the jet is a candidate of
// NH-Net's candidate mix (learned/candidate_mix.hpp) where the surface bends within k.
#pragma once

#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

namespace nhnet {

struct JetOptions {
  /// Neighbourhood size, self included (0 = all columns of knn); at least 6 (six coefficients).
  int k = 0;
};

/// Jet normals of `points` (N x 3) over the first options.k columns of `knn` (N x K, self first),
/// in the tangent frame of `frame` (N x 3 unit normals). NaN rows where the frame is missing or
/// the neighbourhood does not determine the six coefficients.
Normals jet_normals(const Points& points, const IndexMatrix& knn, const Normals& frame,
                    const JetOptions& options = {}, const RunContext& run = {});

}  // namespace nhnet
