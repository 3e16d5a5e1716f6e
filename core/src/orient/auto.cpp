// --orient auto: the concrete orientation a cloud's file asks for (auto.hpp).
#include "nhnet/orient/auto.hpp"

#include "nhnet/errors.hpp"

#include <cstdio>
#include <string>

namespace nhnet {

namespace {

std::string point_text(const Eigen::Vector3d& p) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "(%g, %g, %g)", p.x(), p.y(), p.z());
  return buf;
}

/// sensor_index, if given, has one entry per point, each naming one of the sensors.
void check_sensor_index(const Cloud& cloud) {
  if (cloud.sensor_index.empty()) return;
  if (Eigen::Index(cloud.sensor_index.size()) != cloud.size())
    throw InvalidOptions("orient auto: " + std::to_string(cloud.sensor_index.size()) +
                         " sensor indices for " + std::to_string(cloud.size()) + " points");
  for (const int32_t s : cloud.sensor_index)
    if (s < 0 || size_t(s) >= cloud.sensors.size())
      throw InvalidOptions("orient auto: sensor index " + std::to_string(s) + " out of range (" +
                           std::to_string(cloud.sensors.size()) + " sensors)");
}

/// True when every point was taken by sensors[0] (sensor_index empty or all 0).
bool single_sensor(const Cloud& cloud) {
  for (const int32_t s : cloud.sensor_index)
    if (s != 0) return false;
  return true;
}

/// Viewpoint (one sensor) or Sensors (a sensor per point) from cloud.sensors.
void plan_sensors(const Cloud& cloud, OrientPlan& plan) {
  check_sensor_index(cloud);
  const Sensor& first = cloud.sensors.front();
  if (single_sensor(cloud)) {
    plan.options.mode = OrientMode::Viewpoint;
    plan.options.viewpoint = first.position;
    plan.source = "sensor from " + (first.source.empty() ? std::string("the file") : first.source) +
                  " at " + point_text(first.position);
    return;
  }
  plan.options.mode = OrientMode::Sensors;
  plan.options.sensors.clear();
  for (const Sensor& s : cloud.sensors) plan.options.sensors.push_back(s.position);
  plan.options.sensor_index = cloud.sensor_index;
  plan.source = std::to_string(cloud.sensors.size()) + " sensors (" +
                (first.source.empty() ? std::string("from the file") : first.source) +
                (cloud.sensors.size() > 1 ? ", ...)" : ")");
}

}  // namespace

OrientPlan resolve_orientation(const Cloud& cloud, const OrientOptions& requested) {
  OrientPlan plan{requested, "requested"};
  if (requested.mode != OrientMode::Auto) return plan;
  if (cloud.has_normals()) {
    plan.options.mode = OrientMode::Keep;
    plan.source = "input normals";
  } else if (!cloud.sensors.empty()) {
    plan_sensors(cloud, plan);
  } else if (cloud.organized()) {
    plan.options.mode = OrientMode::Viewpoint;
    plan.options.viewpoint = Eigen::Vector3d::Zero();
    plan.source = "organized " + std::to_string(cloud.grid_width) + "x" +
                  std::to_string(cloud.grid_height) + " grid: sensor at the origin";
  } else if (cloud.airborne) {
    plan.options.mode = OrientMode::Up;
    plan.source = "airborne: up (+z)";
  } else {
    plan.options.mode = OrientMode::Mst;
    plan.source = "no sensor in the file: MST";
  }
  return plan;
}

}  // namespace nhnet
