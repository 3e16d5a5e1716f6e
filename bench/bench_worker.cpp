// nhnet-bench-worker: runs ONE normal estimator on ONE benchmark cloud and prints one JSON line.
//
// The benchmark driver (bench/nhnet_bench.py) starts one worker process per (cloud, method), so
// the peak RSS it reads with wait4() is that method's alone. The worker reads the cloud with its
// ground-truth normals (`<name>.gt.xyzn` from nhnet-datagen), times only the estimator call
// (steady clock, wall seconds; file reading and scoring are outside the timed span) and scores the
// result with nhnet's metrics (unoriented angle error, metrics.hpp).
//
//   nhnet-bench-worker METHOD K GT_XYZN [--threads T] [--scales a,b,c] [--vcm-offset S]
//                      [--normals-out FILE]
//   nhnet-bench-worker --list
//
// Output: {"method":..., "k":..., "points":..., "time_s":..., "rss_before_mb":...,
//          "mean_deg":..., "rms_deg":..., "pgp5":..., "pgp10":..., "over30":..., "count":...,
//          "invalid":..., "k_used":..., "scales_used":[...], "stages":{"name": seconds, ...}}
// "stages" (nhnet methods): wall seconds per progress stage of the core (start, kd-tree,
// neighbours, pca, bandwidth, mfps planes, mfps selection, bilateral filter, canonical frames,
// height maps, nhnet), timed from the core's progress callback; they add up to time_s.
// --normals-out writes the estimated normals (x y z nx ny nz, %.17g) so two builds can be compared
// bit for bit.
#include "peers.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/eval/metrics.hpp"
#include "nhnet/io/io.hpp"
#include "nhnet/pipeline/estimate.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <functional>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

struct Args {
  std::string method;
  int k = 0;
  std::string gt;
  int threads = 2;
  std::vector<int> scales;  // nhnet mfps: explicit patch sizes (empty = auto)
  double vcm_offset = 5.0;  // CGAL VCM offset radius in average spacings
  std::string normals_out;  // optional: write the normals here
};

/// Wall seconds per core progress stage: the time between two callbacks goes to the stage the
/// earlier one named (a stage's tail and the gap before the next stage count as that stage).
struct StageClock {
  std::map<std::string, double> seconds;
  std::string current;
  std::chrono::steady_clock::time_point last = std::chrono::steady_clock::now();
  void tick(const std::string& stage) {
    const auto now = std::chrono::steady_clock::now();
    if (!current.empty()) seconds[current] += std::chrono::duration<double>(now - last).count();
    current = stage;
    last = now;
  }
};
StageClock g_stages;

struct Output {
  nhnet::Normals normals;
  int k_used = 0;
  std::vector<int> scales_used;
};

using Runner = std::function<Output(const nhnet::Points&, const Args&)>;

Output run_nhnet(const nhnet::Points& p, const Args& a, nhnet::Method m, bool auto_k,
                 bool learned_fit = true, const std::string& precision = "float32") {
  nhnet::EstimateOptions o;
  o.method = m;
  o.model.learned_fit = learned_fit;
  o.model.precision = precision;
  o.k = auto_k ? 0 : a.k;
  o.mfps.scales = auto_k ? std::vector<int>{} : a.scales;
  o.run.threads = a.threads;
  o.run.progress = [](double, const std::string& stage) {
    g_stages.tick(stage);
    return true;
  };
  nhnet::EstimateResult r = nhnet::estimate_normals(p, o);
  return {std::move(r.normals), r.k_used, r.scales_used};
}

// Method id -> estimator. The ids are the ones the driver and the tables use.
const std::map<std::string, Runner>& methods() {
  static const std::map<std::string, Runner> m = {
      {"pca", [](auto& p, auto& a) { return run_nhnet(p, a, nhnet::Method::Pca, false); }},
      {"pca-auto", [](auto& p, auto& a) { return run_nhnet(p, a, nhnet::Method::Pca, true); }},
      {"mfps", [](auto& p, auto& a) { return run_nhnet(p, a, nhnet::Method::Mfps, false); }},
      {"mfps-auto", [](auto& p, auto& a) { return run_nhnet(p, a, nhnet::Method::Mfps, true); }},
      // NH-Net with the default model (models/nhnet.pt, or $NHNET_MODEL), the network in float32:
      // the default precision, auto, takes bfloat16 on some CPUs, and the tables must not depend
      // on the machine (nhnet-bf16 measures bfloat16).
      {"nhnet", [](auto& p, auto& a) { return run_nhnet(p, a, nhnet::Method::NhNet, true); }},
      // The same without its last step, the learned fit (--learned-fit off): bench/front.py.
      {"nhnet-mix",
       [](auto& p, auto& a) { return run_nhnet(p, a, nhnet::Method::NhNet, true, false); }},
      // The default with the network in bfloat16 (--precision bfloat16).
      {"nhnet-bf16",
       [](auto& p, auto& a) {
         return run_nhnet(p, a, nhnet::Method::NhNet, true, true, "bfloat16");
       }},
      {"pcl-pca",
       [](auto& p, auto& a) {
         return Output{nhnet_bench::pcl_pca_normals(p, a.k, a.threads), a.k, {}};
       }},
      {"cgal-jet",
       [](auto& p, auto& a) {
         return Output{nhnet_bench::cgal_jet_normals(p, a.k, a.threads), a.k, {}};
       }},
      {"cgal-vcm",
       [](auto& p, auto& a) {
         return Output{nhnet_bench::cgal_vcm_normals(p, a.k, a.vcm_offset, a.threads), a.k, {}};
       }},
  };
  return m;
}

double rss_mb() {  // current resident set size (VmRSS), MB
  double kb = 0;
  if (FILE* f = std::fopen("/proc/self/status", "r")) {
    char line[256];
    while (std::fgets(line, sizeof line, f))
      if (std::sscanf(line, "VmRSS: %lf kB", &kb) == 1) break;
    std::fclose(f);
  }
  return kb / 1024.0;
}

std::string num(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

int parse_int(const std::string& s, const char* what) {
  char* end = nullptr;
  long v = std::strtol(s.c_str(), &end, 10);
  if (s.empty() || *end != '\0' || v < 0 || v > 1000000) {
    std::fprintf(stderr, "nhnet-bench-worker: bad %s '%s'\n", what, s.c_str());
    std::exit(2);
  }
  return int(v);
}

int usage() {
  std::fprintf(stderr,
               "usage: nhnet-bench-worker METHOD K GT_XYZN [--threads T] [--scales a,b,c] "
               "[--vcm-offset S] [--normals-out FILE]\n       nhnet-bench-worker --list\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> pos;
  Args a;
  for (int i = 1; i < argc; ++i) {
    std::string s = argv[i];
    if (s == "--list") {
      for (auto& kv : methods()) std::printf("%s\n", kv.first.c_str());
      return 0;
    }
    if ((s == "--threads" || s == "--scales" || s == "--vcm-offset" || s == "--normals-out") &&
        i + 1 < argc) {
      std::string v = argv[++i];
      if (s == "--normals-out") a.normals_out = v;
      if (s == "--threads") a.threads = parse_int(v, "--threads");
      if (s == "--vcm-offset") a.vcm_offset = std::atof(v.c_str());
      if (s == "--scales") {
        std::stringstream ss(v);
        for (std::string t; std::getline(ss, t, ',');) a.scales.push_back(parse_int(t, "--scales"));
      }
    } else if (!s.empty() && s[0] == '-') {
      return usage();
    } else {
      pos.push_back(s);
    }
  }
  if (pos.size() != 3) return usage();
  a.method = pos[0];
  a.k = parse_int(pos[1], "K");
  a.gt = pos[2];
  auto it = methods().find(a.method);
  if (it == methods().end()) {
    std::fprintf(stderr, "nhnet-bench-worker: unknown method '%s' (see --list)\n",
                 a.method.c_str());
    return 2;
  }
  try {
    const nhnet::Cloud cloud = nhnet::read_cloud(a.gt);
    if (!cloud.has_normals()) {
      std::fprintf(stderr, "nhnet-bench-worker: %s has no ground-truth normals\n", a.gt.c_str());
      return 3;
    }
    const double rss_before = rss_mb();
    const auto t0 = std::chrono::steady_clock::now();
    g_stages.tick("start");  // until the core's first stage: input checks, sort, model load
    Output out = it->second(cloud.points, a);
    const double secs =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    g_stages.tick("");
    if (!a.normals_out.empty()) {
      FILE* f = std::fopen(a.normals_out.c_str(), "w");
      if (!f) throw std::runtime_error("cannot write " + a.normals_out);
      for (Eigen::Index i = 0; i < out.normals.rows(); ++i)
        std::fprintf(f, "%.17g %.17g %.17g %.17g %.17g %.17g\n", cloud.points(i, 0),
                     cloud.points(i, 1), cloud.points(i, 2), out.normals(i, 0), out.normals(i, 1),
                     out.normals(i, 2));
      std::fclose(f);
    }
    std::string stages = "{";
    for (const auto& kv : g_stages.seconds)
      stages += (stages.size() > 1 ? ", \"" : "\"") + kv.first + "\": " + num(kv.second);
    stages += "}";
    const nhnet::AngleStats s = nhnet::angle_stats(out.normals, cloud.normals);
    std::string scales = "[";
    for (size_t i = 0; i < out.scales_used.size(); ++i)
      scales += (i ? "," : "") + std::to_string(out.scales_used[i]);
    scales += "]";
    std::printf(
        "{\"method\": \"%s\", \"k\": %d, \"points\": %lld, \"time_s\": %s, \"rss_before_mb\": %s, "
        "\"mean_deg\": %s, \"rms_deg\": %s, \"pgp5\": %s, \"pgp10\": %s, \"over30\": %s, "
        "\"count\": %lld, "
        "\"invalid\": %lld, \"k_used\": %d, \"scales_used\": %s, \"stages\": %s}\n",
        a.method.c_str(), a.k, static_cast<long long>(cloud.size()), num(secs).c_str(),
        num(rss_before).c_str(), num(s.mean).c_str(), num(s.rms).c_str(), num(s.pgp5).c_str(),
        num(s.pgp10).c_str(), num(s.over30).c_str(), static_cast<long long>(s.count),
        static_cast<long long>(s.invalid), out.k_used, scales.c_str(), stages.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "nhnet-bench-worker: %s: %s\n", a.method.c_str(), e.what());
    return 1;
  }
}
