// nhnet-cli eval EST GT: unoriented angle error between the normals of two clouds holding the
// same points in the same order (benchmark protocol: mean, RMS, PGP5, PGP10; see metrics.hpp).
#include "common.hpp"

#include "nhnet/io/cloud.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/io/io.hpp"
#include "nhnet/eval/metrics.hpp"

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <sstream>

namespace nhcli {

namespace {

struct EvalArgs {
  std::string est, gt;
  bool json = false;
};

nhnet::Cloud read_with_normals(const std::string& path, Reporter& rep) {
  std::vector<std::string> warnings;
  nhnet::Cloud cloud = nhnet::read_cloud(path, {}, &warnings);
  for (const auto& w : warnings) rep.warn(w);
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

  if (a.json) {
    std::ostringstream js;
    js << "{\"estimated\": " << json_string(a.est) << ", \"ground_truth\": " << json_string(a.gt)
       << ", \"mean_deg\": " << json_number(s.mean, 8) << ", \"rms_deg\": " << json_number(s.rms, 8)
       << ", \"pgp5_pct\": " << json_number(s.pgp5 * 100.0, 8)
       << ", \"pgp10_pct\": " << json_number(s.pgp10 * 100.0, 8) << ", \"count\": " << s.count
       << ", \"invalid\": " << s.invalid << "}";
    std::cout << js.str() << std::endl;
  } else {
    std::printf("mean     %.4f deg\n", s.mean);
    std::printf("rms      %.4f deg\n", s.rms);
    std::printf("pgp5     %.2f %%\n", s.pgp5 * 100.0);
    std::printf("pgp10    %.2f %%\n", s.pgp10 * 100.0);
    std::printf("count    %lld\n", static_cast<long long>(s.count));
    std::printf("invalid  %lld\n", static_cast<long long>(s.invalid));
    std::fflush(stdout);
  }
  return kOk;
}

}  // namespace

Command add_eval_command(CLI::App& parent) {
  auto args = std::make_shared<EvalArgs>();
  CLI::App* sub = parent.add_subcommand(
      "eval", "Angle errors of estimated normals against ground-truth normals");
  sub->add_option("EST", args->est, "Cloud with estimated normals")->required();
  sub->add_option("GT", args->gt, "Cloud with ground-truth normals")->required();
  sub->add_flag("--json", args->json, "Print the result as one JSON object");
  sub->footer(
      "EST and GT hold the same points in the same order. Errors are unoriented angles\n"
      "acos(|n_est . n_gt|) in degrees: mean, RMS, and PGP5 / PGP10, the percentage of points\n"
      "under 5 / 10 degrees. Points whose normal is NaN or zero in either file are counted as\n"
      "invalid and left out.\n\n"
      "Example:\n"
      "  nhnet-cli estimate noisy.xyz est.xyzn && nhnet-cli eval est.xyzn noisy.gt.xyzn\n\n"
      "Exit codes: 0 ok, 2 point counts differ, 3 a file is unreadable or has no normals,\n"
      "4 no valid normal to compare.\n");
  return Command{sub, [args] { return run_eval(*args); }};
}

}  // namespace nhcli
