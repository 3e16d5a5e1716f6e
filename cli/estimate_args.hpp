// estimate's options: their CLI11 wiring and help texts (defaults from the core), and their
// checks (exit 2) into the core's options shared by every input.
#pragma once

#include "args.hpp"
#include "nhnet/orient/auto.hpp"
#include "nhnet/orient/orient.hpp"
#include "nhnet/pipeline/estimate.hpp"

#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace nhcli {

/// estimate's command line as given (strings are parsed strictly by parse_estimate_args).
struct EstimateArgs {
  std::vector<std::string> files;  ///< IN OUT, or the inputs with -o DIR
  std::string out_dir;             ///< -o: batch mode
  std::string ext;                 ///< batch: output extension (default: the input's)
  std::string report;              ///< --report JSON path
  bool fail_fast = false;
  std::string method;  ///< empty = default_method(): nhnet, else mfps with a warning
  std::string k;       ///< empty = auto
  std::string scales = scales_text(nhnet::EstimateOptions{}.mfps.scales);
  std::string threads = std::to_string(nhnet::EstimateOptions{}.run.threads);
  std::string tile_points;  ///< empty = the core's tiles (TileOptions: points and memory)
  std::string orient;       ///< empty = auto (nhnet::kDefaultOrientMode, resolved per input)
  std::string seed = std::to_string(nhnet::EstimateOptions{}.mfps.seed);
  std::string model;                                           ///< empty = the shipped model
  std::string device = nhnet::EstimateOptions{}.model.device;  ///< NH-Net device
  /// NH-Net's arithmetic: float32 | bfloat16
  std::string precision = nhnet::EstimateOptions{}.model.precision;
  /// NH-Net's candidate mix: on | off
  std::string candidate_mix = nhnet::EstimateOptions{}.model.candidate_mix ? "on" : "off";
  /// NH-Net's learned weighted jet fit after the mix: on | off
  std::string learned_fit = nhnet::EstimateOptions{}.model.learned_fit ? "on" : "off";
  std::string refine = nhnet::to_string(nhnet::EstimateOptions{}.model.refine);
  std::string network_stride;  ///< empty: the core's (automatic)
  /// Dense clouds through cell means (CellMeanOptions): auto | off | the noise ratio from which
  std::string cell_means = nhnet::EstimateOptions{}.cell_means.noise_ratio > 0 ? "auto" : "off";
  bool stream = false;      ///< --stream: out of core, XYZ input
  bool confidence = false;  ///< --confidence: write each normal's confidence too
  std::string temp_dir;     ///< --temp-dir (stream)
  OutputFlags output;

  bool batch() const { return !out_dir.empty(); }
};

/// Everything parsed and loaded once for all inputs.
struct Setup {
  nhnet::EstimateOptions opt;
  nhnet::OrientOptions orient;
  std::string model_path, model_sha256, device = "-", precision = "-";
  std::string fallback_why;  ///< why the default method is not nhnet (empty: it is, or explicit)
};

/// Adds estimate's options, help texts and footer to `sub`.
void add_estimate_options(CLI::App* sub, EstimateArgs& a);
/// Checks the options (nhnet::InvalidOptions, exit 2) and turns them into the core's options; the
/// model is not loaded yet.
Setup parse_estimate_args(const EstimateArgs& a);

}  // namespace nhcli
