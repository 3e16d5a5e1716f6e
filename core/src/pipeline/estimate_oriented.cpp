// Estimate, then orient (pipeline/estimate_oriented.hpp): the MST takes the estimator's
// neighbour table (docs/design/decisions.md#the-mst-on-the-estimators-neighbour-table).
#include "nhnet/pipeline/estimate_oriented.hpp"

#include "util/parallel.hpp"

namespace nhnet {

double estimation_share(const OrientOptions& orient) {
  return shared_neighbours(orient) > 0 ? 0.85 : 1.0;
}

OrientedResult estimate_oriented(const Points& points, EstimateOptions estimate,
                                 OrientOptions orient, const RunContext& run,
                                 const Normals& reference) {
  const double share = estimation_share(orient);
  estimate.run = detail::narrow(run, 0, share);
  estimate.neighbours = shared_neighbours(orient);
  OrientedResult out;
  out.estimate = estimate_normals(points, estimate);
  hand_neighbours(out.estimate, orient);
  if (orient.mode == OrientMode::None) return out;
  orient.run = detail::narrow(run, share, 1);
  out.orient = orient_normals(points, out.estimate.normals, orient, reference);
  return out;
}

}  // namespace nhnet
