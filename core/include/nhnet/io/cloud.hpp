// In-memory point cloud as read from / written to a file.
#pragma once

#include "nhnet/types.hpp"

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

/// A point cloud: N x 3 points, optional N x 3 normals, and extra per-point properties that are
/// carried through estimation unchanged.
struct Cloud {
  Points points;                      ///< N x 3 coordinates (may contain non-finite rows)
  Normals normals;                    ///< N x 3 normals, or 0 x 3 when the file has none
  std::vector<ExtraProperty> extras;  ///< other per-point properties, in file order

  Eigen::Index size() const { return points.rows(); }
  bool has_normals() const { return normals.rows() == points.rows() && points.rows() > 0; }
};

}  // namespace nhnet
