// nhnet-cli denoise IN OUT: normal-guided point denoising (paper Eq. 9,
// core/include/nhnet/denoise/denoise.hpp). The
// guiding normals are estimated (nhnet / mfps / pca, as `estimate` does; default nhnet when the
// shipped model is there, else mfps with a warning) or taken from the input; the
// output holds the moved points in the input's order, the input's extra properties, and the
// normals used when --keep-normals is given. Same io and exit-code rules as `estimate`.
// Options in denoise_args.*, the summary in summary.*.
#include "cloud_io.hpp"
#include "commands.hpp"
#include "denoise_args.hpp"
#include "errors.hpp"
#include "progress.hpp"
#include "summary.hpp"

#include "nhnet/denoise/denoise.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/io/cloud.hpp"
#include "nhnet/pipeline/estimate.hpp"

#include <CLI/CLI.hpp>

#include <memory>

namespace nhcli {

namespace {

/// Reads IN (exit 3); --normals-from input needs normals in the file.
nhnet::Cloud read_denoise_input(const DenoiseArgs& a, const DenoiseSetup& st, Reporter& rep,
                                std::vector<std::string>& read_warnings) {
  nhnet::Cloud cloud = read_input(rep, a.in, read_warnings);
  if (st.from_input() && !cloud.has_normals())
    throw nhnet::InputError(a.in + ": no normals (use --normals-from " + kNormalSources[1] +
                            " to estimate them)");
  throw_if_interrupted();
  return cloud;
}

/// The guiding normals: the input's, or estimated (exit 4 when too few finite points); the
/// estimator's failed points and warnings go into `sum` and `warnings`.
nhnet::Normals guiding_normals(const DenoiseSetup& st, Reporter& rep, const nhnet::Cloud& cloud,
                               DenoiseSummary& sum, std::vector<std::string>& warnings) {
  if (st.from_input()) return cloud.normals;
  nhnet::EstimateOptions eopt = st.estimate;
  eopt.run.progress = rep.callback(0.0, 0.6);
  nhnet::EstimateResult est = nhnet::estimate_normals(cloud.points, eopt);
  sum.normals_failed = est.failed;
  warnings = std::move(est.warnings);
  return std::move(est.normals);
}

int run_denoise(const DenoiseArgs& a) {
  // 1. Parameters (exit 2).
  DenoiseSetup st = parse_denoise_args(a);
  Reporter rep(a.output.quiet);
  if (!st.fallback_why.empty())
    rep.warn("guiding normals from " + st.source + " (" + st.fallback_why + "; --normals-from " +
             kNormalSources.front() + " needs it)");

  // 2. Output path (exit 6), before any work.
  check_output(a.in, a.out, a.output.overwrite);

  // 3. Read (exit 3).
  std::vector<std::string> read_warnings;
  nhnet::Cloud cloud = read_denoise_input(a, st, rep, read_warnings);

  // 4. Normals, then denoise (exit 4 when too few usable points, 130 when interrupted).
  DenoiseSummary sum;
  std::vector<std::string> warnings;
  nhnet::Normals normals = guiding_normals(st, rep, cloud, sum, warnings);
  st.denoise.run.progress = rep.callback(st.from_input() ? 0.0 : 0.6, 1.0);
  nhnet::DenoiseResult res = nhnet::denoise_points(cloud.points, normals, st.denoise);
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
  write_output(rep, a.out, cloud, a.output.ascii);

  // 6. Summary.
  sum.in = a.in;
  sum.out = a.out;
  sum.normals_from = st.source;
  sum.points = int64_t(cloud.size());
  sum.max_iterations = st.denoise.iterations;
  sum.keep_normals = a.keep_normals;
  sum.warnings = warnings.size() + read_warnings.size();
  sum.seconds = rep.elapsed();
  print_denoise_summary(a.output, sum, res);
  return kOk;
}

}  // namespace

Command add_denoise_command(CLI::App& parent) {
  auto args = std::make_shared<DenoiseArgs>();
  CLI::App* sub = parent.add_subcommand(
      "denoise", "Move noisy points onto their surface, guided by normals (paper Eq. 9)");
  add_denoise_options(sub, *args);
  return Command{sub, [args] { return naming_file(args->in, [&] { return run_denoise(*args); }); }};
}

}  // namespace nhcli
