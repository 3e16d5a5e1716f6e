// Sensor poses of the file formats (sensor.hpp).
#include "io/sensor.hpp"

#include "io/detail.hpp"

#include <cmath>

namespace nhnet::io_detail {

namespace {

double det3(const Eigen::Matrix3d& m) {
  return m(0, 0) * (m(1, 1) * m(2, 2) - m(1, 2) * m(2, 1)) -
         m(0, 1) * (m(1, 0) * m(2, 2) - m(1, 2) * m(2, 0)) +
         m(0, 2) * (m(1, 0) * m(2, 1) - m(1, 1) * m(2, 0));
}

bool finite(const std::array<double, 3>& t) {
  return std::isfinite(t[0]) && std::isfinite(t[1]) && std::isfinite(t[2]);
}

}  // namespace

Sensor sensor_from_quaternion(const std::string& path, const std::array<double, 3>& t,
                              const std::array<double, 4>& q, const std::string& source) {
  const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!finite(t)) input_error(path, source + ": the sensor position is not finite");
  if (!std::isfinite(norm) || norm < 1e-9)
    input_error(path, source + ": the orientation quaternion (" + std::to_string(q[0]) + ", " +
                          std::to_string(q[1]) + ", " + std::to_string(q[2]) + ", " +
                          std::to_string(q[3]) + ") is not a rotation (norm 0 or not finite)");
  const double w = q[0] / norm, x = q[1] / norm, y = q[2] / norm, z = q[3] / norm;
  Sensor s;
  s.position = Eigen::Vector3d(t[0], t[1], t[2]);
  s.rotation << 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),  //
      2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),            //
      2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y);
  s.source = source;
  return s;
}

Sensor sensor_from_axes(const std::string& path, const std::array<double, 3>& t,
                        const Eigen::Matrix3d& axes, const std::string& source) {
  if (!finite(t)) input_error(path, source + ": the sensor position is not finite");
  const double off = (axes.transpose() * axes - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!axes.allFinite() || !(off < 1e-3) || !(det3(axes) > 0))
    input_error(path, source +
                          ": the sensor axes are not a rotation (not orthonormal, "
                          "left-handed or not finite)");
  Sensor s;
  s.position = Eigen::Vector3d(t[0], t[1], t[2]);
  s.rotation = axes;
  s.source = source;
  return s;
}

bool default_pose(const Sensor& sensor) {
  return sensor.position.isZero(0) && sensor.rotation.isIdentity(1e-6);
}

const Sensor* single_sensor(const Cloud& cloud) {
  if (cloud.sensors.empty()) return nullptr;
  for (const int32_t s : cloud.sensor_index)
    if (s != 0) return nullptr;
  return &cloud.sensors.front();
}

std::array<double, 4> quaternion_of(const Eigen::Matrix3d& r) {
  // Shepperd's method: the largest of w, x, y, z first, for precision.
  const double tr = r.trace();
  std::array<double, 4> q{};
  if (tr > 0) {
    const double s = 2 * std::sqrt(tr + 1);
    q = {s / 4, (r(2, 1) - r(1, 2)) / s, (r(0, 2) - r(2, 0)) / s, (r(1, 0) - r(0, 1)) / s};
  } else if (r(0, 0) > r(1, 1) && r(0, 0) > r(2, 2)) {
    const double s = 2 * std::sqrt(1 + r(0, 0) - r(1, 1) - r(2, 2));
    q = {(r(2, 1) - r(1, 2)) / s, s / 4, (r(0, 1) + r(1, 0)) / s, (r(0, 2) + r(2, 0)) / s};
  } else if (r(1, 1) > r(2, 2)) {
    const double s = 2 * std::sqrt(1 + r(1, 1) - r(0, 0) - r(2, 2));
    q = {(r(0, 2) - r(2, 0)) / s, (r(0, 1) + r(1, 0)) / s, s / 4, (r(1, 2) + r(2, 1)) / s};
  } else {
    const double s = 2 * std::sqrt(1 + r(2, 2) - r(0, 0) - r(1, 1));
    q = {(r(1, 0) - r(0, 1)) / s, (r(0, 2) + r(2, 0)) / s, (r(1, 2) + r(2, 1)) / s, s / 4};
  }
  return q;
}

}  // namespace nhnet::io_detail
