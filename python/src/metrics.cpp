// Bindings of the accuracy metrics (metrics.hpp): nhnet.metrics() and nhnet.angle_errors().
#include "bindings.hpp"
#include "dict_fields.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/eval/metrics.hpp"

namespace nhnet::python {

namespace {

void check_sizes(const Normals& est, const Normals& gt) {
  if (est.rows() != gt.rows())
    throw InvalidOptions("est and gt differ in size: " + std::to_string(est.rows()) + " vs " +
                         std::to_string(gt.rows()) + " normals");
}

/// AngleStats as the dict nhnet.metrics() returns.
const auto kStatFields =
    std::make_tuple(field("mean", &AngleStats::mean), field("rms", &AngleStats::rms),
                    field("pgp5", &AngleStats::pgp5), field("pgp10", &AngleStats::pgp10),
                    field("over30", &AngleStats::over30), field("count", &AngleStats::count),
                    field("invalid", &AngleStats::invalid));

}  // namespace

void register_metrics(py::module_& m) {
  m.def(
      "angle_errors",
      [](const py::handle& est, const py::handle& gt) {
        const Normals e = to_points(est, "est"), g = to_points(gt, "gt");
        check_sizes(e, g);
        return to_numpy(angle_errors_deg(e, g));
      },
      "Per-point unoriented angle error in degrees, acos(min(1, |est . gt|)), between two "
      "(N, 3) normal arrays (rows need not be unit length); NaN where either normal is "
      "non-finite or zero.",
      py::arg("est"), py::arg("gt"));
  m.def(
      "metrics",
      [](const py::handle& est, const py::handle& gt) {
        const Normals e = to_points(est, "est"), g = to_points(gt, "gt");
        check_sizes(e, g);
        return fields_to_dict(angle_stats(e, g), kStatFields);
      },
      "Accuracy of estimated normals against ground truth (both (N, 3), same points in the same "
      "order), as `nhnet-cli eval` reports it: {'mean', 'rms'} unoriented angle error in "
      "degrees, {'pgp5', 'pgp10'} share of points under 5 / 10 degrees in [0, 1], 'over30' "
      "share over 30 degrees in [0, 1], 'count' points compared, 'invalid' points left out because "
      "a normal is NaN or zero.",
      py::arg("est"), py::arg("gt"));
}

}  // namespace nhnet::python
