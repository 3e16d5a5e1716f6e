// Out-of-core normal estimation (not a paper stage; issue 10): a cloud that does not fit in
// memory is read from its file in passes and processed in spatial tiles with halos, so memory is
// one tile's working set whatever the cloud's size; the intermediate tiles live in temporary
// files on disk. The tiles and the decisions taken once for the whole cloud (noise level,
// neighbourhood sizes, MFPS's candidate threshold) are those of the in-memory tiling
// (estimate.hpp, TileOptions), so the normals equal the in-memory run's up to the noise probe's
// sampling (tested).
#pragma once

#include "nhnet/orient/orient.hpp"
#include "nhnet/pipeline/estimate.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace nhnet {

struct StreamOptions {
  /// The estimator and its options; `estimate.tiles.points` (> 0) is the points per tile.
  EstimateOptions estimate;
  /// Orientation, applied point by point while the output is written: None, Keep (the input's
  /// normals, XYZ columns 4-6; None with a warning when the input has none), Viewpoint, or Auto
  /// (Keep when the input has normals, else None: an XYZ file names no sensor). Mst, Up and
  /// Sensors need the whole cloud and are refused.
  OrientOptions orient;
  /// Folder for the temporary tile files (about 48 bytes per point); "" = the output's folder.
  std::string temp_dir;
  /// Points kept (reservoir sample) to place the tile boundaries.
  int64_t plan_sample = 1000000;
  /// Most points whose surface variations are kept for MFPS's candidate threshold (an evenly
  /// spaced subset beyond that; the threshold is a histogram quantity).
  int64_t variation_sample = 20000000;
  /// Binary (default) or ASCII PLY output.
  bool ascii = false;
  /// Keep on an input without normals: warn (true) or fall back to None silently (false, for
  /// front ends whose default is "keep when the input has normals").
  bool warn_keep_without_normals = true;
};

struct StreamResult {
  /// Points (data lines) read; points that got no normal (non-finite or degenerate).
  int64_t points = 0;
  int64_t failed = 0;
  /// Spatial tiles, candidates (MFPS, NH-Net), the sizes used, the noise level and spacing
  /// (input units), as in EstimateResult.
  int tiles = 0;
  int64_t candidates = 0;
  int k_used = 0;
  std::vector<int> scales_used;
  double noise_ratio = 0;
  double spacing = 0;
  std::string device_used;
  std::string precision_used;  ///< NH-Net only: as EstimateResult::precision_used
  /// Cell means the tiles were estimated through, summed over the tiles (a mean near a tile's
  /// border counts in each tile whose halo holds it); 0 when the cloud went through its points.
  int64_t cell_means = 0;
  /// With EstimateOptions::confidence: points below kLowConfidence (learned/confidence.hpp);
  /// -1 without it.
  int64_t low_confidence = -1;
  /// Orientation used (Keep falls back to None when the input has no normals) and its counts
  /// (flipped / unoriented / invalid), summed over the written chunks.
  OrientMode orient_mode = OrientMode::None;
  /// Why that orientation: "input normals", "requested", ... (as OrientPlan::source).
  std::string orient_source;
  OrientResult orient;
  /// Non-fatal notes (non-finite points, duplicates, ...).
  std::vector<std::string> warnings;
};

/// Reads the XYZ text cloud `input` (x y z [nx ny nz] ... per line, as read_cloud), estimates
/// normals tile by tile and writes `output` (.ply, or .xyz / .xyzn / .txt: x y z nx ny nz) in
/// the input's point order, through a temporary file renamed at the end; failed points get NaN
/// normals. `output` must not be `input`. Throws InputError (unreadable / malformed input, naming
/// the file and line), InvalidOptions (a PLY / PCD input, Mst / Up / Sensors orientation,
/// tiles.points <= 0, an unsupported output extension), OutputError, Cancelled.
StreamResult estimate_stream(const std::string& input, const std::string& output,
                             const StreamOptions& options);

}  // namespace nhnet
