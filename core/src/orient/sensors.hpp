// Internal to the orientation stage (orient.cpp): the modes with a known sensor per point
// (sensors.cpp) and the airborne rule (up.cpp), see orient.hpp.
#pragma once

#include "nhnet/orient/orient.hpp"
#include "nhnet/types.hpp"

#include <cstdint>
#include <vector>

namespace nhnet::detail {

/// Throws InvalidOptions unless options.sensors is non-empty and finite and sensor_index is
/// empty or has one entry per point naming one of them.
void check_sensors(const Points& points, const OrientOptions& options);

/// Each normal of the rows `used` towards its own point's sensor (sensors[index[i]], or
/// sensors[0] when `index` is empty), (s - p_i) . n_i > 0; perpendicular ones count as
/// unoriented. The sensors mode (options.sensors, options.sensor_index) and the viewpoint mode
/// (the viewpoint as the one sensor).
void orient_towards(const Points& points, Normals& normals,
                    const std::vector<Eigen::Vector3d>& sensors, const std::vector<int32_t>& index,
                    const std::vector<int64_t>& used, OrientResult& res);

/// Up mode, the seeds of the MST: per row of `guide`, +1 when its sign is already decided
/// (g_z >= min_z), -1 when it is decided the other way (g_z <= -min_z), 0 near vertical.
std::vector<int8_t> up_votes(const Normals& guide, double min_z);

/// Up mode, after the MST (`mst`: its counts; `before`: the normals before it): every normal of
/// the rows `used` with |n_z| >= min_z |n| turned to n_z > 0, and the counts of the whole stage
/// into `res` (flipped against `before`).
void finish_up(const Normals& before, Normals& normals, const std::vector<int64_t>& used,
               double min_z, const OrientResult& mst, OrientResult& res);

}  // namespace nhnet::detail
