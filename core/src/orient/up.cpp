// Up mode (orient.hpp): airborne clouds, n_z > 0 where the surface is not near vertical; the
// MST (orient.cpp) carries the sign from there to the walls.
#include "orient/sensors.hpp"

#include <cmath>

namespace nhnet::detail {

std::vector<int8_t> up_votes(const Normals& guide, double min_z) {
  std::vector<int8_t> vote(size_t(guide.rows()), 0);
  for (Eigen::Index i = 0; i < guide.rows(); ++i) {
    const double z = guide(i, 2);
    if (z >= min_z)
      vote[size_t(i)] = 1;
    else if (z <= -min_z)
      vote[size_t(i)] = -1;
  }
  return vote;
}

void finish_up(const Normals& before, Normals& normals, const std::vector<int64_t>& used,
               double min_z, const OrientResult& mst, OrientResult& res) {
  for (const int64_t i : used) {
    const double z = normals(i, 2);
    if (z < 0 && -z >= min_z * normals.row(i).norm()) normals.row(i) *= -1.0;
    if (normals.row(i).dot(before.row(i)) < 0) ++res.flipped;
  }
  // The MST's undecided rows (perpendicular to their guide) may include a few the rule above
  // decided: an upper bound.
  res.unoriented += mst.unoriented;
  res.components += mst.components;
  res.inside_outside_votes += mst.inside_outside_votes;
}

}  // namespace nhnet::detail
