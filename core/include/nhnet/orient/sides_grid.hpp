// The MST's inside/outside grid (core/src/orient/inside_outside.hpp) as data, for drivers that
// decide it once for a whole cloud cut into tiles (not a paper stage; issue 25: the distributed
// job). A tile is an open piece of the surface, whose own flood fill leaks into the interior;
// the whole cloud's grid, built from every tile's occupied voxels, gives each tile's MST the
// same votes the single process takes, so tiles cannot disagree with it at their borders.
#pragma once

#include "nhnet/types.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace nhnet {

/// An occupancy grid over a cloud's box, then dilated and flood-filled from its border.
struct SidesGrid {
  /// Corner of voxel (0, 0, 0), in the points' units.
  Eigen::RowVector3d origin = Eigen::RowVector3d::Zero();
  /// Voxel size, in the points' units.
  double h = 1;
  /// 6-connected steps the occupied voxels were dilated by.
  int dilation = 2;
  /// Voxels along x, y, z.
  std::array<int64_t, 3> dims{};
  /// dims[0] x dims[1] x dims[2] voxels, x slowest: 0 empty, 1 occupied, 2 outside.
  std::vector<uint8_t> cell;
};

/// The grids the single-process MST tries, in order, for distinct valid points in the box
/// [lo, hi]: the first whose leak (share of points with both offsets outside) is below
/// max_leak is used, none when the list is empty (a box too large for the grid to resolve).
struct SidesGridPlan {
  /// Voxel size and dilation of each candidate, finest first.
  std::vector<double> h;
  std::vector<int> dilation;
  /// A grid is watertight when its leak is below this share.
  double max_leak = 0;
};

/// The plan for points in [lo, hi] whose mean and median distance to their nearest other point
/// are `spacing` and `typical_spacing` (the MST graph's, mst_nearest in orient.hpp), with the
/// flood fill's defaults.
SidesGridPlan sides_grid_plan(const Eigen::RowVector3d& lo, const Eigen::RowVector3d& hi,
                              double spacing, double typical_spacing);

/// The empty grid (origin, dims; `cell` all 0) the single-process MST lays over points in the box
/// [lo, hi] at voxel `h` for `dilation` steps.
SidesGrid sides_grid_frame(const Eigen::RowVector3d& lo, const Eigen::RowVector3d& hi, double h,
                           int dilation);

/// The voxel index of each point in `grid` (clamped into it), as the grid's votes locate them.
std::vector<int64_t> sides_grid_voxels(const SidesGrid& grid, const Points& points);

/// Marks the voxels `occupied` (indices from sides_grid_voxels) as occupied, dilates them and
/// flood-fills the outside. Throws InvalidOptions for an index outside the grid.
void fill_sides_grid(SidesGrid& grid, const std::vector<int64_t>& occupied);

}  // namespace nhnet
