// Accuracy of the normal-guided denoiser (paper Eq. 9, core/include/nhnet/denoise/denoise.hpp) on
// generated clouds with clean points: for every BASE (a datagen cloud path without extension:
// BASE.xyz noisy, BASE.clean.xyz clean, BASE.gt.xyzn ground-truth normals) and every normal source,
// prints the mean distance of the noisy and of the denoised points to the clean surface
// (point-to-plane to the nearest clean point, metrics.hpp), in % of the clean cloud's bounding-box
// diagonal; and for estimated normals the share whose sign agrees with the ground truth after
// `--orient mst` (orient_normals defaults), over all points and over the points within 60 degrees
// of the truth (the sign of a normal that is off by more says little). Usage: denoise_accuracy
// [--methods pca,mfps,nhnet,gt] [--radius-factors 3] [--iterations 5,20]
//                         [--cache DIR] BASE...
// (normal sources: pca / mfps / nhnet = nhnet::estimate_normals with that method, automatic
// scales; gt = the ground-truth normals, an upper bound). --cache DIR keeps the estimated normals
// in DIR/NAME.METHOD.xyzn and reuses them (for repeated runs while tuning the denoiser or the
// orientation). See tools/README.md.
#include "nhnet/denoise/denoise.hpp"
#include "nhnet/eval/metrics.hpp"
#include "nhnet/io/io.hpp"
#include "nhnet/orient/orient.hpp"
#include "nhnet/pipeline/estimate.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace nhnet;

static std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');) out.push_back(item);
  return out;
}

int main(int argc, char** argv) {
  std::vector<std::string> methods{"pca", "mfps"};
  std::vector<double> factors{DenoiseOptions().radius_factor};
  int iterations = DenoiseOptions().iterations;
  std::vector<int> iteration_list;
  DenoiseOptions dbase;
  bool trace = false;
  OrientOptions obase;
  std::string cache;
  std::vector<std::string> bases;
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    if (arg == "--methods" && a + 1 < argc) {
      methods = split(argv[++a]);
    } else if (arg == "--radius-factors" && a + 1 < argc) {
      factors.clear();
      for (const auto& f : split(argv[++a])) factors.push_back(std::atof(f.c_str()));
    } else if (arg == "--iterations" && a + 1 < argc) {
      for (const auto& v : split(argv[++a])) iteration_list.push_back(std::atoi(v.c_str()));
    } else if (arg == "--sheet-gap" && a + 1 < argc) {
      dbase.sheet_gap = std::atof(argv[++a]);
    } else if (arg == "--orient-reflect" && a + 1 < argc) {
      obase.reflect = std::atoi(argv[++a]) != 0;
    } else if (arg == "--orient-guide-k" && a + 1 < argc) {
      obase.guide_k = std::atoi(argv[++a]);
      obase.smooth_guide = obase.guide_k > 0;
    } else if (arg == "--orient-reflect-min" && a + 1 < argc) {
      obase.reflect_min = std::atof(argv[++a]);
    } else if (arg == "--orient-vote" && a + 1 < argc) {
      obase.outward_vote = std::atoi(argv[++a]) != 0;
    } else if (arg == "--orient-reflect-noise" && a + 1 < argc) {
      obase.reflect_noise = std::atof(argv[++a]);
    } else if (arg == "--orient-inside-outside" && a + 1 < argc) {
      obase.inside_outside = std::atoi(argv[++a]) != 0;
    } else if (arg == "--orient-k" && a + 1 < argc) {
      obase.k = std::atoi(argv[++a]);
    } else if (arg == "--stop-drop" && a + 1 < argc) {
      dbase.stop_drop = std::atof(argv[++a]);
    } else if (arg == "--trace") {
      trace = true;
    } else if (arg == "--cache" && a + 1 < argc) {
      cache = argv[++a];
    } else if (!arg.empty() && arg[0] == '-') {
      std::fprintf(stderr,
                   "usage: denoise_accuracy [--methods pca,mfps,nhnet,gt] [--radius-factors 3] "
                   "[--iterations 5,20] [--cache DIR] [--sheet-gap G] [--orient-reflect 0|1] "
                   "[--orient-guide-k K (0 = no guide)] [--orient-k K] [--orient-inside-outside "
                   "0|1] BASE...\n");
      return 2;
    } else {
      bases.push_back(arg);
    }
  }
  if (iteration_list.empty()) iteration_list.push_back(iterations);
  std::printf("%-36s %-5s %4s %6s %10s %10s %7s %6s %8s %8s\n", "cloud", "norm", "it", "factor",
              "before_%", "after_%", "ratio", "sec", "sign_%", "sign60_%");
  for (const auto& base : bases) {
    const Cloud noisy = read_cloud(base + ".xyz");
    const Cloud clean = read_cloud(base + ".clean.xyz");
    const Cloud gt = read_cloud(base + ".gt.xyzn");
    const Eigen::Vector3d lo = clean.points.colwise().minCoeff(),
                          hi = clean.points.colwise().maxCoeff();
    const double pct = 100.0 / (hi - lo).norm();
    const double before = surface_distances(noisy.points, clean.points, gt.normals).mean() * pct;
    const std::string name = base.substr(base.find_last_of('/') + 1);
    for (const auto& m : methods) {
      const auto t0 = std::chrono::steady_clock::now();
      Normals normals;
      const std::string cached = cache.empty() ? "" : cache + "/" + name + "." + m + ".xyzn";
      if (m == "gt") {
        normals = gt.normals;
      } else if (!cached.empty() && std::ifstream(cached).good()) {
        normals = read_cloud(cached).normals;
      } else {
        EstimateOptions eo;
        eo.method = method_from_string(m);
        normals = estimate_normals(noisy.points, eo).normals;
        if (!cached.empty()) {
          Cloud c;
          c.points = noisy.points;
          c.normals = normals;
          write_cloud(cached, c);
        }
      }
      const double t_est =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      double sign = NAN, sign60 = NAN;
      if (m != "gt") {
        Normals oriented = normals;
        orient_normals(noisy.points, oriented, obase);
        int64_t all = 0, agree = 0, close = 0, agree60 = 0;
        for (Eigen::Index i = 0; i < oriented.rows(); ++i) {
          const double d = oriented.row(i).dot(gt.normals.row(i));
          if (!std::isfinite(d)) continue;
          ++all;
          agree += d > 0;
          if (std::abs(d) >= 0.5) {
            ++close;
            agree60 += d > 0;
          }
        }
        sign = 100.0 * double(agree) / double(all);
        sign60 = 100.0 * double(agree60) / double(close);
      }
      for (int iters : iteration_list)
        for (double f : factors) {
          const auto t1 = std::chrono::steady_clock::now();
          DenoiseOptions o = dbase;
          o.radius_factor = f;
          o.iterations = iters;
          const DenoiseResult r = denoise_points(noisy.points, normals, o);
          const double after = surface_distances(r.points, clean.points, gt.normals).mean() * pct;
          const double t =
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
          std::printf("%-36s %-5s %4d %6.2f %10.4f %10.4f %7.3f %6.2f %8.2f %8.2f\n", name.c_str(),
                      m.c_str(), iters, f, before, after, after / before, t + t_est, sign, sign60);
          if (trace) {
            std::printf("  ran %d, roughness:", r.iterations);
            for (double v : r.roughness) std::printf(" %.3g", v * pct);
            std::printf("\n");
          }
          std::fflush(stdout);
        }
    }
  }
  return 0;
}
