// nhnet-cli estimate IN OUT | IN... -o DIR: read a cloud, estimate normals (PCA, MFPS or NH-Net),
// orient them (keep the input's signs / towards a viewpoint / MST / none), write the cloud with
// its extra properties. Every check that can fail cheaply (parameters, model, output path) runs
// before any reading/computing. This file: the command, its checks before any input is read,
// and one input; options in estimate_args.*, -o DIR in estimate_batch.cpp, --report in
// estimate_report.*.
#include "cloud_io.hpp"
#include "commands.hpp"
#include "errors.hpp"
#include "estimate.hpp"
#include "progress.hpp"
#include "sha256.hpp"
#include "summary.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/io/cloud.hpp"
#include "nhnet/learned/confidence.hpp"
#include "nhnet/learned/nhnet_model.hpp"
#include "nhnet/orient/auto.hpp"
#include "nhnet/orient/orient.hpp"
#include "nhnet/pipeline/estimate.hpp"
#include "nhnet/pipeline/estimate_oriented.hpp"
#include "nhnet/pipeline/stream.hpp"

#include <CLI/CLI.hpp>

#include <filesystem>
#include <iostream>
#include <memory>

namespace nhcli {

namespace {

// ---- before any input ---------------------------------------------------------------------------

/// Warnings about the options: the default method fell back to mfps, --scales with pca.
void warn_options(const EstimateArgs& a, const Setup& st) {
  if (a.output.quiet) return;
  if (!st.fallback_why.empty())
    std::cerr << "nhnet-cli: warning: method mfps (" << st.fallback_why
              << "; --method nhnet needs it)" << std::endl;
  if (st.opt.method == nhnet::Method::Pca && !st.opt.mfps.scales.empty())
    std::cerr << "nhnet-cli: warning: --scales is ignored with --method pca" << std::endl;
}

/// -o DIR exists; the --report path can be written (exit 6).
void check_output_dirs(const EstimateArgs& a) {
  if (a.batch()) {
    std::error_code ec;
    if (!std::filesystem::is_directory(a.out_dir, ec))
      throw nhnet::OutputError("-o " + a.out_dir + ": not an existing directory");
  }
  if (!a.report.empty()) check_output("", a.report, a.output.overwrite);
}

/// Loads the NH-Net model once, before any input is read (exit 5 / 8 on failure).
void load_model(const EstimateArgs& a, Setup& st) {
  if (st.opt.method != nhnet::Method::NhNet) return;
  st.model_path = a.model.empty() ? nhnet::default_model_path() : a.model;
  auto model = std::make_shared<const nhnet::NhNetModel>(st.model_path, a.device,
                                                         st.opt.run.threads, a.precision);
  st.device = model->device();
  st.precision = model->precision();
  st.opt.model.loaded = std::move(model);
  if (!a.report.empty()) st.model_sha256 = sha256_file(st.model_path);
  // --device auto says up front where it runs when NH-Net was asked for; the summary line
  // always names the device.
  if (a.device == "auto" && !a.method.empty() && !a.output.quiet)
    std::cerr << "nhnet-cli: NH-Net runs on " << st.device << " (--device auto)" << std::endl;
}

// ---- one input ----------------------------------------------------------------------------------

/// The summary of an nhnet::EstimateResult or nhnet::StreamResult (points and warnings aside).
template <class Result>
EstimateSummary summary_of(const Setup& st, const Outcome& o, const Result& res) {
  EstimateSummary s;
  s.in = o.in;
  s.out = o.out;
  s.method = st.opt.method;
  s.device = st.device;
  s.precision = st.precision;
  s.failed = res.failed;
  s.k = res.k_used;
  s.scales = res.scales_used;
  s.noise_ratio = res.noise_ratio;
  s.spacing = res.spacing;
  s.candidates = res.candidates;
  s.tiles = res.tiles;
  s.cell_means = res.cell_means;
  s.seconds = o.seconds;
  return s;
}

/// --stream: the out-of-core estimate (stream.hpp); same summary and JSON as estimate_in_memory.
void estimate_stream(const EstimateArgs& a, const Setup& st, Outcome& o) {
  Reporter rep(a.output.quiet);
  check_output(o.in, o.out, a.output.overwrite);
  nhnet::StreamOptions so;
  so.estimate = st.opt;
  so.orient = st.orient;
  so.temp_dir = a.temp_dir;
  so.ascii = a.output.ascii;
  so.estimate.run.progress = rep.callback(0.0, 1.0);
  const nhnet::StreamResult res = nhnet::estimate_stream(o.in, o.out, so);
  rep.clear();
  for (const auto& w : res.warnings) rep.warn(w);
  throw_if_interrupted();
  nhnet::OrientOptions shown = so.orient;
  shown.mode = res.orient_mode;  // auto resolved; keep falls back to none without input normals
  warn_unoriented(rep, shown, res.orient);
  o.orient = nhnet::to_string(shown.mode);
  o.orient_source = res.orient_source;
  o.points = res.points;
  o.failed = res.failed;
  o.seconds = rep.elapsed();
  EstimateSummary sum = summary_of(st, o, res);
  sum.points = res.points;
  sum.low_confidence = res.low_confidence;
  sum.streamed = true;
  sum.warnings = res.warnings.size();
  sum.orient = shown;
  sum.orient_source = res.orient_source;
  sum.orient_result = res.orient;
  print_estimate_summary(a.output, sum);
}

/// The orientation of one cloud: --orient, by default auto (resolve_orientation: the input's
/// normals, the file's sensor, airborne up, else mst); keep without normals warns and becomes
/// none.
nhnet::OrientPlan orientation_for(const Setup& st, Reporter& rep, const std::string& in,
                                  const nhnet::Cloud& cloud) {
  nhnet::OrientPlan plan = nhnet::resolve_orientation(cloud, st.orient);
  if (plan.options.mode == nhnet::OrientMode::Keep && !cloud.has_normals()) {
    rep.warn("--orient keep: " + in + " has no normals; output normals stay unoriented");
    plan.options.mode = nhnet::OrientMode::None;
  }
  return plan;
}

/// Reads IN, estimates, orients and writes OUT; fills `o`. Throws on failure.
void estimate_in_memory(const EstimateArgs& a, const Setup& st, Outcome& o) {
  Reporter rep(a.output.quiet);

  // Output path (exit 6), before any work.
  check_output(o.in, o.out, a.output.overwrite);

  // Read (exit 3).
  std::vector<std::string> read_warnings;
  nhnet::Cloud cloud = read_input(rep, o.in, read_warnings);
  throw_if_interrupted();
  o.points = int64_t(cloud.size());
  const nhnet::OrientPlan plan = orientation_for(st, rep, o.in, cloud);
  const nhnet::OrientOptions& orient = plan.options;
  o.orient = nhnet::to_string(orient.mode);
  o.orient_source = plan.source;

  // Estimate (exit 4 when too few finite points, 130 when interrupted), then orient.
  nhnet::OrientedResult both = nhnet::estimate_oriented(
      cloud.points, st.opt, orient, nhnet::RunContext{st.opt.run.threads, rep.callback()},
      cloud.normals);
  nhnet::EstimateResult& res = both.estimate;
  const nhnet::OrientResult& ores = both.orient;
  rep.clear();
  for (const auto& w : res.warnings) rep.warn(w);
  warn_unoriented(rep, orient, ores);
  throw_if_interrupted();

  // Write (exit 6); write_cloud goes through a temporary file + rename.
  cloud.normals = std::move(res.normals);
  const int64_t low = st.opt.confidence ? nhnet::count_low_confidence(res.confidence) : -1;
  cloud.confidence = std::move(res.confidence);  // empty without --confidence
  write_output(rep, o.out, cloud, a.output.ascii);
  o.failed = res.failed;
  o.seconds = rep.elapsed();

  EstimateSummary sum = summary_of(st, o, res);
  sum.points = int64_t(cloud.size());
  sum.low_confidence = low;
  sum.warnings = res.warnings.size() + read_warnings.size();
  sum.orient = orient;
  sum.orient_source = plan.source;
  sum.orient_result = ores;
  print_estimate_summary(a.output, sum);
}

/// IN OUT: one input, with its --report.
int run_single(const EstimateArgs& a, const Setup& st) {
  Outcome o;
  o.in = a.files[0];
  o.out = a.files[1];
  try {
    estimate_file(a, st, o);
    record_success(o);
  } catch (...) {
    if (a.report.empty()) throw;
    record_failure(o, /*name_input=*/false);
    write_report(a.report, st, {o}, o.seconds);
    throw;
  }
  if (!a.report.empty()) write_report(a.report, st, {o}, o.seconds);
  return kOk;
}

int run_estimate(const EstimateArgs& a) {
  // 1. Parameters (exit 2), then the output directory and report path (exit 6).
  Setup st = parse_estimate_args(a);
  warn_options(a, st);
  check_output_dirs(a);
  // 2. The model (exit 5, 8), before any input is read.
  load_model(a, st);
  return a.batch() ? run_batch(a, st) : run_single(a, st);
}

}  // namespace

void estimate_file(const EstimateArgs& a, const Setup& st, Outcome& o) {
  naming_file(o.in, [&] {
    if (a.stream)
      estimate_stream(a, st, o);
    else
      estimate_in_memory(a, st, o);
  });
}

Command add_estimate_command(CLI::App& parent) {
  auto args = std::make_shared<EstimateArgs>();
  CLI::App* sub = parent.add_subcommand(
      "estimate", "Estimate unit normals of a point cloud and write the cloud with them");
  add_estimate_options(sub, *args);
  return Command{sub, [args] { return run_estimate(*args); }};
}

}  // namespace nhcli
