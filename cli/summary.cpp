// Summary lines (stderr), --json objects (stdout) and eval's table: what a finished run reports.
#include "summary.hpp"

#include "json.hpp"
#include "nhnet/learned/confidence.hpp"
#include "progress.hpp"

#include <cstdio>
#include <iostream>
#include <sstream>

namespace nhcli {

// ---- orientation --------------------------------------------------------------------------------

void warn_unoriented(Reporter& rep, const nhnet::OrientOptions& opt, const nhnet::OrientResult& r) {
  if (r.unoriented_components > 0)
    rep.warn("--orient mst: " + std::to_string(r.unoriented_components) + " of " +
             std::to_string(r.components) + " connected parts could not be oriented; " +
             std::to_string(r.unoriented) + " normals keep an arbitrary sign");
  else if (r.unoriented > 0)
    rep.warn("--orient " + std::string(nhnet::to_string(opt.mode)) + ": " +
             std::to_string(r.unoriented) + " normals could not be oriented (" +
             (opt.mode == nhnet::OrientMode::Keep ? "the input normal is missing or perpendicular"
              : opt.mode == nhnet::OrientMode::Up ? "vertical, perpendicular to their guide"
                                                  : "perpendicular to the line of sight") +
             "); their sign is arbitrary");
}

namespace {

/// Summary-line text: "mst (2 parts, 0 unoriented, 1234 flipped; no sensor in the file: MST)",
/// "keep (12 flipped; input normals)", "none"; the source only when auto chose the mode.
std::string orient_summary(const nhnet::OrientOptions& opt, const std::string& source,
                           const nhnet::OrientResult& r) {
  std::string s = nhnet::to_string(opt.mode);
  const std::string why = source.empty() || source == "requested" ? "" : source;
  if (opt.mode == nhnet::OrientMode::None) return why.empty() ? s : s + " (" + why + ")";
  s += " (";
  if (opt.mode == nhnet::OrientMode::Mst || opt.mode == nhnet::OrientMode::Up)
    s += std::to_string(r.components) + (r.components == 1 ? " part, " : " parts, ") +
         std::to_string(r.completed) + " completed, ";
  if (opt.mode != nhnet::OrientMode::Keep || r.unoriented > 0)
    s += std::to_string(r.unoriented) + " unoriented, ";
  s += std::to_string(r.flipped) + " flipped";
  if (opt.mode == nhnet::OrientMode::Mst && opt.inside_outside)
    s += r.voxel > 0 ? ", " + std::to_string(r.inside_outside_votes) + " sided by the flood fill"
                     : ", open: the tree alone";
  return s + (why.empty() ? ")" : "; " + why + ")");
}

/// JSON members: "orient": "...", "flipped": N, "unoriented": N, "components": N, ...
std::string orient_json(const nhnet::OrientOptions& opt, const std::string& source,
                        const nhnet::OrientResult& r) {
  std::string s = "\"orient\": " + json_string(nhnet::to_string(opt.mode)) +
                  ", \"orient_source\": " + json_string(source) +
                  ", \"flipped\": " + std::to_string(r.flipped) +
                  ", \"unoriented\": " + std::to_string(r.unoriented) +
                  ", \"components\": " + std::to_string(r.components) +
                  ", \"unoriented_components\": " + std::to_string(r.unoriented_components) +
                  ", \"completed\": " + std::to_string(r.completed);
  if (opt.mode == nhnet::OrientMode::Mst)
    s += ", \"orient_k\": " + std::to_string(opt.k) +
         ", \"inside_outside_votes\": " + std::to_string(r.inside_outside_votes) +
         ", \"voxel\": " + json_number(r.voxel, 17);
  if (opt.mode == nhnet::OrientMode::Viewpoint)
    s += ", \"viewpoint\": [" + json_number(opt.viewpoint[0], 17) + ", " +
         json_number(opt.viewpoint[1], 17) + ", " + json_number(opt.viewpoint[2], 17) + "]";
  return s;
}

// ---- estimate -----------------------------------------------------------------------------------

std::string join(const std::vector<int>& v, const char* sep) {
  std::string s;
  for (size_t i = 0; i < v.size(); ++i) s += (i ? sep : "") + std::to_string(v[i]);
  return s;
}

void print_estimate_line(const EstimateSummary& s) {
  const bool nhnet = s.method == nhnet::Method::NhNet;
  char noise[32], secs[32];
  std::snprintf(noise, sizeof noise, "%.3g", s.noise_ratio);
  std::snprintf(secs, sizeof secs, "%.2f", s.seconds);
  const std::string tiles = s.streamed    ? ", streamed in " + std::to_string(s.tiles) + " tiles"
                            : s.tiles > 1 ? ", " + std::to_string(s.tiles) + " tiles"
                                          : std::string();
  const std::string means =
      s.cell_means > 0 ? ", through " + std::to_string(s.cell_means) + " cell means" : "";
  char low[64] = "";
  if (s.low_confidence >= 0)
    std::snprintf(low, sizeof low, ", %lld below confidence %g", (long long)s.low_confidence,
                  nhnet::kLowConfidence);
  std::ostringstream line;
  line << "nhnet-cli: " << s.points << " points, " << s.failed << " failed, method "
       << nhnet::to_string(s.method)
       << (nhnet ? nhnet::network_phrase(s.device, s.precision) : std::string()) << ", k " << s.k
       << ", scales " << (s.scales.empty() ? std::string("-") : join(s.scales, "/"))
       << ", noise ratio " << noise << ", " << s.candidates << " candidates" << means << low
       << tiles << ", orient " << orient_summary(s.orient, s.orient_source, s.orient_result) << ", "
       << secs << " s, output " << s.out;
  std::cerr << line.str() << std::endl;
}

void print_estimate_json(const EstimateSummary& s) {
  const bool nhnet = s.method == nhnet::Method::NhNet;
  std::ostringstream js;
  js << "{\"input\": " << json_string(s.in) << ", \"output\": " << json_string(s.out)
     << ", \"points\": " << s.points << ", \"failed\": " << s.failed
     << ", \"method\": " << json_string(nhnet::to_string(s.method))
     << (nhnet ? ", \"device\": " + json_string(s.device) +
                     ", \"precision\": " + json_string(s.precision)
               : std::string())
     << ", \"k\": " << s.k << ", \"scales\": [" << join(s.scales, ", ") << "]"
     << ", \"noise_ratio\": " << json_number(s.noise_ratio)
     << ", \"spacing\": " << json_number(s.spacing) << ", \"candidates\": " << s.candidates
     << ", \"cell_means\": " << s.cell_means
     << (s.low_confidence >= 0 ? ", \"low_confidence\": " + std::to_string(s.low_confidence)
                               : std::string())
     << ", \"tiles\": " << s.tiles << (s.streamed ? ", \"streamed\": true" : "") << ", "
     << orient_json(s.orient, s.orient_source, s.orient_result) << ", \"warnings\": " << s.warnings
     << ", \"seconds\": " << json_number(s.seconds, 4) << "}";
  std::cout << js.str() << std::endl;
}

// ---- denoise ------------------------------------------------------------------------------------

void print_denoise_line(const DenoiseSummary& s, const nhnet::DenoiseResult& res) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "radius %.4g, %.1f neighbours on average, %.2f s", res.radius,
                res.mean_neighbors, s.seconds);
  std::ostringstream line;
  line << "nhnet-cli: " << s.points << " points, " << res.moved << " moved, " << res.skipped
       << " skipped, " << res.isolated << " isolated, normals from " << s.normals_from << ", "
       << res.iterations << " iterations (at most " << s.max_iterations << "), " << buf
       << ", output " << s.out;
  std::cerr << line.str() << std::endl;
}

void print_denoise_json(const DenoiseSummary& s, const nhnet::DenoiseResult& res) {
  std::ostringstream js;
  js << "{\"input\": " << json_string(s.in) << ", \"output\": " << json_string(s.out)
     << ", \"points\": " << s.points << ", \"moved\": " << res.moved
     << ", \"skipped\": " << res.skipped << ", \"isolated\": " << res.isolated
     << ", \"normals_from\": " << json_string(s.normals_from)
     << ", \"normals_failed\": " << s.normals_failed << ", \"iterations\": " << s.max_iterations
     << ", \"iterations_run\": " << res.iterations << ", \"radius\": " << json_number(res.radius, 8)
     << ", \"spacing\": " << json_number(res.spacing, 8)
     << ", \"sigma\": " << json_number(res.sigma)
     << ", \"mean_neighbors\": " << json_number(res.mean_neighbors)
     << ", \"keep_normals\": " << (s.keep_normals ? "true" : "false")
     << ", \"warnings\": " << s.warnings << ", \"seconds\": " << json_number(s.seconds, 4) << "}";
  std::cout << js.str() << std::endl;
}

}  // namespace

void print_estimate_summary(const OutputFlags& flags, const EstimateSummary& s) {
  if (!flags.quiet && !flags.json) print_estimate_line(s);
  if (flags.json) print_estimate_json(s);
}

void print_denoise_summary(const OutputFlags& flags, const DenoiseSummary& s,
                           const nhnet::DenoiseResult& res) {
  if (!flags.quiet && !flags.json) print_denoise_line(s, res);
  if (flags.json) print_denoise_json(s, res);
}

// ---- eval ---------------------------------------------------------------------------------------

void print_eval_result(const std::string& est, const std::string& gt, const nhnet::AngleStats& s,
                       bool json) {
  if (json) {
    std::ostringstream js;
    js << "{\"estimated\": " << json_string(est) << ", \"ground_truth\": " << json_string(gt)
       << ", \"mean_deg\": " << json_number(s.mean, 8) << ", \"rms_deg\": " << json_number(s.rms, 8)
       << ", \"pgp5_pct\": " << json_number(s.pgp5 * 100.0, 8)
       << ", \"pgp10_pct\": " << json_number(s.pgp10 * 100.0, 8)
       << ", \"over30_pct\": " << json_number(s.over30 * 100.0, 8) << ", \"count\": " << s.count
       << ", \"invalid\": " << s.invalid << "}";
    std::cout << js.str() << std::endl;
    return;
  }
  std::printf("mean     %.4f deg\n", s.mean);
  std::printf("rms      %.4f deg\n", s.rms);
  std::printf("pgp5     %.2f %%\n", s.pgp5 * 100.0);
  std::printf("pgp10    %.2f %%\n", s.pgp10 * 100.0);
  std::printf("over30   %.2f %%\n", s.over30 * 100.0);
  std::printf("count    %lld\n", static_cast<long long>(s.count));
  std::printf("invalid  %lld\n", static_cast<long long>(s.invalid));
  std::fflush(stdout);
}

}  // namespace nhcli
