// Height-map patches (paper Sec. 5.1, Eq. 6): for each of a point's F (rotated) normals n_f, an
// m x m grid on the tangent plane T(p_i, n_f) through the point itself; bin b holds the
// Gaussian-weighted mean signed height of the points near it,
//   v_b = sum_k w(b, p_k) (p_k - p_i) . n_f / sum_k w(b, p_k),  w = exp(-|b - p_k|^2 / (2 h^2)),
// over the neighbours p_k within 0.9 h of the bin centre (authors' code). Extent: R = distance
// to the farthest of the point's k nearest neighbours. Only those k neighbours are gathered (not
// a cloud-wide radius query as in the authors' code), which keeps the cost at O(F k) per point;
// so the cell size is h = R / (floor(m / 2) + 0.9) (authors: R / floor(m / 2)), which keeps the
// outermost bins' balls along the axes inside the gathered ball (corners are partly outside).
// Axes: x = e1 of the canonical frame, y = e2, both projected onto the tangent plane
// (Gram-Schmidt), with n_f the frame's (sign-canonical) normal taken back to world coordinates;
// so the map is invariant to rotation, translation and the input normals' signs.
// Normalisation (documented choice, local to the point): every height is divided by the cell
// size h. The authors divide by one mean |height| of the whole shape, which makes a point's
// descriptor depend on the rest of the cloud; h scales with the point's own neighbourhood, so
// the map is also invariant to uniform scaling. Empty bins are 0.
#pragma once

#include "nhnet/learned/canonical_frame.hpp"
#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

namespace nhnet {

/// N x (F m m) float maps, row-major; entry [f][r][c] at column (f m + r) m + c, r along x.
using HeightMaps = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct HeightMapOptions {
  /// Grid size m (odd). Paper: 7.
  int size = 7;
  /// Ball radius around each bin centre, in cells. Authors' code: 0.9.
  double ball = 0.9;
};

/// Maps from the first `k` columns of `knn` (M x K, self first) and the frames (M rows); row r
/// belongs to point `first` + r of `points`. Rows whose frame is non-finite are NaN.
HeightMaps height_maps(const Points& points, const IndexMatrix& knn, int k,
                       const CanonicalFrames& frames, const HeightMapOptions& options = {},
                       const RunContext& run = {}, Eigen::Index first = 0);

}  // namespace nhnet
