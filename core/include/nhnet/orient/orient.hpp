// Normal orientation, a stage after estimation (the paper's normals, like every PCA-type
// estimate, are unoriented: the sign of each normal is arbitrary). Modes:
//   keep       flip each normal to agree with a reference normal of the same point (the input's)
//   viewpoint  flip each normal to point towards a sensor position: (v - p_i) . n_i > 0
//   mst        Hoppe et al. 1992: a minimum spanning tree (Prim) of the symmetric k-NN graph,
//              each edge weighted by 1 - |c_ij| with c_ij the agreement of the two normals, the
//              orientation propagated from a seed (the highest point of the component, its
//              normal turned to +z, i.e. outward on a closed surface), one tree per connected
//              component; the point order never changes. CGAL's mst_orient_normals takes
//              c_ij = n_i . n_j; here n_i is first mirrored at the plane bisecting p_i p_j
//              (OrientOptions::reflect), which stays right across sharp edges and thin walls.
//              By default it propagates smooth PCA guide normals and copies their signs (see
//              OrientOptions::smooth_guide).
//   sensors    like viewpoint, each point towards its own sensor (OrientOptions::sensors and
//              sensor_index: merged scans, E57 files with several poses)
//   up         taken from above (airborne LiDAR): n_z > 0 wherever the surface is not near
//              vertical (|n_z| >= OrientOptions::up_min_z); the near-vertical rest takes its sign
//              from the MST grown from those decided points at once
//   auto       not a mode of its own: resolve_orientation() (auto.hpp) turns it into one of the
//              above from what the cloud carries (input normals, sensors, organized grid,
//              airborne); orient_normals() refuses it unresolved
//   none       leave the signs as they are
#pragma once

#include "nhnet/orient/sides_grid.hpp"
#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace nhnet {

enum class OrientMode { None, Keep, Viewpoint, Mst, Sensors, Up, Auto };

/// "none" / "keep" / "viewpoint" / "mst" / "sensors" / "up" / "auto"; throws InvalidOptions
/// otherwise.
OrientMode orient_mode_from_string(const std::string& name);
const char* to_string(OrientMode mode);

struct OrientOptions {
  /// Which orientation to apply.
  OrientMode mode = OrientMode::Mst;
  /// Viewpoint mode: the sensor position, in the points' coordinates.
  Eigen::Vector3d viewpoint = Eigen::Vector3d::Zero();
  /// Sensors mode: the sensor positions, in the points' coordinates.
  std::vector<Eigen::Vector3d> sensors;
  /// Sensors mode: per point, its sensor's index into `sensors`; empty = all sensors[0].
  std::vector<int32_t> sensor_index;
  /// Up mode: a normal with |n_z| >= up_min_z is turned to n_z > 0; the others (near-vertical
  /// surfaces, walls) take their sign from the MST. 0.5 = surfaces tilted up to 60 degrees from
  /// horizontal. An airborne scanner looks down within about 30 degrees of nadir (typical field
  /// of view +-20..30 degrees), so a surface it sees with n_z <= -0.5 would face away from every
  /// line of sight: below 30 degrees of tilt from vertical the sign is certain from z alone.
  double up_min_z = 0.5;
  /// Mst mode: neighbours per point in the k-NN graph, self included (CGAL's examples: 18; at
  /// least 2). Larger k bridges gaps between sampled parts, smaller k keeps thin parts apart.
  int k = 18;
  /// Mst: propagate over guide normals, PCA normals over the guide_k nearest neighbours, and
  /// give each normal the sign of its point's oriented guide. Sharp normals (MFPS, NH-Net) are
  /// perpendicular across an edge, where propagation is a coin flip; wide PCA normals turn
  /// smoothly over edges and average the noise out. Measured on the fandisk sample (0.6 % noise)
  /// with MFPS normals, share agreeing in sign with the truth: propagated directly 75 %; through
  /// a guide of 18 / 30 / 50 / 90 neighbours 98.7 / 99.5 / 99.7 / 99.7 % (99.93 % of the points
  /// whose normal is within 60 degrees of the truth). false = propagate the normals themselves.
  bool smooth_guide = true;
  /// Neighbourhood size of the guide's PCA (self included, >= 3).
  int guide_k = 50;
  /// Mst: decide whether two neighbours' signs agree by mirroring n_i at the plane bisecting
  /// p_i p_j before the dot product with n_j (König & Gumhold 2009's idea), instead of Hoppe's
  /// plain n_i . n_j. Exact on spheres, across sharp edges and across thin walls (the two sides
  /// of a blade face away from each other: n_i . n_j = -1 would copy a wrong sign through the
  /// wall). false = Hoppe / CGAL's criterion.
  bool reflect = true;
  /// Mst: after propagation, flip a component whose normals point towards its centroid on the
  /// whole (sum_i (p_i - c) . n_i < 0; on a closed surface that sum is 3 x the volume for
  /// outward normals). false = the seed rule alone (highest point's normal to +z, as CGAL).
  bool outward_vote = true;
  /// Mst: decide each point's side by a voxel flood fill of the space around the cloud where
  /// the sampled surface is closed (core/src/orient/inside_outside.hpp), and grow the tree from
  /// every decided point at once; open clouds (the fill leaks into the interior) are left to the
  /// tree alone. Measured on the benchmark's closed models
  /// (docs/design/decisions.md#inside-or-outside-by-a-voxel-flood-fill): thin-bladed rotor 71 % ->
  /// 98 %, couplingdown at 0.4-0.5 % noise 92 % -> 99 %. false = the tree alone.
  bool inside_outside = true;
  /// Mst with inside_outside: the flood-filled grid to vote on instead of building one from
  /// the points (sides_grid.hpp): the whole cloud's grid, decided once and handed to each tile
  /// of a distributed run. nullptr = built here, from these points.
  std::shared_ptr<const SidesGrid> sides;
  /// Mst: each row's guide normal as the MST would fit it (MstGuides::row_guides of the same
  /// points, normals and options), so that a tile of a distributed run fits its guides once for
  /// the flood fill's leak count and its MST: the guide's PCA is skipped (the neighbour search
  /// keeps its depth, so the graph is the same). nullptr = fitted here.
  std::shared_ptr<const Normals> guides;
  /// Mst: the points' neighbour table (EstimateResult::neighbours of the same points: N rows,
  /// itself first, nearest first) used for the graph and the guides instead of a search of its
  /// own, when it has shared_neighbours() columns (or N) and every point takes part (valid
  /// normals, no exact duplicates); otherwise the search runs as without it. nullptr = search.
  std::shared_ptr<const IndexMatrix> neighbours;
  /// Mirror only pairs whose offset along both normals exceeds reflect_noise x the noise (the
  /// median over the points of the median |(p_j - p_i) . n_i| over their k nearest); below that
  /// the mirror mostly reflects noise.
  double reflect_noise = 4.0;
  /// Mirror only pairs whose offset makes at least this cosine with both normals (j lies above
  /// or below p_i's tangent plane, as across a wall); other pairs use n_i . n_j.
  double reflect_min = 0;
  /// Threads (0 = all cores) and progress/cancel callback.
  RunContext run;
};

struct OrientResult {
  /// Normals whose sign was changed.
  int64_t flipped = 0;
  /// Valid normals whose sign could not be decided: keep, the reference normal is missing (NaN
  /// or zero) or perpendicular; viewpoint, the normal is perpendicular to the line of sight;
  /// mst, the normal is perpendicular to its oriented guide normal. Left as they were.
  int64_t unoriented = 0;
  /// Normals that are NaN or zero, or whose point is non-finite (never touched).
  int64_t invalid = 0;
  /// Mst: connected components of the k-NN graph over the valid points, and how many of them
  /// could not be oriented completely (always 0 since the MST is our own: every point of a
  /// component is reached; kept for the callers that report it).
  int64_t components = 0;
  int64_t unoriented_components = 0;
  /// Mst: points that had to be completed outside the spanning tree. Always 0 since the MST runs
  /// on the symmetric k-NN graph (CGAL's one-sided graph could fall apart inside a component);
  /// kept for the callers that report it.
  int64_t completed = 0;
  /// Mst with inside_outside: points whose side the flood fill decided, and its voxel size in
  /// the points' units (0 = no watertight grid: the cloud is open, the tree alone decided).
  int64_t inside_outside_votes = 0;
  double voxel = 0;
};

/// Columns of a neighbour table that an orientation with `options` can reuse
/// (EstimateOptions::neighbours, OrientOptions::neighbours): Mst and Up, k or, with the smooth
/// guide, max(k, guide_k); 0 for the other modes.
int shared_neighbours(const OrientOptions& options);

/// Orients `normals` (N x 3, rows of `points`, N x 3) in place; the order of the rows never
/// changes. `reference` (N x 3) is needed by OrientMode::Keep only. Throws InvalidOptions for
/// bad options or mismatched sizes, Cancelled when the progress callback returns false.
OrientResult orient_normals(const Points& points, Normals& normals, const OrientOptions& options,
                            const Normals& reference = Normals());

/// Flips each valid row of `normals` (N x 3) whose dot product with the matching row of
/// `reference` (N x 3) is negative, so signs agree with the reference ("--orient keep").
/// Rows where the reference is zero or non-finite are left as they are. Returns how many were
/// flipped.
int64_t orient_like(Normals& normals, const Normals& reference);

/// Distributed MST (issue 25): for a tile given as its own rows [0, own) then its halo, the
/// distance from each distinct valid own point to its nearest other point in the MST's graph
/// over all the rows: the single-process MST's spacing terms (their mean is its flood fill's
/// unit, their median its typical spacing), summed over tiles. Options as orient_normals'.
std::vector<double> mst_nearest(const Points& points, const Normals& normals, int64_t own,
                                const OrientOptions& options);

/// Distributed MST: a tile's distinct valid own points (rows [0, own)) and their guide normals
/// as the MST builds them over all the rows (OrientOptions::smooth_guide), the normals its flood
/// fill votes with (sides_leaked), from one neighbour search and one fit per tile.
struct MstGuides {
  /// The distinct valid own points and their guides.
  Points points;
  Normals guides;
  /// mst_nearest's distances (the same graph).
  std::vector<double> nearest;
  /// Every row's guide (NaN for rows the MST does not take: invalid or a later exact
  /// duplicate), for OrientOptions::guides.
  Normals row_guides;
};
MstGuides mst_guides(const Points& points, const Normals& normals, int64_t own,
                     const OrientOptions& options);

/// How many of `points` (with their unit `guides`) reach the outside of `grid` on both sides:
/// summed over the tiles and divided by their count, the leak that decides whether the whole
/// cloud's candidate grid is watertight (SidesGridPlan::max_leak), as in one process. With
/// `limit` > 0 the count stops, in blocks of points, once it reaches `limit`: a count >= limit
/// says only "at least limit" (an open cloud's grids leak almost everywhere, and a lower bound
/// already above the limit decides as the full count would).
int64_t sides_leaked(const Points& points, const Normals& guides, const SidesGrid& grid,
                     int threads, int64_t limit = 0);

}  // namespace nhnet
