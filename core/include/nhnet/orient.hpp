// Normal orientation, a stage after estimation (the paper's normals, like every PCA-type
// estimate, are unoriented: the sign of each normal is arbitrary). Modes:
//   keep       flip each normal to agree with a reference normal of the same point (the input's)
//   viewpoint  flip each normal to point towards a sensor position: (v - p_i) . n_i > 0
//   mst        Hoppe et al. 1992 as CGAL's mst_orient_normals does it: a minimum spanning tree
//              of the k-NN graph weighted by 1 - |n_i . n_j|, the orientation propagated from a
//              seed (the highest point of the component, its normal turned to +z, i.e. outward
//              on a closed surface). Run once per connected component of the k-NN graph (CGAL
//              alone orients only the component of its seed); the point order never changes.
//   none       leave the signs as they are
#pragma once

#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace nhnet {

enum class OrientMode { None, Keep, Viewpoint, Mst };

/// "none" / "keep" / "viewpoint" / "mst"; throws InvalidOptions otherwise.
OrientMode orient_mode_from_string(const std::string& name);
const char* to_string(OrientMode mode);

struct OrientOptions {
  /// Which orientation to apply.
  OrientMode mode = OrientMode::Mst;
  /// Viewpoint mode: the sensor position, in the points' coordinates.
  Eigen::Vector3d viewpoint = Eigen::Vector3d::Zero();
  /// Mst mode: neighbours per point in the k-NN graph, self included (CGAL's examples: 18; at
  /// least 2). Larger k bridges gaps between sampled parts, smaller k keeps thin parts apart.
  int k = 18;
  /// Threads (0 = all cores) and progress/cancel callback.
  RunContext run;
};

struct OrientResult {
  /// Normals whose sign was changed.
  int64_t flipped = 0;
  /// Valid normals whose sign could not be decided: keep, the reference normal is missing (NaN
  /// or zero) or perpendicular; viewpoint, the normal is perpendicular to the line of sight;
  /// mst, the point lies in a component that could not be oriented. Left as they were.
  int64_t unoriented = 0;
  /// Normals that are NaN or zero, or whose point is non-finite (never touched).
  int64_t invalid = 0;
  /// Mst: connected components of the k-NN graph over the valid points, and how many of them
  /// could not be oriented completely (CGAL left some of their points unoriented).
  int64_t components = 0;
  int64_t unoriented_components = 0;
};

/// Orients `normals` (N x 3, rows of `points`, N x 3) in place; the order of the rows never
/// changes. `reference` (N x 3) is needed by OrientMode::Keep only. Throws InvalidOptions for
/// bad options or mismatched sizes, Cancelled when the progress callback returns false.
OrientResult orient_normals(const Points& points, Normals& normals, const OrientOptions& options,
                            const Normals& reference = Normals());

}  // namespace nhnet
