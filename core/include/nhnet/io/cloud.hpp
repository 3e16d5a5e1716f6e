// In-memory point cloud as read from / written to a file.
#pragma once

#include "nhnet/types.hpp"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace nhnet {

/// Storage type of an extra per-point property, as declared by the file it came from.
enum class ScalarType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

/// A per-point scalar property other than x y z nx ny nz (colour channel, intensity, ...).
/// Values are held as double, which represents every PLY/PCD scalar type exactly.
struct ExtraProperty {
  std::string name;            ///< property name as in the file ("red", "intensity", ...)
  ScalarType type;             ///< declared type, used again when writing
  std::vector<double> values;  ///< N values, one per point, in point order
};

/// A sensor that took (part of) a cloud, in the points' coordinates.
struct Sensor {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< sensor origin
  Eigen::Matrix3d rotation =
      Eigen::Matrix3d::Identity();  ///< sensor axes in the cloud frame (columns)
  std::string source;               ///< for reports: "PCD VIEWPOINT", "E57 scan 'name'"...
};

/// What a LAS/LAZ input carried beyond the points (header, VLRs, EVLRs, every point's raw record),
/// so that writing LAS/LAZ again passes each attribute through bit-exact. Defined in
/// core/src/io/las.hpp; opaque here.
struct LasSource;

/// A point cloud: N x 3 points, optional N x 3 normals, and extra per-point properties that are
/// carried through estimation unchanged.
struct Cloud {
  Points points;                      ///< N x 3 coordinates (may contain non-finite rows)
  Normals normals;                    ///< N x 3 normals, or 0 x 3 when the file has none
  std::vector<ExtraProperty> extras;  ///< other per-point properties, in file order
  /// N confidences of the normals (EstimateResult::confidence), or empty. Written by every
  /// writer as its format's own field (PLY / PCD `confidence`, LAS / LAZ extra bytes
  /// `Confidence`, E57 `nhnet:confidence`, XYZ a seventh column after the normals); readers
  /// leave it empty (a file's confidence comes back as an extra).
  Eigen::VectorXd confidence;
  std::vector<Sensor> sensors;  ///< sensors the file names; empty = none known
  std::vector<int32_t>
      sensor_index;         ///< per point, index into sensors; empty = all taken by sensors[0]
  int64_t grid_width = 0;   ///< organized grid (depth image) width, row-major; 0 = unorganized
  int64_t grid_height = 0;  ///< organized grid height; 0 = unorganized
  bool airborne = false;  ///< taken from above, sensor unknown (airborne LAS/LAZ): normals face +z
  /// LAS/LAZ input only: its header, VLRs and raw point records (read-only, shared by copies);
  /// used by the LAS/LAZ writer while the point count is unchanged; null for other inputs.
  std::shared_ptr<const LasSource> las_source;

  Eigen::Index size() const { return points.rows(); }
  bool has_normals() const { return normals.rows() == points.rows() && points.rows() > 0; }
  /// True when the points form a grid_width x grid_height depth image (row-major).
  bool organized() const {
    return grid_width > 0 && grid_height > 0 && grid_width * grid_height == points.rows();
  }
};

}  // namespace nhnet
