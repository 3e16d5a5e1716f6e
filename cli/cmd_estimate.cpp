// nhnet-cli estimate IN OUT: read a cloud, estimate normals (PCA or MFPS), orient them (keep the
// input's signs / towards a viewpoint / MST / none), write the cloud with its extra properties.
// Every check that can fail cheaply (parameters, output path) runs before any reading/computing.
#include "common.hpp"

#include "nhnet/cloud.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/estimate.hpp"
#include "nhnet/io.hpp"
#include "nhnet/orient.hpp"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <iostream>
#include <memory>
#include <sstream>

namespace nhcli {

namespace {

struct EstimateArgs {
  std::string in, out;
  std::string method = "mfps";
  std::string k;  // empty = auto
  std::string scales = "auto";
  std::string threads = "0";
  std::string orient;  // empty = keep when the input has normals, mst otherwise
  std::string seed = "1";
  std::string model;            // empty = the shipped model
  std::string device = "auto";  // NH-Net device
  bool ascii = false, overwrite = false, quiet = false, json = false;
};

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
  opt.model = a.model;
  opt.device = a.device;
  if (a.device != "auto" && a.device != "cpu" && a.device != "cuda")
    throw nhnet::InvalidOptions("--device must be auto, cpu or cuda, got '" + a.device + "'");
  if (opt.method != nhnet::Method::NhNet && (!a.model.empty() || a.device != "auto"))
    throw nhnet::InvalidOptions("--model and --device only apply to --method nhnet");
  nhnet::OrientOptions orient;
  if (!a.orient.empty()) orient = parse_orient(a.orient);
  orient.run.threads = opt.run.threads;
  check_output_format(a.out);

  Reporter rep(a.quiet);
  if (opt.method == nhnet::Method::Pca && !opt.scales.empty())
    rep.warn("--scales is ignored with --method pca");

  // 2. Output path (exit 6), before any work.
  check_output(a.in, a.out, a.overwrite);

  // 3. Read (exit 3).
  std::vector<std::string> read_warnings;
  nhnet::Cloud cloud = read_input(rep, a.in, read_warnings);
  throw_if_interrupted();

  if (a.orient.empty())
    orient.mode = cloud.has_normals() ? nhnet::OrientMode::Keep : nhnet::OrientMode::Mst;
  if (orient.mode == nhnet::OrientMode::Keep && !cloud.has_normals()) {
    rep.warn("--orient keep: " + a.in + " has no normals; output normals stay unoriented");
    orient.mode = nhnet::OrientMode::None;
  }

  // 4. Estimate (exit 4 when too few finite points, 130 when interrupted), then orient.
  const double est_end = orient.mode == nhnet::OrientMode::Mst ? 0.9 : 1.0;
  opt.run.progress = rep.callback(0.0, est_end);
  nhnet::EstimateResult res;
  try {
    res = nhnet::estimate_normals(cloud.points, opt);
  } catch (const nhnet::UnprocessableInput& e) {
    throw nhnet::UnprocessableInput(a.in + ": " + e.what());  // name the file (exit 4)
  }
  rep.clear();
  for (const auto& w : res.warnings) rep.warn(w);
  if (opt.method == nhnet::Method::NhNet && opt.device == "auto" && !a.quiet)
    std::cerr << "nhnet-cli: NH-Net ran on " << res.device_used << " (--device auto)" << std::endl;
  throw_if_interrupted();

  orient.run.progress = rep.callback(est_end, 1.0);
  const nhnet::OrientResult ores =
      nhnet::orient_normals(cloud.points, res.normals, orient, cloud.normals);
  rep.clear();
  warn_unoriented(rep, orient, ores);
  throw_if_interrupted();

  // 5. Write (exit 6); write_cloud goes through a temporary file + rename.
  cloud.normals = std::move(res.normals);
  write_output(rep, a.out, cloud, a.ascii);
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
         << orient_summary(orient, ores);
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
       << ", " << orient_json(orient, ores)
       << ", \"warnings\": " << res.warnings.size() + read_warnings.size()
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
  add_in_out(sub, args->in, args->out);
  sub->add_option("-m,--method", args->method, "pca | mfps | nhnet (default: mfps)")->type_name("NAME");
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
      "  nhnet-cli estimate scan.ply out.ply --orient viewpoint 0 0 1.5\n\n"
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
