// Sensors and viewpoint modes (orient.hpp): each normal towards its own point's sensor.
#include "orient/sensors.hpp"

#include "nhnet/errors.hpp"

#include <string>

namespace nhnet::detail {

void check_sensors(const Points& points, const OrientOptions& options) {
  if (options.sensors.empty()) throw InvalidOptions("orient sensors: no sensor positions given");
  for (const Eigen::Vector3d& s : options.sensors)
    if (!s.allFinite()) throw InvalidOptions("orient sensors: a sensor position is not finite");
  const std::vector<int32_t>& index = options.sensor_index;
  if (index.empty()) return;
  if (Eigen::Index(index.size()) != points.rows())
    throw InvalidOptions("orient sensors: " + std::to_string(index.size()) +
                         " sensor indices for " + std::to_string(points.rows()) + " points");
  for (const int32_t s : index)
    if (s < 0 || size_t(s) >= options.sensors.size())
      throw InvalidOptions("orient sensors: sensor index " + std::to_string(s) + " out of range (" +
                           std::to_string(options.sensors.size()) + " sensors)");
}

void orient_towards(const Points& points, Normals& normals,
                    const std::vector<Eigen::Vector3d>& sensors, const std::vector<int32_t>& index,
                    const std::vector<int64_t>& used, OrientResult& res) {
  for (const int64_t i : used) {
    const Eigen::Vector3d& s = sensors[index.empty() ? 0 : size_t(index[size_t(i)])];
    const double d = (s.transpose() - points.row(i)).dot(normals.row(i));
    if (d < 0) {
      normals.row(i) *= -1.0;
      ++res.flipped;
    } else if (!(d > 0)) {
      ++res.unoriented;
    }
  }
}

}  // namespace nhnet::detail
