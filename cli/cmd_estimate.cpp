// nhnet-cli estimate IN OUT | IN... -o DIR: read a cloud, estimate normals (PCA, MFPS or NH-Net),
// orient them (keep the input's signs / towards a viewpoint / MST / none), write the cloud with
// its extra properties. Every check that can fail cheaply (parameters, model, output path) runs
// before any reading/computing. With -o DIR, every input (or every cloud in an input directory)
// is processed in turn; one failure does not stop the rest (unless --fail-fast).
#include "common.hpp"

#include "nhnet/io/cloud.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/pipeline/estimate.hpp"
#include "nhnet/io/io.hpp"
#include "nhnet/learned/nhnet_model.hpp"
#include "nhnet/orient/orient.hpp"
#include "nhnet/pipeline/stream.hpp"
#include "nhnet/version.hpp"
#include "sha256.hpp"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <iostream>
#include <memory>
#include <sstream>

namespace nhcli {

namespace {

namespace fs = std::filesystem;

struct EstimateArgs {
  std::vector<std::string> files;  // IN OUT, or the inputs with -o DIR
  std::string out_dir;             // -o: batch mode
  std::string ext;                 // batch: output extension (default: the input's)
  std::string report;              // --report JSON path
  bool fail_fast = false;
  std::string method;  // empty = default_method(): nhnet, else mfps with a warning
  std::string k;  // empty = auto
  std::string scales = "auto";
  std::string threads = "0";
  std::string tile_points = "1000000";
  std::string orient;  // empty = keep when the input has normals, mst otherwise
  std::string seed = "1";
  std::string model;            // empty = the shipped model
  std::string device = "auto";  // NH-Net device
  bool stream = false;          // --stream: out of core, XYZ input
  std::string temp_dir;         // --temp-dir (stream)
  bool ascii = false, overwrite = false, quiet = false, json = false;
};

/// Everything parsed and loaded once for all inputs.
struct Setup {
  nhnet::EstimateOptions opt;
  nhnet::OrientOptions orient;
  std::string model_path, model_sha256, device = "-";
  std::string fallback_why;  // why the default method is not nhnet (empty: it is, or explicit)
};

/// One input's outcome, for the summary and --report.
struct Outcome {
  std::string in, out;
  std::string status = "skipped";  // ok / failed / interrupted / skipped (not run)
  int exit_code = -1;
  std::string error;
  int64_t points = -1, failed = -1;
  double seconds = 0;
};

std::string join(const std::vector<int>& v, const char* sep) {
  std::string s;
  for (size_t i = 0; i < v.size(); ++i) s += (i ? sep : "") + std::to_string(v[i]);
  return s;
}

Setup prepare(const EstimateArgs& a) {
  Setup st;
  nhnet::EstimateOptions& opt = st.opt;
  // The default is NH-Net; --model or --device alone ask for it too (and fail loudly if it
  // cannot run instead of falling back).
  const bool nhnet_asked = !a.model.empty() || a.device != "auto";
  const std::string method = !a.method.empty() ? a.method
                             : nhnet_asked     ? "nhnet"
                                               : default_method(st.fallback_why);
  opt.method = nhnet::method_from_string(method);
  opt.k = a.k.empty() ? 0 : parse_int("--k", a.k, 3);
  opt.mfps.scales = parse_scales(a.scales);
  opt.run.threads = parse_int("--threads", a.threads, 0);
  opt.tiles.points = parse_int("--tile-points", a.tile_points, 0);
  if (opt.tiles.points > 0 && opt.tiles.points < 1000)
    throw nhnet::InvalidOptions("--tile-points must be 0 (no tiles) or at least 1000, got " +
                                a.tile_points);
  opt.mfps.seed = parse_u64("--seed", a.seed);
  opt.model.path = a.model;
  opt.model.device = a.device;
  if (a.device != "auto" && a.device != "cpu" && a.device != "cuda")
    throw nhnet::InvalidOptions("--device must be auto, cpu or cuda, got '" + a.device + "'");
  if (opt.method != nhnet::Method::NhNet && nhnet_asked)
    throw nhnet::InvalidOptions("--model and --device only apply to --method nhnet");
  if (!a.orient.empty()) st.orient = parse_orient(a.orient);
  st.orient.run.threads = opt.run.threads;
  return st;
}

/// Loads the NH-Net model once, before any input is read (exit 5 / 8 on failure).
void load_model(const EstimateArgs& a, Setup& st) {
  if (st.opt.method != nhnet::Method::NhNet) return;
  st.model_path = a.model.empty() ? nhnet::default_model_path() : a.model;
  auto model = std::make_shared<const nhnet::NhNetModel>(st.model_path, a.device,
                                                         st.opt.run.threads);
  st.device = model->device();
  st.opt.model.loaded = std::move(model);
  if (!a.report.empty()) st.model_sha256 = sha256_file(st.model_path);
  // --device auto says up front where it runs when NH-Net was asked for; the summary line
  // always names the device.
  if (a.device == "auto" && !a.method.empty() && !a.quiet)
    std::cerr << "nhnet-cli: NH-Net runs on " << st.device << " (--device auto)" << std::endl;
}

/// What the summary line and the --json object report of one input.
struct Summary {
  int64_t points = 0, failed = 0;
  int k = 0;
  std::vector<int> scales;
  double noise_ratio = 0, spacing = 0;
  int64_t candidates = 0;
  int tiles = 1;
  bool streamed = false;
  size_t warnings = 0;
};

/// The summary line on stderr (unless --quiet / --json) and the --json object on stdout.
void print_summary(const EstimateArgs& a, const Setup& st, const std::string& in,
                   const std::string& out, const Summary& s, const nhnet::OrientOptions& orient,
                   const nhnet::OrientResult& ores, double seconds) {
  const char* method = nhnet::to_string(st.opt.method);
  if (!a.quiet && !a.json) {
    char noise[32], secs[32];
    std::snprintf(noise, sizeof noise, "%.3g", s.noise_ratio);
    std::snprintf(secs, sizeof secs, "%.2f", seconds);
    const std::string tiles = s.streamed   ? ", streamed in " + std::to_string(s.tiles) + " tiles"
                              : s.tiles > 1 ? ", " + std::to_string(s.tiles) + " tiles"
                                            : std::string();
    std::ostringstream line;
    line << "nhnet-cli: " << s.points << " points, " << s.failed << " failed, method " << method
         << (st.opt.method == nhnet::Method::NhNet ? " on " + st.device : std::string()) << ", k "
         << s.k << ", scales " << (s.scales.empty() ? std::string("-") : join(s.scales, "/"))
         << ", noise ratio " << noise << ", " << s.candidates << " candidates" << tiles
         << ", orient " << orient_summary(orient, ores) << ", " << secs << " s, output " << out;
    std::cerr << line.str() << std::endl;
  }
  if (a.json) {
    std::ostringstream js;
    js << "{\"input\": " << json_string(in) << ", \"output\": " << json_string(out)
       << ", \"points\": " << s.points << ", \"failed\": " << s.failed
       << ", \"method\": " << json_string(method) << ", \"k\": " << s.k
       << ", \"scales\": [" << join(s.scales, ", ") << "]"
       << ", \"noise_ratio\": " << json_number(s.noise_ratio)
       << ", \"spacing\": " << json_number(s.spacing) << ", \"candidates\": " << s.candidates
       << ", \"tiles\": " << s.tiles << (s.streamed ? ", \"streamed\": true" : "") << ", "
       << orient_json(orient, ores) << ", \"warnings\": " << s.warnings
       << ", \"seconds\": " << json_number(seconds, 4) << "}";
    std::cout << js.str() << std::endl;
  }
}

/// --stream: the out-of-core estimate (stream.hpp); same summary and JSON as run_one.
void run_one_stream(const EstimateArgs& a, const Setup& st, const std::string& in,
                    const std::string& out, Outcome& o) {
  Reporter rep(a.quiet);
  check_output(in, out, a.overwrite);
  nhnet::StreamOptions so;
  so.estimate = st.opt;
  so.orient = st.orient;
  so.temp_dir = a.temp_dir;
  so.ascii = a.ascii;
  if (a.orient.empty()) {  // keep when the input has normals, else none (mst needs the whole cloud)
    so.orient.mode = nhnet::OrientMode::Keep;
    so.warn_keep_without_normals = false;
  }
  so.estimate.run.progress = rep.callback(0.0, 1.0);
  const nhnet::StreamResult res = nhnet::estimate_stream(in, out, so);
  rep.clear();
  for (const auto& w : res.warnings) rep.warn(w);
  throw_if_interrupted();
  nhnet::OrientOptions shown = so.orient;
  shown.mode = res.orient_mode;  // keep falls back to none when the input has no normals
  warn_unoriented(rep, shown, res.orient);
  o.points = res.points;
  o.failed = res.failed;
  o.seconds = rep.elapsed();
  Summary sum{res.points, res.failed, res.k_used, res.scales_used, res.noise_ratio, res.spacing,
              res.candidates, res.tiles, true, res.warnings.size()};
  print_summary(a, st, in, out, sum, shown, res.orient, o.seconds);
}

/// Reads IN, estimates, orients and writes OUT; fills `o`. Throws on failure.
void run_one(const EstimateArgs& a, const Setup& st, const std::string& in, const std::string& out,
             Outcome& o) {
  nhnet::EstimateOptions opt = st.opt;
  nhnet::OrientOptions orient = st.orient;
  Reporter rep(a.quiet);

  // Output path (exit 6), before any work.
  check_output(in, out, a.overwrite);

  // Read (exit 3).
  std::vector<std::string> read_warnings;
  nhnet::Cloud cloud = read_input(rep, in, read_warnings);
  throw_if_interrupted();
  o.points = int64_t(cloud.size());

  if (a.orient.empty())
    orient.mode = cloud.has_normals() ? nhnet::OrientMode::Keep : nhnet::OrientMode::Mst;
  if (orient.mode == nhnet::OrientMode::Keep && !cloud.has_normals()) {
    rep.warn("--orient keep: " + in + " has no normals; output normals stay unoriented");
    orient.mode = nhnet::OrientMode::None;
  }

  // Estimate (exit 4 when too few finite points, 130 when interrupted), then orient.
  const double est_end = orient.mode == nhnet::OrientMode::Mst ? 0.9 : 1.0;
  opt.run.progress = rep.callback(0.0, est_end);
  nhnet::EstimateResult res = nhnet::estimate_normals(cloud.points, opt);
  rep.clear();
  for (const auto& w : res.warnings) rep.warn(w);
  throw_if_interrupted();

  orient.run.progress = rep.callback(est_end, 1.0);
  const nhnet::OrientResult ores =
      nhnet::orient_normals(cloud.points, res.normals, orient, cloud.normals);
  rep.clear();
  warn_unoriented(rep, orient, ores);
  throw_if_interrupted();

  // Write (exit 6); write_cloud goes through a temporary file + rename.
  cloud.normals = std::move(res.normals);
  write_output(rep, out, cloud, a.ascii);
  const double seconds = rep.elapsed();
  o.failed = res.failed;
  o.seconds = seconds;

  Summary sum{int64_t(cloud.size()), res.failed, res.k_used, res.scales_used, res.noise_ratio,
              res.spacing, res.candidates, res.tiles, false,
              res.warnings.size() + read_warnings.size()};
  print_summary(a, st, in, out, sum, orient, ores, seconds);
}

/// run_one naming the file on exit-4 and exit-7 errors.
void run_one_named(const EstimateArgs& a, const Setup& st, const std::string& in,
                   const std::string& out, Outcome& o) {
  naming_file(in, [&] {
    if (a.stream) run_one_stream(a, st, in, out, o);
    else run_one(a, st, in, out, o);
  });
}

/// --report: one JSON object (temporary file + rename, so a reader never sees half of it).
void write_report(const EstimateArgs& a, const Setup& st, const std::vector<Outcome>& outcomes,
                  double seconds) {
  std::ostringstream js;
  int ok = 0, failed = 0;
  for (const auto& o : outcomes) {
    ok += o.status == "ok";
    failed += o.status == "failed";
  }
  js << "{\n  \"nhnet_version\": " << json_string(nhnet::version())
     << ",\n  \"method\": " << json_string(nhnet::to_string(st.opt.method))
     << ",\n  \"device\": " << json_string(st.device)
     << ",\n  \"model\": " << (st.model_path.empty() ? "null" : json_string(st.model_path))
     << ",\n  \"model_sha256\": "
     << (st.model_sha256.empty() ? "null" : json_string(st.model_sha256))
     << ",\n  \"inputs\": " << outcomes.size() << ",\n  \"ok\": " << ok
     << ",\n  \"failed\": " << failed
     << ",\n  \"not_run\": " << int(outcomes.size()) - ok - failed
     << ",\n  \"seconds\": " << json_number(seconds, 4) << ",\n  \"files\": [";
  for (size_t i = 0; i < outcomes.size(); ++i) {
    const Outcome& o = outcomes[i];
    js << (i ? ",\n" : "\n") << "    {\"input\": " << json_string(o.in)
       << ", \"output\": " << json_string(o.out) << ", \"status\": " << json_string(o.status)
       << ", \"exit_code\": " << (o.exit_code < 0 ? "null" : std::to_string(o.exit_code))
       << ", \"error\": " << (o.error.empty() ? "null" : json_string(o.error))
       << ", \"points\": " << (o.points < 0 ? "null" : std::to_string(o.points))
       << ", \"invalid\": " << (o.failed < 0 ? "null" : std::to_string(o.failed))
       << ", \"seconds\": " << json_number(o.seconds, 4) << "}";
  }
  js << "\n  ]\n}\n";
  const std::string tmp = a.report + ".nhnet-tmp";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    f << js.str();
    f.close();
    if (!f) {
      std::remove(tmp.c_str());
      throw nhnet::OutputError("cannot write the report " + a.report);
    }
  }
  if (std::rename(tmp.c_str(), a.report.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw nhnet::OutputError("cannot write the report " + a.report);
  }
}

bool cloud_extension(const fs::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return e == ".ply" || e == ".pcd" || e == ".xyz" || e == ".xyzn" || e == ".txt";
}

/// The batch's inputs: files as given, directories replaced by their clouds (by extension,
/// sorted, not recursive); each with its output path in DIR.
std::vector<Outcome> batch_jobs(const EstimateArgs& a) {
  std::vector<std::string> inputs;
  for (const auto& f : a.files) {
    std::error_code ec;
    if (fs::is_directory(f, ec)) {
      std::vector<std::string> found;
      for (fs::directory_iterator it(f, ec), end; !ec && it != end; it.increment(ec))
        if (it->is_regular_file(ec) && cloud_extension(it->path())) found.push_back(it->path().string());
      if (ec) throw nhnet::InputError(f + ": cannot list the directory: " + ec.message());
      std::sort(found.begin(), found.end());
      inputs.insert(inputs.end(), found.begin(), found.end());
    } else {
      inputs.push_back(f);
    }
  }
  std::vector<Outcome> jobs;
  for (const auto& in : inputs) {
    Outcome o;
    o.in = in;
    const fs::path p(in);
    o.out = (fs::path(a.out_dir) / (p.stem().string() + (a.ext.empty() ? p.extension().string()
                                                                        : "." + a.ext)))
                .string();
    jobs.push_back(o);
  }
  return jobs;
}

int run_batch(const EstimateArgs& a, const Setup& st) {
  Reporter rep(a.quiet);
  std::vector<Outcome> jobs = batch_jobs(a);
  if (jobs.empty())
    throw nhnet::InputError("no input clouds (.ply, .pcd, .xyz, .xyzn, .txt) in " + a.files[0]);
  std::map<std::string, std::string> claimed;  // output -> the input writing it
  bool stop = false;
  for (Outcome& o : jobs) {
    if (stop || interrupted()) break;
    try {
      if (a.ext.empty()) check_output_format(o.out);
      const auto [it, fresh] = claimed.emplace(o.out, o.in);
      if (!fresh)
        throw nhnet::OutputError("cannot write " + o.out + " for " + o.in + ": it is the output of " +
                                 it->second);
      run_one_named(a, st, o.in, o.out, o);
      o.status = "ok";
      o.exit_code = kOk;
    } catch (...) {
      std::string message;
      o.exit_code = classify_current_exception(message);
      if (message.find(o.in) == std::string::npos) message = o.in + ": " + message;
      o.error = one_line(message);
      const bool cancelled = o.exit_code == kInterrupted || o.exit_code == kTerminated;
      o.status = cancelled ? "interrupted" : "failed";
      rep.clear();
      if (!cancelled) std::cerr << "nhnet-cli: error: " << o.error << std::endl;
      stop = cancelled || a.fail_fast;
    }
  }
  int ok = 0, failed = 0;
  std::string failures;
  for (const auto& o : jobs) {
    ok += o.status == "ok";
    if (o.status == "failed") {
      ++failed;
      failures += (failures.empty() ? "" : ", ") + o.in + " (exit " + std::to_string(o.exit_code) + ")";
    }
  }
  const int not_run = int(jobs.size()) - ok - failed;
  if (!a.report.empty()) write_report(a, st, jobs, rep.elapsed());
  std::cerr << "nhnet-cli: batch: " << jobs.size() << " inputs, " << ok << " ok, " << failed
            << " failed" << (not_run ? ", " + std::to_string(not_run) + " not run" : std::string())
            << (failures.empty() ? std::string() : "; failed: " + failures) << std::endl;
  if (const int sig = interrupted()) {
    std::cerr << "nhnet-cli: error: interrupted (" << (sig == SIGTERM ? "SIGTERM" : "SIGINT")
              << "); the " << ok << " outputs written before are complete, the rest were not written"
              << std::endl;
    return sig == SIGTERM ? kTerminated : kInterrupted;
  }
  return failed > 0 ? kBatch : kOk;
}

int run_estimate(const EstimateArgs& a) {
  // 1. Parameters (exit 2).
  const bool batch = !a.out_dir.empty();
  if (!batch && a.files.size() != 2)
    throw nhnet::InvalidOptions("estimate takes IN OUT, or several inputs (files or directories) "
                                "with -o DIR; got " + std::to_string(a.files.size()) + " paths");
  if (!batch && (!a.ext.empty() || a.fail_fast))
    throw nhnet::InvalidOptions("--ext and --fail-fast only apply with -o DIR");
  Setup st = prepare(a);
  if (a.stream) {
    if (st.orient.mode == nhnet::OrientMode::Mst && !a.orient.empty())
      throw nhnet::InvalidOptions("--orient mst needs the whole cloud in memory; with --stream "
                                  "use none, keep or viewpoint X Y Z");
    if (st.opt.tiles.points <= 0)
      throw nhnet::InvalidOptions("--stream needs --tile-points > 0");
    const std::string out = batch ? "x." + (a.ext.empty() ? std::string("xyzn") : a.ext) : a.files[1];
    const nhnet::FileFormat f = nhnet::format_from_extension(out);
    if (f != nhnet::FileFormat::Ply && f != nhnet::FileFormat::Xyz)
      throw nhnet::InvalidOptions("--stream writes .ply or .xyz/.xyzn/.txt, not " + out);
  } else if (!a.temp_dir.empty()) {
    throw nhnet::InvalidOptions("--temp-dir only applies with --stream");
  }
  if (!batch) check_output_format(a.files[1]);
  if (!a.ext.empty()) check_output_format("x." + a.ext);
  if (!st.fallback_why.empty() && !a.quiet)
    std::cerr << "nhnet-cli: warning: method mfps (" << st.fallback_why
              << "; --method nhnet needs it)" << std::endl;
  if (st.opt.method == nhnet::Method::Pca && !st.opt.mfps.scales.empty() && !a.quiet)
    std::cerr << "nhnet-cli: warning: --scales is ignored with --method pca" << std::endl;
  if (batch) {
    std::error_code ec;
    if (!fs::is_directory(a.out_dir, ec))
      throw nhnet::OutputError("-o " + a.out_dir + ": not an existing directory");
  }
  if (!a.report.empty()) check_output("", a.report, a.overwrite);

  // 2. The model (exit 5, 8), before any input is read.
  load_model(a, st);

  if (batch) return run_batch(a, st);
  Outcome o;
  o.in = a.files[0];
  o.out = a.files[1];
  try {
    run_one_named(a, st, o.in, o.out, o);
    o.status = "ok";
    o.exit_code = kOk;
  } catch (...) {
    if (a.report.empty()) throw;
    std::string message;
    o.exit_code = classify_current_exception(message);
    o.status = o.exit_code == kInterrupted || o.exit_code == kTerminated ? "interrupted" : "failed";
    o.error = one_line(message);
    write_report(a, st, {o}, o.seconds);
    throw;
  }
  if (!a.report.empty()) write_report(a, st, {o}, o.seconds);
  return kOk;
}

}  // namespace

Command add_estimate_command(CLI::App& parent) {
  auto args = std::make_shared<EstimateArgs>();
  CLI::App* sub = parent.add_subcommand(
      "estimate", "Estimate unit normals of a point cloud and write the cloud with them");
  sub->add_option("PATHS", args->files,
                  "IN OUT: input cloud and output cloud (format from the extension: .ply, .pcd, "
                  ".xyz/.xyzn/.txt; input content is sniffed); with -o DIR: any number of input "
                  "clouds or directories of clouds")
      ->required()
      ->type_name("PATH");
  sub->add_option("-o,--output-dir", args->out_dir,
                  "Batch: write each input's result to DIR/<input name> (must exist); one "
                  "failing input does not stop the others (exit 10 if any failed)")
      ->type_name("DIR");
  sub->add_option("--ext", args->ext, "Batch: output extension, e.g. ply (default: the input's)")
      ->type_name("EXT");
  sub->add_flag("--fail-fast", args->fail_fast, "Batch: stop at the first failing input");
  sub->add_option("--report", args->report,
                  "Write a JSON report: per input status, exit code, error, point and invalid "
                  "counts, seconds; method, device, model path and SHA-256, version")
      ->type_name("FILE");
  sub->add_option("-m,--method", args->method, "pca | mfps | nhnet (default: nhnet with the shipped model; mfps, with a warning, when "
                  "the model file or libtorch is missing)")->type_name("NAME");
  sub->add_option("--model", args->model,
                  "NH-Net model (TorchScript from nhnet-export; default: the shipped models/nhnet.pt)")
      ->type_name("PATH");
  sub->add_option("--device", args->device, "NH-Net device: auto | cpu | cuda (default: auto)")
      ->type_name("DEV");
  sub->add_option("-k,--k", args->k,
                  "PCA neighbourhood size, >= 3 (default: chosen from the noise level)")
      ->type_name("K");
  sub->add_option("--scales", args->scales,
                  "MFPS patch sizes: auto or a list like 50,100,150 (default: auto)")
      ->type_name("LIST");
  sub->add_option("--threads", args->threads, "Worker threads, 0 = all cores (default: 0)")
      ->type_name("N");
  sub->add_option("--tile-points", args->tile_points,
                  "Clouds with more points are processed in spatial tiles of at most N points "
                  "with overlapping halos: same normals, memory bounded by one tile; 0 = never "
                  "(default: 1000000)")
      ->type_name("N");
  sub->add_flag("--stream", args->stream,
                 "Out of core, for clouds larger than memory: read the XYZ text input in passes "
                 "and process it tile by tile (--tile-points) through temporary files; same "
                 "normals as in memory; output .ply or .xyz/.xyzn (x y z nx ny nz); orientation "
                 "keep (default when the input has normals, else none) or viewpoint");
  sub->add_option("--temp-dir", args->temp_dir,
                  "--stream: folder for the temporary tile files, ~48 bytes per point (default: "
                  "the output's folder)")
      ->type_name("DIR");
  sub->add_option("--orient", args->orient,
                  "keep: agree with the input's normals (default when the input has normals); "
                  "mst[:K]: consistent over each connected part by a minimum spanning tree over "
                  "K neighbours (default K 18; default mode when the input has no normals); "
                  "viewpoint X Y Z: towards a sensor at X Y Z; none: signs arbitrary")
      ->type_name("MODE");
  sub->add_option("--seed", args->seed, "Seed of MFPS's random plane samples (default: 1)")
      ->type_name("S");
  add_output_flags(sub, args->ascii, args->overwrite, args->quiet, args->json);
  sub->footer(
      "Orientation: by default normals agree with the input's normals when it has some, else\n"
      "they are made consistent by MST over each connected part (outward on closed surfaces;\n"
      "the highest point of each part faces +z). Points that fail get NaN normals.\n"
      "Other per-point properties (colour, intensity, ...) are kept in PLY/PCD output.\n\n"
      "Examples:\n"
      "  nhnet-cli estimate scan.ply scan-normals.ply\n"
      "  nhnet-cli estimate scan.xyz out.pcd --method pca --k 30 --threads 4\n"
      "  nhnet-cli estimate noisy.xyz out.xyzn --scales 50,100,150 --json\n"
      "  nhnet-cli estimate scan.ply out.ply --orient viewpoint 0 0 1.5\n"
      "  nhnet-cli estimate scans/ extra.ply -o out/ --ext ply --report report.json\n"
      "  nhnet-cli estimate survey.xyz survey.ply --stream --temp-dir /scratch\n\n"
      "Exit codes: 0 ok, 2 bad parameter, 3 bad input, 4 too few finite points, 5 bad model,\n"
      "6 cannot write output, 7 out of memory, 8 device unavailable, 10 some batch inputs\n"
      "failed, 130 SIGINT, 143 SIGTERM.\n");
  return Command{sub, [args] { return run_estimate(*args); }};
}

}  // namespace nhcli
