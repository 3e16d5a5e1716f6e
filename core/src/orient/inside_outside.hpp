// Internal to the orientation stage (orient.cpp): which side of a closed surface is outside,
// decided per point by a voxel flood fill (not a paper stage; issue 5). The points are
// rasterised into an occupancy grid (voxel h = a few point spacings, dilated so the sampled
// surface is watertight), the empty space reachable from the grid's border is flood-filled:
// that is the outside. A normal n_i points outward when p_i + s h n_i lands in the outside and
// p_i - s h n_i does not, for the first step s that tells the two apart. Unlike a propagated
// orientation it is decided at every point on its own, so one weak link cannot flip a region,
// and it holds across thin walls (the other side of a blade is occupied or enclosed, never
// outside). Where the fill leaks into the interior (an open scan, a hole wider than the
// dilation) both offsets reach the outside: the grid is then dilated one step more, then
// coarsened step by step, and when no grid is watertight no point gets a vote.
#pragma once

#include "nhnet/orient/sides_grid.hpp"
#include "nhnet/types.hpp"

#include <cstdint>
#include <memory>
#include <vector>

namespace nhnet::detail {

struct InsideOutsideOptions {
  /// Voxel sizes tried, in point spacings, finest first; at each size the dilations are tried
  /// in order, and the first watertight grid is used.
  std::vector<double> voxel_spacings{1.5, 2, 2.5, 3, 4, 6};
  /// Dilations of the occupied voxels (6-connected steps) that close the gaps between samples,
  /// tried in order at each voxel size: a finer voxel closed by one more step resolves thin
  /// parts better than the next coarser voxel closed by two (rotor's blades, 2-6 spacings
  /// thick: 98.93 -> 99.09 % correct signs with NH-Net normals,
  /// docs/design/decisions.md#flood-fill-one-more-dilation-before-a-coarser-voxel), and the smaller
  /// dilation first keeps every cloud watertight with it as it was (couplingdown lost 0.1 point to
  /// a dilation of 3 alone).
  std::vector<int> dilations{2, 3};
  /// A grid is watertight when fewer than this share of the points have both offsets outside.
  double max_leak = 0.05;
  /// Largest grid side in voxels (the voxel grows for large clouds; memory <= side^3 bytes).
  int max_side = 384;
  /// Typical point spacing (the median distance to the nearest other point; 0 = not known).
  /// When the box needs voxels coarser than the coarsest voxel_spacings of it (a far outlier
  /// stretches the box), no grid is built: such a grid cannot resolve the surface, and filling
  /// a 384^3 grid took 5 s on a 4001-point cloud with one outlier 1000 radii away.
  double typical_spacing = 0;
};

/// The grids tried for points in [lo, hi] with mean nearest distance `spacing` (> 0), in order
/// (sides_grid.hpp sides_grid_plan, with these options).
SidesGridPlan grid_plan(const Eigen::RowVector3d& lo, const Eigen::RowVector3d& hi, double spacing,
                        const InsideOutsideOptions& options);

/// The flood-filled grid of a cloud, and the votes it gives.
class InsideOutside {
 public:
  /// Builds the first watertight grid for `points` (M x 3, finite) with unit normals `normals`
  /// (M x 3), `spacing` the average distance to the nearest other point (> 0), and votes for
  /// each of the M normals (votes()) on `threads` threads (0 = all cores).
  InsideOutside(const Points& points, const Normals& normals, double spacing,
                const InsideOutsideOptions& options = {}, int threads = 0);
  /// The votes for `points` / `normals` (as above) on a grid decided elsewhere (the whole
  /// cloud's, for one of its tiles: sides_grid.hpp), whatever its leak. Throws InvalidOptions
  /// for a grid whose cells do not match its dimensions.
  InsideOutside(const Points& points, const Normals& normals, const SidesGrid& grid, int threads);
  /// Only the leak on `grid` of `points` / `normals` (as above), counted in blocks of points
  /// until it reaches `limit` (> 0; <= 0: all): orient.hpp sides_leaked.
  static int64_t count_leaked(const Points& points, const Normals& normals, const SidesGrid& grid,
                              int threads, int64_t limit);
  ~InsideOutside();
  InsideOutside(const InsideOutside&) = delete;
  InsideOutside& operator=(const InsideOutside&) = delete;

  /// M votes for the normals given to the constructor: +1 points outward, -1 inward, 0
  /// undecided (all 0 when no grid was watertight).
  const std::vector<int8_t>& votes() const { return votes_; }
  /// The vote for normal `n` (unit) at position `p` on the grid used (0 when none).
  int8_t vote(const Eigen::RowVector3d& p, const Eigen::RowVector3d& n) const;
  /// Voxel size used (points' units); 0 when no grid was watertight (an open cloud).
  double voxel() const;
  /// Share of the points whose both offsets reached the outside on the grid used (when none was
  /// watertight: at least max_leak, on the coarsest grid tried, which stopped voting there).
  double leak() const { return leak_; }
  /// The number of those points (leak() x M).
  int64_t leaked() const { return leaked_; }
  /// Grids built and flood-filled (0 when none was tried).
  int grids_built() const { return grids_built_; }

  struct Grid;

 private:
  std::unique_ptr<Grid> grid_;
  std::vector<int8_t> votes_;
  double leak_ = 1;
  int64_t leaked_ = 0;
  int grids_built_ = 0;
};

}  // namespace nhnet::detail
