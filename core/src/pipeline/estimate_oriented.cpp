// Estimate, then orient (pipeline/estimate_oriented.hpp): the MST takes the estimator's
// neighbour table (docs/design/decisions.md#the-mst-on-the-estimators-neighbour-table).
#include "nhnet/pipeline/estimate_oriented.hpp"

#include "pipeline/cell_means.hpp"
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
  // A cloud estimated through cell means is oriented through them (the graph orientations).
  const bool on_means = orient.mode == OrientMode::Mst || orient.mode == OrientMode::Up;
  detail::MeansRun means;
  out.estimate =
      detail::estimate_normals_keeping_means(points, estimate, on_means ? &means : nullptr);
  hand_neighbours(out.estimate, orient);
  if (orient.mode == OrientMode::None) return out;
  orient.run = detail::narrow(run, share, 1);
  if (on_means && out.estimate.cell_means > 0)
    out.orient = detail::orient_through_means(means, out.estimate, orient);
  else
    out.orient = orient_normals(points, out.estimate.normals, orient, reference);
  return out;
}

}  // namespace nhnet
