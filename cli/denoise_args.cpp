// denoise's options: CLI11 wiring with help texts whose defaults come from the core, and the
// checks that turn them into nhnet::DenoiseOptions / EstimateOptions (exit 2).
#include "denoise_args.hpp"

#include "cloud_io.hpp"
#include "errors.hpp"
#include "nhnet/errors.hpp"

#include <CLI/CLI.hpp>

#include <algorithm>

namespace nhcli {

const std::vector<std::string> kNormalSources = {"nhnet", "mfps", "pca", "input"};

namespace {

std::string source_list(const char* sep) {
  std::string s;
  for (const auto& n : kNormalSources) s += (s.empty() ? "" : sep) + n;
  return s;
}

const char* kFooter =
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
    "143 SIGTERM.\n";

}  // namespace

void add_denoise_options(CLI::App* sub, DenoiseArgs& a) {
  const nhnet::DenoiseOptions core;
  add_in_out(sub, a.in, a.out);
  sub->add_option("--iterations", a.iterations,
                  "Update steps, >= 1 " + default_note(std::to_string(core.iterations)))
      ->type_name("N");
  const std::string sources = source_list(" | ");
  const std::string fallback =
      kNormalSources.front() + " when the shipped model is there, else " + kNormalSources[1];
  sub->add_option("--normals-from", a.normals_from,
                  sources + ": estimate the guiding normals with that method, or use the input's " +
                      default_note(fallback))
      ->type_name("SOURCE");
  sub->add_option("--radius", a.radius,
                  "Ball radius of the neighbourhoods, input units " +
                      default_note(number_text(core.radius_factor) + " x average spacing"))
      ->type_name("R");
  sub->add_flag("--keep-normals", a.keep_normals,
                "Write the normals used (estimated at the noisy positions, unoriented unless "
                "taken from the input); default: no normals in OUT");
  add_threads_option(sub, a.threads);
  add_seed_option(sub, a.seed);
  add_precision_option(sub, a.precision);
  add_output_flags(sub, a.output);
  sub->footer(kFooter);
}

DenoiseSetup parse_denoise_args(const DenoiseArgs& a) {
  DenoiseSetup st;
  st.denoise.iterations = parse_int("--iterations", a.iterations, 1);
  if (!a.radius.empty()) st.denoise.radius = parse_double("--radius", a.radius, 0.0);
  st.denoise.run.threads = parse_int("--threads", a.threads, 0);
  st.source = a.normals_from.empty() ? nhnet::to_string(nhnet::default_method(&st.fallback_why))
                                     : a.normals_from;
  if (std::find(kNormalSources.begin(), kNormalSources.end(), st.source) == kNormalSources.end())
    throw nhnet::InvalidOptions("--normals-from must be one of " + source_list(", ") + ", got '" +
                                one_line(st.source) + "'");
  if (!st.from_input()) st.estimate.method = nhnet::method_from_string(st.source);
  st.estimate.run.threads = st.denoise.run.threads;
  st.estimate.mfps.seed = parse_u64("--seed", a.seed);
  st.estimate.model.precision = parse_precision(a.precision);
  check_output_format(a.out);
  return st;
}

}  // namespace nhcli
