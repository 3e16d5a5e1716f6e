// What the commands report of a successful run: the summary line on stderr (unless --quiet or
// --json), the --json object on stdout, eval's table, and the warning about unoriented normals.
#pragma once

#include "args.hpp"
#include "nhnet/denoise/denoise.hpp"
#include "nhnet/eval/metrics.hpp"
#include "nhnet/orient/orient.hpp"
#include "nhnet/pipeline/estimate.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace nhcli {

class Reporter;

/// What estimate reports of one input.
struct EstimateSummary {
  std::string in, out;
  nhnet::Method method = nhnet::Method::Mfps;
  std::string device;     ///< where NH-Net ran (named with method nhnet)
  std::string precision;  ///< the network's arithmetic there (ModelOptions::precision resolved)
  int64_t points = 0, failed = 0;
  int k = 0;
  std::vector<int> scales;
  double noise_ratio = 0, spacing = 0;
  int64_t candidates = 0;
  int tiles = 1;
  int64_t cell_means = 0;       ///< EstimateResult::cell_means (0: the points themselves)
  int64_t low_confidence = -1;  ///< --confidence: points below nhnet::kLowConfidence, else -1
  bool streamed = false;
  size_t warnings = 0;
  nhnet::OrientOptions orient;
  std::string orient_source;  ///< why this orientation (OrientPlan::source, orient/auto.hpp)
  nhnet::OrientResult orient_result;
  double seconds = 0;
};

/// What denoise reports besides its nhnet::DenoiseResult.
struct DenoiseSummary {
  std::string in, out;
  std::string normals_from;  ///< the source of the guiding normals
  int64_t points = 0;
  int64_t normals_failed = 0;  ///< points the estimator gave no normal
  int max_iterations = 0;      ///< --iterations
  bool keep_normals = false;
  size_t warnings = 0;
  double seconds = 0;
};

/// estimate's summary line and --json object.
void print_estimate_summary(const OutputFlags& flags, const EstimateSummary& s);
/// denoise's summary line and --json object.
void print_denoise_summary(const OutputFlags& flags, const DenoiseSummary& s,
                           const nhnet::DenoiseResult& res);
/// eval's table on stdout, or its --json object.
void print_eval_result(const std::string& est, const std::string& gt, const nhnet::AngleStats& s,
                       bool json);

/// Warns about normals / connected parts that could not be oriented (nothing when all were).
void warn_unoriented(Reporter& rep, const nhnet::OrientOptions& opt, const nhnet::OrientResult& r);

}  // namespace nhcli
