// denoise's options: their CLI11 wiring and help texts (defaults from the core), and their
// checks (exit 2) into the core's denoise options and the guiding normals' estimator options.
#pragma once

#include "args.hpp"
#include "nhnet/denoise/denoise.hpp"
#include "nhnet/pipeline/estimate.hpp"

#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace nhcli {

/// Where the guiding normals come from, best first: the first entry is the default when it can
/// run (nhnet: this build links libtorch and the shipped model file is there), else the second.
/// Every name but "input" is a method of nhnet::estimate_normals (method_from_string), so a new
/// estimator is one more entry here.
extern const std::vector<std::string> kNormalSources;

/// denoise's command line as given (strings are parsed strictly by parse_denoise_args).
struct DenoiseArgs {
  std::string in, out;
  std::string iterations = std::to_string(nhnet::DenoiseOptions{}.iterations);
  std::string normals_from;  ///< empty = default_method()
  std::string radius;        ///< empty = from the average spacing
  std::string threads = std::to_string(nhnet::DenoiseOptions{}.run.threads);
  std::string seed = std::to_string(nhnet::EstimateOptions{}.mfps.seed);
  std::string precision = nhnet::EstimateOptions{}.model.precision;  ///< of NH-Net's normals
  bool keep_normals = false;
  OutputFlags output;
};

/// The parsed options.
struct DenoiseSetup {
  nhnet::DenoiseOptions denoise;
  nhnet::EstimateOptions estimate;  ///< the guiding normals' estimator (not used for "input")
  std::string source;               ///< one of kNormalSources
  std::string fallback_why;  ///< why the default source is not nhnet (empty: it is, or explicit)

  bool from_input() const { return source == "input"; }
};

/// Adds denoise's IN OUT, options, help texts and footer to `sub`.
void add_denoise_options(CLI::App* sub, DenoiseArgs& a);
/// Checks the options (nhnet::InvalidOptions, exit 2) and turns them into the core's options.
DenoiseSetup parse_denoise_args(const DenoiseArgs& a);

}  // namespace nhcli
