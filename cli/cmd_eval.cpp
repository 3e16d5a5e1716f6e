// nhnet-cli eval EST GT: unoriented angle error between the normals of two clouds holding the
// same points in the same order (benchmark protocol: mean, RMS, PGP5, PGP10; see metrics.hpp).
// Arguments in eval_args.*, the table / JSON in summary.*.
#include "cloud_io.hpp"
#include "commands.hpp"
#include "errors.hpp"
#include "eval_args.hpp"
#include "progress.hpp"
#include "summary.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/eval/metrics.hpp"
#include "nhnet/io/cloud.hpp"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

namespace nhcli {

namespace {

nhnet::Cloud read_with_normals(const std::string& path, Reporter& rep) {
  std::vector<std::string> warnings;
  nhnet::Cloud cloud = read_input(rep, path, warnings);
  if (!cloud.has_normals())
    throw nhnet::InputError(path + ": no normals (eval needs nx ny nz in both files)");
  return cloud;
}

/// Largest distance between matching points relative to the bounding-box diagonal of `a`, to
/// catch a pair of files whose points are not in the same order.
double max_relative_offset(const nhnet::Points& a, const nhnet::Points& b) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo;
  double max_d = 0;
  for (Eigen::Index i = 0; i < a.rows(); ++i) {
    const Eigen::Vector3d p = a.row(i).transpose(), q = b.row(i).transpose();
    if (!p.allFinite() || !q.allFinite()) continue;
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
    max_d = std::max(max_d, (p - q).norm());
  }
  const double diag = (hi - lo).norm();
  return diag > 0 && std::isfinite(diag) ? max_d / diag : 0.0;
}

int run_eval(const EvalArgs& a) {
  Reporter rep(/*quiet=*/true);
  const nhnet::Cloud est = read_with_normals(a.est, rep);
  const nhnet::Cloud gt = read_with_normals(a.gt, rep);
  if (est.size() != gt.size())
    throw nhnet::InvalidOptions(a.est + " has " + std::to_string(est.size()) + " points but " +
                                a.gt + " has " + std::to_string(gt.size()) +
                                "; eval needs the same points in the same order");
  const double offset = max_relative_offset(est.points, gt.points);
  if (offset > 1e-3) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.3g", offset * 100.0);
    rep.warn("points of " + a.est + " and " + a.gt + " differ by up to " + buf +
             " % of the bounding-box diagonal; are they the same points in the same order?");
  }
  const nhnet::AngleStats s = nhnet::angle_stats(est.normals, gt.normals);
  if (s.count == 0)
    throw nhnet::UnprocessableInput("no point has a valid normal in both " + a.est + " and " +
                                    a.gt);
  print_eval_result(a.est, a.gt, s, a.json);
  return kOk;
}

}  // namespace

Command add_eval_command(CLI::App& parent) {
  auto args = std::make_shared<EvalArgs>();
  CLI::App* sub = parent.add_subcommand(
      "eval", "Angle errors of estimated normals against ground-truth normals");
  add_eval_options(sub, *args);
  return Command{sub, [args] { return run_eval(*args); }};
}

}  // namespace nhcli
