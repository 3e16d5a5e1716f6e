// The default orientation ("--orient auto"): the mode a cloud's own file asks for. A sensor
// position decides every sign exactly (each point was seen from it, so its normal faces it); the
// MST only guesses from the shape. resolve_orientation() picks, in this order:
//   the input has normals               -> keep (their signs)
//   the file names sensors              -> viewpoint (one) or sensors (one per point)
//   an organized grid (depth image)     -> viewpoint at the origin (PCL's convention: an
//                                          organized cloud is in its camera's frame)
//   airborne (LAS/LAZ from above)       -> up
//   otherwise                           -> mst
#pragma once

#include "nhnet/io/cloud.hpp"
#include "nhnet/orient/orient.hpp"

#include <string>

namespace nhnet {

/// The orientation every front end (CLI, Python, plugins) applies when none is asked for.
constexpr OrientMode kDefaultOrientMode = OrientMode::Auto;

/// A concrete orientation and why it was chosen.
struct OrientPlan {
  /// The options to pass to orient_normals(); mode is never Auto.
  OrientOptions options;
  /// One line for reports and logs: "input normals", "sensor from PCD VIEWPOINT at (0, 0, 0)",
  /// "2 sensors (E57 scan 'a', ...)", "airborne: up (+z)", "no sensor in the file: MST", or
  /// "requested" when the mode was not Auto.
  std::string source;
};

/// Turns OrientMode::Auto into a concrete mode from what the cloud carries: input normals -> Keep;
/// sensors (PCD VIEWPOINT, organized grid, E57 poses, PLY sensor) -> Viewpoint/Sensors; airborne
/// -> Up; else Mst. Every other field of `requested` (k, threads, ...) is kept; a mode other
/// than Auto is returned as it is. Throws InvalidOptions when the cloud's sensor_index does not
/// match its points or sensors.
OrientPlan resolve_orientation(const Cloud& cloud, const OrientOptions& requested);

}  // namespace nhnet
