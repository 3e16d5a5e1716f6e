// estimate's options: CLI11 wiring with help texts whose defaults come from the core, and the
// checks that turn them into nhnet::EstimateOptions / OrientOptions (exit 2).
#include "estimate_args.hpp"

#include "args.hpp"
#include "cloud_io.hpp"
#include "errors.hpp"
#include "json.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/io/io.hpp"

#include <CLI/CLI.hpp>

#include <string>

namespace nhcli {

namespace {

// ---- options ------------------------------------------------------------------------------------

/// PATHS, -o, --ext, --fail-fast, --report.
void add_path_options(CLI::App* sub, EstimateArgs& a) {
  sub->add_option("PATHS", a.files,
                  "IN OUT: input cloud and output cloud (format from the extension: .ply, .pcd, "
                  ".xyz/.xyzn/.txt; input content is sniffed); with -o DIR: any number of input "
                  "clouds or directories of clouds")
      ->required()
      ->type_name("PATH");
  sub->add_option("-o,--output-dir", a.out_dir,
                  "Batch: write each input's result to DIR/<input name> (must exist); one "
                  "failing input does not stop the others (exit 10 if any failed)")
      ->type_name("DIR");
  sub->add_option("--ext", a.ext, "Batch: output extension, e.g. ply (default: the input's)")
      ->type_name("EXT");
  sub->add_flag("--fail-fast", a.fail_fast, "Batch: stop at the first failing input");
  sub->add_option("--report", a.report,
                  "Write a JSON report: per input status, exit code, error, point and invalid "
                  "counts, seconds; method, device, model path and SHA-256, version")
      ->type_name("FILE");
}

/// -m, --model, --device, --precision, -k, --scales, --threads, --tile-points.
void add_method_options(CLI::App* sub, EstimateArgs& a) {
  const nhnet::EstimateOptions core;
  sub->add_option("-m,--method", a.method,
                  "pca | mfps | nhnet (default: nhnet with the shipped model; mfps, with a "
                  "warning, when the model file or libtorch is missing)")
      ->type_name("NAME");
  sub->add_option("--model", a.model,
                  "NH-Net model (TorchScript from nhnet-export; default: the shipped "
                  "models/nhnet.pt)")
      ->type_name("PATH");
  sub->add_option("--device", a.device,
                  "NH-Net device: auto | cpu | cuda " + default_note(core.model.device))
      ->type_name("DEV");
  add_precision_option(sub, a.precision);
  sub->add_option("--candidate-mix", a.candidate_mix,
                  "NH-Net: mix the network's normals with the PCA and MFPS candidates (on), or "
                  "the network's normals as they are, the paper's (off) " +
                      default_note(a.candidate_mix))
      ->type_name("on|off");
  sub->add_option("--learned-fit", a.learned_fit,
                  "NH-Net with the candidate mix: refit each mixed normal by the learned "
                  "weighted jet fit (on), or keep the mix's normals (off) " +
                      default_note(a.learned_fit))
      ->type_name("on|off");
  sub->add_option("--refine", a.refine,
                  "NH-Net with the candidate mix: run the network on every point (all), only "
                  "where MFPS moved the PCA normal near features (moved: faster), or all on a "
                  "noisy cloud and moved on a clean one (auto) " +
                      default_note(a.refine))
      ->type_name("auto|all|moved");
  sub->add_option("--network-stride", a.network_stride,
                  "NH-Net where it runs on every point: describe every N-th point (along a "
                  "Morton curve), the feature points and those whose PCA normal departs from "
                  "their strided neighbour's, and give the others the mean of their described "
                  "neighbours' network normals; 1 = every point (slower on dense noisy clouds); "
                  "0 = automatic, from the neighbourhood size " +
                      default_note(std::to_string(nhnet::EstimateOptions{}.model.network_stride)))
      ->type_name("N");
  sub->add_option("-k,--k", a.k,
                  "PCA neighbourhood size, >= 3 (default: chosen from the noise level)")
      ->type_name("K");
  sub->add_option("--scales", a.scales,
                  "MFPS patch sizes: auto or a list like 50,100,150 " +
                      default_note(scales_text(core.mfps.scales)))
      ->type_name("LIST");
  sub->add_option("--cell-means", a.cell_means,
                  "Dense clouds whose noise exceeds their spacing (noise ratio >= " +
                      json_number(nhnet::EstimateOptions{}.cell_means.noise_ratio) +
                      "): estimate on local means of the points and give each point its nearest "
                      "means' normal, several times faster there (auto), from another noise ratio "
                      "(a number > 0), or always on the points themselves (off) " +
                      default_note(a.cell_means))
      ->type_name("auto|off|RATIO");
  add_threads_option(sub, a.threads);
  sub->add_option("--tile-points", a.tile_points,
                  "Clouds with more points are processed in spatial tiles of at most N points "
                  "with overlapping halos: same normals, memory bounded by one tile; 0 = never " +
                      default_note(std::to_string(core.tiles.points) +
                                   ", and only when the estimate in one piece would take more "
                                   "than " +
                                   std::to_string(core.tiles.memory >> 30) + " GiB"))
      ->type_name("N");
}

/// --stream, --temp-dir, --orient.
void add_stream_orient_options(CLI::App* sub, EstimateArgs& a) {
  sub->add_flag("--stream", a.stream,
                "Out of core, for clouds larger than memory: read the XYZ text input in passes "
                "and process it tile by tile (--tile-points) through temporary files; same "
                "normals as in memory (as accurate, not equal, through --cell-means); output .ply "
                "or .xyz/.xyzn (x y z nx ny nz); orientation "
                "auto (keep when the input has normals, else none), keep or viewpoint");
  sub->add_flag("--confidence", a.confidence,
                "Also write each normal's confidence in [0, 1] (the chance that it is within 30 "
                "degrees of the true normal, judged from its neighbourhood): PLY / PCD property "
                "'confidence', LAS / LAZ float extra bytes 'Confidence', E57 field "
                "'nhnet:confidence', XYZ a 7th column; NaN where a point failed " +
                    default_note(nhnet::EstimateOptions{}.confidence ? "on" : "off"));
  sub->add_option("--temp-dir", a.temp_dir,
                  "--stream: folder for the temporary tile files, ~48 bytes per point (default: "
                  "the output's folder)")
      ->type_name("DIR");
  sub->add_option("--orient", a.orient,
                  "auto: from the file (keep its normals' signs; else towards the sensor it "
                  "names: PCD VIEWPOINT, PLY camera, organized grid at the origin; else up for "
                  "airborne scans; else mst); keep: agree with the input's normals; "
                  "viewpoint X Y Z: towards a sensor at X Y Z; up: n_z > 0 (airborne); "
                  "mst[:K]: consistent over each connected part by a minimum spanning tree over "
                  "K neighbours (default K " +
                      std::to_string(nhnet::OrientOptions{}.k) + "); none: signs arbitrary " +
                      default_note(nhnet::to_string(nhnet::kDefaultOrientMode)))
      ->type_name("MODE");
}

const char* kFooter =
    "Orientation (--orient auto): normals agree with the input's normals when it has some;\n"
    "else they face the sensor the file names (PCD VIEWPOINT, PLY camera element; an\n"
    "organized cloud's sensor is at the origin); else up for airborne scans; else they are\n"
    "made consistent by MST over each connected part (outward on closed surfaces). The\n"
    "summary says which. Points that fail get NaN normals.\n"
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
    "failed, 130 SIGINT, 143 SIGTERM.\n";

// ---- checks -------------------------------------------------------------------------------------

/// IN OUT, or -o DIR with the options that only apply to it.
void check_paths(const EstimateArgs& a) {
  if (!a.batch() && a.files.size() != 2)
    throw nhnet::InvalidOptions(
        "estimate takes IN OUT, or several inputs (files or directories) "
        "with -o DIR; got " +
        std::to_string(a.files.size()) + " paths");
  if (!a.batch() && (!a.ext.empty() || a.fail_fast))
    throw nhnet::InvalidOptions("--ext and --fail-fast only apply with -o DIR");
}

/// --cell-means: auto (the core's ratio), off (0) or the noise ratio from which (a number > 0).
double parse_cell_means(const std::string& text) {
  try {
    return nhnet::cell_means_from_string(text);
  } catch (const nhnet::InvalidOptions& e) {
    throw nhnet::InvalidOptions(std::string("--cell-means ") + e.what());
  }
}

/// The estimator's and orientation's options.
Setup prepare(const EstimateArgs& a) {
  Setup st;
  nhnet::EstimateOptions& opt = st.opt;
  // The default is NH-Net; --model or --device alone ask for it too (and fail loudly if it
  // cannot run instead of falling back).
  const bool nhnet_asked = !a.model.empty() || a.device != "auto" ||
                           a.precision != EstimateArgs{}.precision ||
                           a.candidate_mix != EstimateArgs{}.candidate_mix ||
                           a.learned_fit != EstimateArgs{}.learned_fit ||
                           a.refine != EstimateArgs{}.refine || !a.network_stride.empty();
  const std::string method = !a.method.empty() ? a.method
                             : nhnet_asked
                                 ? "nhnet"
                                 : nhnet::to_string(nhnet::default_method(&st.fallback_why));
  opt.method = nhnet::method_from_string(method);
  if (!a.k.empty()) opt.k = parse_int("--k", a.k, 3);
  opt.mfps.scales = parse_scales(a.scales);
  opt.run.threads = parse_int("--threads", a.threads, 0);
  if (!a.tile_points.empty()) {  // tiles of that size whatever the memory they save
    opt.tiles.points = parse_int("--tile-points", a.tile_points, 0);
    opt.tiles.memory = 0;
  }
  if (opt.tiles.points > 0 && opt.tiles.points < 1000)
    throw nhnet::InvalidOptions("--tile-points must be 0 (no tiles) or at least 1000, got " +
                                a.tile_points);
  opt.mfps.seed = parse_u64("--seed", a.seed);
  opt.model.path = a.model;
  opt.model.device = a.device;
  if (a.device != "auto" && a.device != "cpu" && a.device != "cuda")
    throw nhnet::InvalidOptions("--device must be auto, cpu or cuda, got '" + a.device + "'");
  opt.model.precision = parse_precision(a.precision);
  if (a.candidate_mix != "on" && a.candidate_mix != "off")
    throw nhnet::InvalidOptions("--candidate-mix must be on or off, got '" + a.candidate_mix + "'");
  opt.model.candidate_mix = a.candidate_mix == "on";
  if (a.learned_fit != "on" && a.learned_fit != "off")
    throw nhnet::InvalidOptions("--learned-fit must be on or off, got '" + a.learned_fit + "'");
  opt.model.learned_fit = a.learned_fit == "on";
  opt.model.refine = nhnet::refine_from_string(a.refine);
  if (!a.network_stride.empty())
    opt.model.network_stride = parse_int("--network-stride", a.network_stride, 0);
  opt.cell_means.noise_ratio = parse_cell_means(a.cell_means);
  opt.confidence = a.confidence;
  if (opt.method != nhnet::Method::NhNet && nhnet_asked)
    throw nhnet::InvalidOptions(
        "--model, --device, --precision, --candidate-mix, --learned-fit, --refine and "
        "--network-stride only apply to --method nhnet");
  st.orient.mode = nhnet::kDefaultOrientMode;
  if (!a.orient.empty()) st.orient = parse_orient(a.orient);
  st.orient.run.threads = opt.run.threads;
  return st;
}

/// --stream's limits (no mst, tiles, .ply / .xyz output); --temp-dir only with it.
void check_stream(const EstimateArgs& a, const Setup& st) {
  if (!a.stream) {
    if (!a.temp_dir.empty()) throw nhnet::InvalidOptions("--temp-dir only applies with --stream");
    return;
  }
  if (st.orient.mode == nhnet::OrientMode::Mst || st.orient.mode == nhnet::OrientMode::Up)
    throw nhnet::InvalidOptions("--orient " + std::string(nhnet::to_string(st.orient.mode)) +
                                " needs the whole cloud in memory; with --stream "
                                "use auto, none, keep or viewpoint X Y Z");
  if (st.opt.tiles.points <= 0) throw nhnet::InvalidOptions("--stream needs --tile-points > 0");
  const std::string out =
      a.batch() ? "x." + (a.ext.empty() ? std::string("xyzn") : a.ext) : a.files[1];
  const nhnet::FileFormat f = nhnet::format_from_extension(out);
  if (f != nhnet::FileFormat::Ply && f != nhnet::FileFormat::Xyz)
    throw nhnet::InvalidOptions("--stream writes .ply or .xyz/.xyzn/.txt, not " + out);
}

}  // namespace

void add_estimate_options(CLI::App* sub, EstimateArgs& a) {
  add_path_options(sub, a);
  add_method_options(sub, a);
  add_stream_orient_options(sub, a);
  add_seed_option(sub, a.seed);
  add_output_flags(sub, a.output);
  sub->footer(kFooter);
}

Setup parse_estimate_args(const EstimateArgs& a) {
  check_paths(a);
  Setup st = prepare(a);
  check_stream(a, st);
  if (!a.batch()) check_output_format(a.files[1]);
  if (!a.ext.empty()) check_output_format("x." + a.ext);
  return st;
}

}  // namespace nhcli
