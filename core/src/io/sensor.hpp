// Internal to the readers and writers (core/src/io/): sensor poses as the file formats spell
// them. PCD: "VIEWPOINT tx ty tz qw qx qy qz" (translation, unit quaternion); PLY: PCL's
// "element camera" (view_px..z, the three axes x_axis*, y_axis*, z_axis*), see ply.cpp.
#pragma once

#include "nhnet/io/cloud.hpp"

#include <array>
#include <string>

namespace nhnet::io_detail {

/// The sensor at translation `t` turned by the quaternion q = (w, x, y, z), normalised; InputError
/// naming `path` when a value is not finite or q has norm 0 (not a rotation).
Sensor sensor_from_quaternion(const std::string& path, const std::array<double, 3>& t,
                              const std::array<double, 4>& q, const std::string& source);

/// The sensor at `t` with axes `axes` (columns); InputError naming `path` unless they are finite
/// and form a rotation (orthonormal within 1e-3, float precision, and right-handed).
Sensor sensor_from_axes(const std::string& path, const std::array<double, 3>& t,
                        const Eigen::Matrix3d& axes, const std::string& source);

/// True for the pose every PCL file carries by default: position 0, identity rotation (PCD
/// "VIEWPOINT 0 0 0 1 0 0 0"). On an unorganized cloud it says nothing about the sensor.
bool default_pose(const Sensor& sensor);

/// The sensor a writer stores: sensors[0] when every point was taken by it, else none (null).
const Sensor* single_sensor(const Cloud& cloud);

/// The unit quaternion (w, x, y, z) of a rotation matrix.
std::array<double, 4> quaternion_of(const Eigen::Matrix3d& r);

}  // namespace nhnet::io_detail
