// nhnet-cli estimate IN OUT: read a cloud, estimate unoriented normals (PCA or MFPS), optionally
// flip them to agree with the input's normals, write the cloud with its extra properties.
// Every check that can fail cheaply (parameters, output path) runs before any reading/computing.
#include "common.hpp"

#include "nhnet/cloud.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/estimate.hpp"
#include "nhnet/io.hpp"

#include <CLI/CLI.hpp>

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>

namespace fs = std::filesystem;

namespace nhcli {

namespace {

struct EstimateArgs {
  std::string in, out;
  std::string method = "mfps";
  std::string k;  // empty = auto
  std::string scales = "auto";
  std::string threads = "0";
  std::string orient;  // empty = keep when the input has normals, none otherwise
  std::string seed = "1";
  bool ascii = false, overwrite = false, quiet = false, json = false;
};

/// Output path checks (exit 6) done before reading anything.
void check_output(const std::string& in, const std::string& out, bool overwrite) {
  std::error_code ec;
  const fs::path out_path(out), in_path(in);
  const fs::file_status st = fs::status(out_path, ec);
  if (fs::exists(st)) {
    if (fs::is_directory(st)) throw nhnet::OutputError(out + ": is a directory");
    std::error_code ec2;
    if (fs::exists(in_path, ec2) && fs::equivalent(in_path, out_path, ec2) && !ec2)
      throw nhnet::OutputError("refusing to overwrite the input " + in +
                               " (choose another output path)");
    if (!overwrite)
      throw nhnet::OutputError(out + " already exists (use --overwrite to replace it)");
  }
  fs::path dir = out_path.parent_path();
  if (dir.empty()) dir = ".";
  const fs::file_status dst = fs::status(dir, ec);
  if (!fs::exists(dst))
    throw nhnet::OutputError("cannot write " + out + ": directory " + dir.string() +
                             " does not exist");
  if (!fs::is_directory(dst))
    throw nhnet::OutputError("cannot write " + out + ": " + dir.string() + " is not a directory");
  if (::access(dir.c_str(), W_OK | X_OK) != 0)
    throw nhnet::OutputError("cannot write " + out + ": directory " + dir.string() + ": " +
                             std::strerror(errno));
}

std::string join(const std::vector<int>& v, const char* sep) {
  std::string s;
  for (size_t i = 0; i < v.size(); ++i) s += (i ? sep : "") + std::to_string(v[i]);
  return s;
}

int run_estimate(const EstimateArgs& a) {
  // 1. Parameters (exit 2).
  nhnet::EstimateOptions opt;
  opt.method = nhnet::method_from_string(a.method);
  opt.k = a.k.empty() ? 0 : parse_int("--k", a.k, 3);
  opt.scales = parse_scales(a.scales);
  opt.run.threads = parse_int("--threads", a.threads, 0);
  opt.seed = parse_u64("--seed", a.seed);
  if (!a.orient.empty() && a.orient != "keep" && a.orient != "none")
    throw nhnet::InvalidOptions("--orient must be 'keep' or 'none', got '" + a.orient + "'");
  if (nhnet::format_from_extension(a.out) == nhnet::FileFormat::Auto)
    throw nhnet::InvalidOptions("cannot tell the output format from the extension of " + a.out +
                                " (use .ply, .pcd, .xyz, .xyzn or .txt)");

  Reporter rep(a.quiet);
  if (opt.method == nhnet::Method::Pca && !opt.scales.empty())
    rep.warn("--scales is ignored with --method pca");

  // 2. Output path (exit 6), before any work.
  check_output(a.in, a.out, a.overwrite);

  // 3. Read (exit 3).
  rep.stage("reading");
  std::vector<std::string> read_warnings;
  nhnet::Cloud cloud = nhnet::read_cloud(a.in, {}, &read_warnings);
  for (const auto& w : read_warnings) rep.warn(w);
  throw_if_interrupted();

  bool orient_keep = a.orient.empty() ? cloud.has_normals() : a.orient == "keep";
  if (orient_keep && !cloud.has_normals()) {
    rep.warn("--orient keep: " + a.in + " has no normals; output normals stay unoriented");
    orient_keep = false;
  }

  // 4. Estimate (exit 4 when too few finite points, 130 when interrupted).
  opt.run.progress = rep.callback();
  nhnet::EstimateResult res;
  try {
    res = nhnet::estimate_normals(cloud.points, opt);
  } catch (const nhnet::UnprocessableInput& e) {
    throw nhnet::UnprocessableInput(a.in + ": " + e.what());  // name the file (exit 4)
  }
  rep.clear();
  for (const auto& w : res.warnings) rep.warn(w);
  throw_if_interrupted();

  int64_t flipped = 0;
  if (orient_keep) flipped = nhnet::orient_like(res.normals, cloud.normals);

  // 5. Write (exit 6); write_cloud goes through a temporary file + rename.
  cloud.normals = std::move(res.normals);
  nhnet::WriteOptions wopt;
  wopt.ascii = a.ascii;
  rep.stage("writing", 1.0);
  nhnet::write_cloud(a.out, cloud, wopt);
  rep.clear();
  const double seconds = rep.elapsed();

  // 6. Summary.
  const char* method = nhnet::to_string(opt.method);
  if (!a.quiet && !a.json) {
    char noise[32];
    std::snprintf(noise, sizeof noise, "%.3g", res.noise_ratio);
    std::ostringstream line;
    line << "nhnet-cli: " << cloud.size() << " points, " << res.failed << " failed, method "
         << method << ", k " << res.k_used << ", scales "
         << (res.scales_used.empty() ? std::string("-") : join(res.scales_used, "/"))
         << ", noise ratio " << noise << ", " << res.candidates << " candidates, orient "
         << (orient_keep ? "keep (" + std::to_string(flipped) + " flipped)" : std::string("none"));
    char secs[32];
    std::snprintf(secs, sizeof secs, "%.2f", seconds);
    line << ", " << secs << " s, output " << a.out;
    std::cerr << line.str() << std::endl;
  }
  if (a.json) {
    std::ostringstream js;
    js << "{\"input\": " << json_string(a.in) << ", \"output\": " << json_string(a.out)
       << ", \"points\": " << cloud.size() << ", \"failed\": " << res.failed
       << ", \"method\": " << json_string(method) << ", \"k\": " << res.k_used
       << ", \"scales\": [" << join(res.scales_used, ", ") << "]"
       << ", \"noise_ratio\": " << json_number(res.noise_ratio)
       << ", \"spacing\": " << json_number(res.spacing)
       << ", \"candidates\": " << res.candidates
       << ", \"orient\": " << json_string(orient_keep ? "keep" : "none")
       << ", \"flipped\": " << flipped << ", \"warnings\": " << res.warnings.size() + read_warnings.size()
       << ", \"seconds\": " << json_number(seconds, 4) << "}";
    std::cout << js.str() << std::endl;
  }
  return kOk;
}

}  // namespace

Command add_estimate_command(CLI::App& parent) {
  auto args = std::make_shared<EstimateArgs>();
  CLI::App* sub = parent.add_subcommand(
      "estimate", "Estimate unit normals of a point cloud and write the cloud with them");
  sub->add_option("IN", args->in, "Input cloud (.ply, .pcd, .xyz/.xyzn/.txt; content is sniffed)")
      ->required();
  sub->add_option("OUT", args->out,
                  "Output cloud; the format follows the extension (.ply, .pcd, .xyz/.xyzn/.txt)")
      ->required();
  sub->add_option("-m,--method", args->method, "pca | mfps (default: mfps)")->type_name("NAME");
  sub->add_option("-k,--k", args->k,
                  "PCA neighbourhood size, >= 3 (default: chosen from the noise level)")
      ->type_name("K");
  sub->add_option("--scales", args->scales,
                  "MFPS patch sizes: auto or a list like 50,100,150 (default: auto)")
      ->type_name("LIST");
  sub->add_option("--threads", args->threads, "Worker threads, 0 = all cores (default: 0)")
      ->type_name("N");
  sub->add_option("--orient", args->orient,
                  "keep: flip normals to agree with the input's normals (default when the input "
                  "has normals); none: leave signs arbitrary")
      ->type_name("MODE");
  sub->add_option("--seed", args->seed, "Seed of MFPS's random plane samples (default: 1)")
      ->type_name("S");
  sub->add_flag("--ascii", args->ascii, "Write PLY/PCD as ascii instead of binary");
  sub->add_flag("--overwrite", args->overwrite, "Replace OUT if it exists (never the input)");
  sub->add_flag("-q,--quiet", args->quiet,
                "No progress bar and no summary line (warnings and errors still go to stderr)");
  sub->add_flag("--json", args->json, "Print the summary as one JSON object on stdout");
  sub->footer(
      "Normals are UNORIENTED (sign arbitrary) unless --orient keep flips them to agree with\n"
      "the input's own normals. Points that fail (non-finite, degenerate) get NaN normals.\n"
      "Other per-point properties (colour, intensity, ...) are kept in PLY/PCD output.\n\n"
      "Examples:\n"
      "  nhnet-cli estimate scan.ply scan-normals.ply\n"
      "  nhnet-cli estimate scan.xyz out.pcd --method pca --k 30 --threads 4\n"
      "  nhnet-cli estimate noisy.xyz out.xyzn --scales 50,100,150 --json\n\n"
      "Exit codes: 0 ok, 2 bad parameter, 3 bad input, 4 too few finite points,\n"
      "6 cannot write output, 7 out of memory, 130 SIGINT, 143 SIGTERM.\n");
  return Command{sub, [args] {
                   try {
                     return run_estimate(*args);
                   } catch (const std::bad_alloc&) {  // exit 7, naming the file
                     throw OutOfMemory(args->in + ": out of memory (the cloud needs more memory "
                                       "than this process may use; no output written)");
                   }
                 }};
}

}  // namespace nhcli
