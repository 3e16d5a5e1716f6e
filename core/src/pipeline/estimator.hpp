// Internal API of the estimator, shared by the pipeline's files: estimate.cpp (the front door and
// the geometry stage), refine.cpp (NH-Net), describe.cpp, tiling.cpp and stream.cpp (the two
// tilings). Canonical point order, the normalised frame, the noise probe, the decisions a tiling
// takes once for the whole cloud, and the stage functions every path calls (nothing re-enters
// estimate_normals).
#pragma once

#include "nhnet/geometry/radial.hpp"
#include "nhnet/geometry/scales.hpp"
#include "nhnet/neighbors/neighbors.hpp"
#include "nhnet/pipeline/describe.hpp"
#include "nhnet/pipeline/estimate.hpp"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace nhnet::detail {

/// What a tiling measured once on the whole cloud and hands every tile, so that each tile uses
/// the whole cloud's sizes and threshold (not user options).
struct TileOverrides {
  /// Noise ratio and point spacing of the whole cloud (spacing in the tile's coordinates). When
  /// spacing > 0 the noise probe is skipped and these choose the neighbourhood sizes.
  double noise_ratio = 0;
  double spacing = 0;
  /// MFPS's candidate threshold on the surface variation (FeatureDetection::absolute_threshold);
  /// < 0 = chosen from this cloud's histogram.
  double variation_threshold = -1;
  /// The cloud's canonical points and kd-tree when a step before the estimate built them (the
  /// cell-mean decision's probe): estimate_geometry takes them over instead of building its own.
  struct Prepared* prepared = nullptr;
};

/// With options.confidence, res.confidence from res's normals, curvatures and noise ratio over
/// `points` (learned/confidence.hpp, the weights of options.method); else, or when res has one
/// already (a run through cell means blends its means' confidences), nothing.
void add_confidence(const Points& points, const EstimateOptions& options, EstimateResult& res);

/// A result for n points with NaN normals and curvatures and nothing valid yet.
EstimateResult empty_result(Eigen::Index n);

/// One cloud (or one tile) through the stages its method needs, untiled: the geometry stage, then
/// NH-Net for Method::NhNet. Options are already checked.
EstimateResult estimate_cloud(const Points& points, const EstimateOptions& options,
                              const TileOverrides& overrides);

/// `points` in tiles when they want them (estimate_tiled), else in one piece (estimate_cloud with
/// `overrides`): estimate_normals after its cell-mean decision. Options are already checked.
EstimateResult estimate_points(const Points& points, const EstimateOptions& options,
                               const TileOverrides& overrides);

/// What the geometry stage knows besides its normals, for NH-Net's candidate mix
/// (learned/candidate_mix.hpp); input rows, like EstimateResult.
struct GeometrySide {
  /// N x 3 PCA normals (k_used neighbours); NaN where the point failed.
  Normals pca;
  /// N: weight of the PCA normal in MFPS's PCA blend (mfps_blend.cpp), whether or not the blend
  /// was applied; 0 for points that are no candidate or have no rival face.
  Eigen::VectorXd blend_weight;
  /// N x 3 jet normals (geometry/jet.hpp, k_used neighbours, PCA's frame); NaN where none.
  Normals jet;
  /// N x 3 PCA normals over mix_half_k(k_used) neighbours, and their surface variations; NaN
  /// where none.
  Normals half;
  Eigen::VectorXd half_variation;
  /// Radial normals (geometry/radial.hpp) with their offsets and elongations, over k_used and
  /// mix_half_k(k_used) neighbours; NaN where none.
  RadialResult radial, radial_half;
  /// N x kMixNeighbours (fewer in a tiny cloud) nearest input rows of each point, self first;
  /// a point without a normal lists only itself, a duplicate its first copy's row.
  IndexMatrix knn;
  /// N x kFitMembers members of each point for the learned fit (learned/learned_fit.hpp), spread
  /// over its learned_fit_k(k_used) nearest, input rows, self first; empty when the cloud has
  /// fewer points than that.
  IndexMatrix members;
};

/// The geometry stage's neighbour table handed on to the descriptors, so that one k-NN search
/// serves MFPS and NH-Net's descriptors alike (issue 23).
struct SharedTable {
  /// Input: the options of the descriptors that follow; the table reaches their k
  /// (descriptor_k of the smallest MFPS scale).
  DescriptorOptions descriptor;
  /// Output: the canonical points' table (canonical indices, each row sorted by distance, self
  /// first), at least the descriptors' k deep, and the input row of each canonical point. Left
  /// empty when some input row is a duplicate or not finite: the descriptors search their own.
  IndexMatrix knn;
  std::vector<int64_t> rows;
};

/// The geometry stage (paper Sec. 4): PCA everywhere, and MFPS near sharp features when
/// options.method is Mfps (NH-Net's callers pass geometry_options(), which sets it). With
/// `side`, also what GeometrySide holds; with `table`, its neighbour table for the descriptors.
EstimateResult estimate_geometry(const Points& points, const EstimateOptions& options,
                                 const TileOverrides& overrides, GeometrySide* side = nullptr,
                                 SharedTable* table = nullptr);

/// NH-Net on top of the geometry stage (paper Sec. 5, refine.cpp).
EstimateResult estimate_nhnet(const Points& points, const EstimateOptions& options,
                              const TileOverrides& overrides);

/// The descriptor input of a cloud whose geometry stage ran (describe.cpp): the rows with a
/// normal, their points, normals and k-NN table at the descriptor's size. With `only` (one flag
/// per input row), only the flagged rows are described: they come first (`described` of them,
/// each with a k-NN row), the other rows with a normal follow as neighbours. With a filled
/// `table` (estimate_geometry's) and every row with a normal, the rows follow the canonical
/// order and the table is taken (moved) instead of searched anew.
/// `options` are checked by the caller (neighborhood_factor > 0).
DescriptorInput descriptor_input(const Points& points, EstimateResult geometry,
                                 const DescriptorOptions& options, const RunContext& run,
                                 const std::vector<uint8_t>* only = nullptr,
                                 SharedTable* table = nullptr);

/// The options of the geometry stage under the descriptors (training and NH-Net alike): MFPS,
/// the PCA blend as given, the first 90 % of `options.run`'s progress (the neighbour table of
/// descriptor_input takes the rest).
EstimateOptions geometry_options(const EstimateOptions& options, bool pca_blend);

/// The finite, deduplicated points of a cloud in canonical (lexicographic) order, normalised.
struct Canonical {
  /// Row of `points` for each canonical point (M).
  std::vector<int64_t> rows;
  /// For every row of `points` (N): the row of its first exact copy, -1 when not finite.
  std::vector<int64_t> copies;
  /// Finite rows of `points`, duplicates included.
  size_t finite_count = 0;
  /// M x 3 canonical points in the normalised frame (normalise()).
  Points pts;
  /// Input length of one normalised unit.
  double unit = 1;
};

/// Recentres `pts` (N x 3, finite) and scales it by a power of two into [-2, 2); returns the
/// input length of one normalised unit.
double normalise(Points& pts);

/// Canonical points of `points` (N x 3); appends the non-finite / duplicate warnings. Throws
/// UnprocessableInput when fewer than 3 distinct finite points remain.
Canonical canonical_points(const Points& points, std::vector<std::string>& warnings);

struct Probe {
  /// Noise ratio and spacing (units of the probed points).
  NoiseEstimate noise;
  /// 99th percentile of the distance to the far_k-th nearest point among the probed points.
  double far_radius = 0;
  int far_k = 0;
};

/// What estimate_geometry and estimate_tiled would build first: the canonical points,
/// canonical_points' warnings, the kd-tree over the points (TileOverrides::prepared) and the
/// noise probe over them, for the rows at `source` only (NH-Net's stage runs on its rows in
/// another order and takes them over through permute_prepared, row_order.hpp).
struct Prepared {
  const double* source = nullptr;
  Canonical canon;
  std::vector<std::string> warnings;
  std::unique_ptr<Neighbors> tree;
  /// The probe of canon.pts over `tree`, when the step that built them ran it (`probed`).
  Probe probe;
  bool probed = false;
};

/// Builds `prepared` for `points`: their canonical points, kd-tree and noise probe (`run`: the
/// probe's progress), what a step before the estimate leaves it (the cell-mean decision's).
void prepare_points(const Points& points, Prepared& prepared, const RunContext& run);

/// prepare_points without the probe (a tile through cell means is given the whole cloud's noise).
void index_points(const Points& points, Prepared& prepared);

/// The noise probe of `pts` (M x 3, canonical order) over `tree` (built on pts): every point of
/// clouds up to kProbeAllPoints (then `table`, when given, receives the M x 75 probe table),
/// an evenly spaced subset of larger ones.
Probe probe_noise(const Points& pts, const Neighbors& tree, const RunContext& run,
                  IndexMatrix* table);

/// The probe's result from its rows: `d2` (R x K) squared distances to each probed point's K
/// nearest (self first) and `residual` (R x 2) their probe_residuals, in one length unit.
Probe probe_from_rows(const DistanceMatrix& d2, const ProbeResiduals& residual);

/// What a tiled run (in memory or streamed) hands its tiles: the sizes for the probe's noise level
/// over m points (the options' k and scales win), the largest neighbourhood the stages use, and
/// neighbourhood radii from the probe's far radius.
struct TileSizes {
  ScaleChoice choice;
  int kneed = 0;
  double far_radius = 0;
  int far_k = 0;
  /// Radius of a k-neighbourhood (area ~ k on a surface; never below the probe's own radius).
  double radius(int k) const;
  /// Halo widths (frame units) of the in-memory tiling (tiling.cpp) for a tile's estimate and
  /// for its surface-variation pass: TileOptions::halo radii of the largest neighbourhood for
  /// MFPS and NH-Net; PCA and the variation pass, whose values depend on one neighbourhood only,
  /// keep the same margin over that one radius (halo - 2, at least a third of halo). The
  /// streamed and distributed tiles (tiles.cpp) keep halo for every stage: a distributed MST
  /// fits its guide normals (50 neighbours) over a tile's halo too.
  double estimate_halo(const EstimateOptions& options) const;
  double variation_halo(const EstimateOptions& options) const;
};
TileSizes tile_sizes(const Probe& probe, const EstimateOptions& options, int64_t m);

/// Halo radii for a stage whose values depend on one neighbourhood (and its neighbours') only,
/// from TileOptions::halo: halo - 2, at least a third of halo.
double one_radius_halo(double halo);

/// Surface variation (pca.hpp) of every row of `pts` at k neighbours: the tiled runs' first
/// pass, tile by tile (tiling.cpp, tiles.cpp's tile_variation).
Eigen::VectorXd surface_variation(const Points& pts, int k, const RunContext& run);

/// Copies each duplicate's result from its first copy (`copies`, from Canonical), counts the
/// failed rows and warns about the degenerate ones (beyond the N - finite_count non-finite).
void finish_result(EstimateResult& res, const std::vector<int64_t>& copies, size_t finite_count);

/// Throws InvalidOptions for options no stage accepts.
void check_options(const EstimateOptions& options);

/// True when `points` has more finite rows than options.tiles.points (> 0).
bool wants_tiles(const Points& points, const EstimateOptions& options);

/// One kd-tree split of the tilings: the longest axis of the bounding box of rows
/// order[begin, end) of `pts` (N x 3), cut at the point-count quantile (parts / 2) / parts;
/// reorders the range so that [begin, mid) are below the cut (ties by row).
struct RangeCut {
  int axis;
  int64_t mid;
  double value;  ///< coordinate of order[mid] on `axis`
};
RangeCut split_range(const Points& pts, std::vector<int64_t>& order, int64_t begin, int64_t end,
                     int64_t parts);

/// Estimated peak bytes of an untiled estimate of m points whose deepest neighbour table has
/// kneed columns (TileOptions::memory).
int64_t untiled_bytes(int64_t m, int kneed, Method method);

/// estimate_normals in spatial tiles with halos (tiling.cpp), or in one piece when that fits in
/// TileOptions::memory. `prepared` (may be null): the canonical points, tree and probe of
/// `points` when a step before built them (the cell-mean decision); else built here. Either
/// way they serve the run in one piece, or the tiling (the tree then released).
EstimateResult estimate_tiled(const Points& points, const EstimateOptions& options,
                              Prepared* prepared);

}  // namespace nhnet::detail
