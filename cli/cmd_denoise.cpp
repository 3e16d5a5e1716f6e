// nhnet-cli denoise IN OUT: normal-guided point denoising (paper Eq. 9, core/denoise.hpp). The
// guiding normals are estimated (nhnet / mfps / pca, as `estimate` does; default nhnet when the
// shipped model is there, else mfps with a warning) or taken from the input; the
// output holds the moved points in the input's order, the input's extra properties, and the
// normals used when --keep-normals is given. Same io and exit-code rules as `estimate`.
#include "common.hpp"

#include "nhnet/io/cloud.hpp"
#include "nhnet/denoise/denoise.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/pipeline/estimate.hpp"
#include "nhnet/io/io.hpp"
#include "nhnet/learned/nhnet_model.hpp"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

namespace nhcli {

namespace {

/// Where the guiding normals come from, best first: the first entry is the default when it can
/// run (nhnet: this build links libtorch and the shipped model file is there), else the second.
/// Every name but "input" is a method of nhnet::estimate_normals (method_from_string), so a new
/// estimator is one more entry here.
const std::vector<std::string> kNormalSources = {"nhnet", "mfps", "pca", "input"};

struct DenoiseArgs {
  std::string in, out;
  std::string iterations = "20";
  std::string normals_from;  // empty = default_method()
  std::string radius;  // empty = from the average spacing
  std::string threads = "0";
  std::string seed = "1";
  bool keep_normals = false, ascii = false, overwrite = false, quiet = false, json = false;
};

std::string source_list(const char* sep) {
  std::string s;
  for (const auto& n : kNormalSources) s += (s.empty() ? "" : sep) + n;
  return s;
}

int run_denoise(const DenoiseArgs& a) {
  // 1. Parameters (exit 2).
  nhnet::DenoiseOptions dopt;
  dopt.iterations = parse_int("--iterations", a.iterations, 1);
  if (!a.radius.empty()) dopt.radius = parse_double("--radius", a.radius, 0.0);
  dopt.run.threads = parse_int("--threads", a.threads, 0);
  std::string fallback_why;
  const std::string source = a.normals_from.empty() ? default_method(fallback_why) : a.normals_from;
  if (std::find(kNormalSources.begin(), kNormalSources.end(), source) == kNormalSources.end())
    throw nhnet::InvalidOptions("--normals-from must be one of " + source_list(", ") + ", got '" +
                                one_line(source) + "'");
  const bool from_input = source == "input";
  nhnet::EstimateOptions eopt;
  if (!from_input) eopt.method = nhnet::method_from_string(source);
  eopt.run.threads = dopt.run.threads;
  eopt.mfps.seed = parse_u64("--seed", a.seed);
  check_output_format(a.out);
  Reporter rep(a.quiet);
  if (!fallback_why.empty())
    rep.warn("guiding normals from " + source + " (" + fallback_why + "; --normals-from " +
             kNormalSources.front() + " needs it)");

  // 2. Output path (exit 6), before any work.
  check_output(a.in, a.out, a.overwrite);

  // 3. Read (exit 3); --normals-from input needs normals in the file.
  std::vector<std::string> read_warnings;
  nhnet::Cloud cloud = read_input(rep, a.in, read_warnings);
  if (from_input && !cloud.has_normals())
    throw nhnet::InputError(a.in + ": no normals (use --normals-from " + kNormalSources[1] +
                            " to estimate them)");
  throw_if_interrupted();

  // 4. Normals, then denoise (exit 4 when too few usable points, 130 when interrupted).
  nhnet::Normals normals;
  int64_t failed = 0;
  std::vector<std::string> warnings;
  if (from_input) {
    normals = cloud.normals;
  } else {
    eopt.run.progress = rep.callback(0.0, 0.6);
    nhnet::EstimateResult est = nhnet::estimate_normals(cloud.points, eopt);
    normals = std::move(est.normals);
    failed = est.failed;
    warnings = std::move(est.warnings);
  }
  dopt.run.progress = rep.callback(from_input ? 0.0 : 0.6, 1.0);
  nhnet::DenoiseResult res = nhnet::denoise_points(cloud.points, normals, dopt);
  rep.clear();
  warnings.insert(warnings.end(), res.warnings.begin(), res.warnings.end());
  for (const auto& w : warnings) rep.warn(w);
  throw_if_interrupted();

  // 5. Write (exit 6) through a temporary file + rename.
  cloud.points = std::move(res.points);
  if (a.keep_normals)
    cloud.normals = std::move(normals);
  else
    cloud.normals.resize(0, 3);
  write_output(rep, a.out, cloud, a.ascii);
  const double seconds = rep.elapsed();

  // 6. Summary.
  if (!a.quiet && !a.json) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "radius %.4g, %.1f neighbours on average, %.2f s", res.radius,
                  res.mean_neighbors, seconds);
    std::ostringstream line;
    line << "nhnet-cli: " << cloud.size() << " points, " << res.moved << " moved, "
         << res.skipped << " skipped, " << res.isolated << " isolated, normals from "
         << source << ", " << res.iterations << " iterations (at most " << dopt.iterations
         << "), " << buf << ", output "
         << a.out;
    std::cerr << line.str() << std::endl;
  }
  if (a.json) {
    std::ostringstream js;
    js << "{\"input\": " << json_string(a.in) << ", \"output\": " << json_string(a.out)
       << ", \"points\": " << cloud.size() << ", \"moved\": " << res.moved
       << ", \"skipped\": " << res.skipped << ", \"isolated\": " << res.isolated
       << ", \"normals_from\": " << json_string(source)
       << ", \"normals_failed\": " << failed << ", \"iterations\": " << dopt.iterations
       << ", \"iterations_run\": " << res.iterations
       << ", \"radius\": " << json_number(res.radius, 8)
       << ", \"spacing\": " << json_number(res.spacing, 8)
       << ", \"sigma\": " << json_number(res.sigma)
       << ", \"mean_neighbors\": " << json_number(res.mean_neighbors)
       << ", \"keep_normals\": " << (a.keep_normals ? "true" : "false")
       << ", \"warnings\": " << warnings.size() + read_warnings.size()
       << ", \"seconds\": " << json_number(seconds, 4) << "}";
    std::cout << js.str() << std::endl;
  }
  return kOk;
}

}  // namespace

Command add_denoise_command(CLI::App& parent) {
  auto args = std::make_shared<DenoiseArgs>();
  CLI::App* sub = parent.add_subcommand(
      "denoise", "Move noisy points onto their surface, guided by normals (paper Eq. 9)");
  add_in_out(sub, args->in, args->out);
  sub->add_option("--iterations", args->iterations, "Update steps, >= 1 (default: 20)")
      ->type_name("N");
  sub->add_option("--normals-from", args->normals_from,
                  source_list(" | ") + ": estimate the guiding normals with that method, or use "
                  "the input's (default: " + kNormalSources.front() + " when the shipped model "
                  "is there, else " + kNormalSources[1] + ")")
      ->type_name("SOURCE");
  sub->add_option("--radius", args->radius,
                  "Ball radius of the neighbourhoods, input units (default: 2 x average spacing)")
      ->type_name("R");
  sub->add_flag("--keep-normals", args->keep_normals,
                "Write the normals used (estimated at the noisy positions, unoriented unless "
                "taken from the input); default: no normals in OUT");
  sub->add_option("--threads", args->threads, "Worker threads, 0 = all cores (default: 0)")
      ->type_name("N");
  sub->add_option("--seed", args->seed, "Seed of MFPS's random plane samples (default: 1)")
      ->type_name("S");
  add_output_flags(sub, args->ascii, args->overwrite, args->quiet, args->json);
  sub->footer(
      "Each point moves towards the planes of its neighbours within the ball (normals and\n"
      "neighbourhoods fixed, computed once), which removes noise and keeps sharp edges when the\n"
      "normals do. Points in the input's order; other properties (colour, ...) are kept.\n"
      "Points with a non-finite position or no valid normal are not moved.\n\n"
      "Examples:\n"
      "  nhnet-cli denoise scan.ply scan-clean.ply\n"
      "  nhnet-cli denoise scan.xyzn clean.xyzn --normals-from input --keep-normals\n"
      "  nhnet-cli denoise noisy.xyz clean.xyz --normals-from pca --iterations 10 --radius 0.02\n\n"
      "Exit codes: 0 ok, 2 bad parameter, 3 bad input (or no normals with --normals-from\n"
      "input), 4 too few usable points, 6 cannot write output, 7 out of memory, 130 SIGINT,\n"
      "143 SIGTERM.\n");
  return Command{sub, [args] { return naming_file(args->in, [&] { return run_denoise(*args); }); }};
}

}  // namespace nhcli
