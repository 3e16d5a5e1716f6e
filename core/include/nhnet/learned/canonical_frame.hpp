// Canonical frame of a point's normal set (paper Sec. 5.1, "Consistency regardless of
// orientation"): the normal tensor T = sum_f n_f n_f^T of the F normals is eigen-decomposed
// (eigenvalues ascending, e1 smallest, e3 dominant) and R = [e1 e2 e3]^T maps world vectors to
// the frame, so the normals are rotated onto the z axis.
// Deterministic sign rule (the authors' code leaves eigenvector signs to the solver), invariant
// to the signs of the input normals and equivariant under rotations:
//   e3: points away from the centroid of the k neighbour offsets (to the convex side; ties: by
//       their third moment along e3), so it depends on the geometry only and not on the input
//       normal's sign (the authors take the self normal's side, which is arbitrary for unoriented
//       input); every normal is then taken on that side (z >= 0; paper: "if one normal is in
//       the direction of negative Z-axis, we reverse it");
//   e2, e1 (each separately): the third moment sum_f (n_f . e)^3 of those normals is positive;
//       where it is below 1e-6 per normal (the normals hardly spread along e, e.g. e1 at an edge
//       or both in a flat region) the third moment of the neighbour offsets sum_j ((p_j - p_i) .
//       e)^3 decides instead, and if that vanishes too (exactly symmetric samples) the solver's
//       sign stays. The frame may be a reflection (det -1); every consumer only needs R^T R = I.
#pragma once

#include "nhnet/learned/bilateral_filter.hpp"
#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

namespace nhnet {

/// N x 9 rotations, row-major 3 x 3 each (entry (r, c) at column 3 r + c); R n maps world to frame.
using Rotations = Eigen::Matrix<double, Eigen::Dynamic, 9, Eigen::RowMajor>;

struct CanonicalFrames {
  /// Rotation of every point (NaN rows where the normals are non-finite).
  Rotations rotations;
  /// The normals in the frame, N x 3 F, each with z >= 0.
  FeatureNormals rotated;
};

/// Frames of every row of `normals` (M x 3 F, from bilateral_filter) with neighbour table `knn`
/// (M x K, first `k` columns used for the signs); row r belongs to point `first` + r of `points`.
CanonicalFrames canonical_frames(const Points& points, const IndexMatrix& knn, int k,
                                 const FeatureNormals& normals, const RunContext& run = {},
                                 Eigen::Index first = 0);

}  // namespace nhnet
