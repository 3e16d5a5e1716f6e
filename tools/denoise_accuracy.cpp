// Accuracy of the normal-guided denoiser (paper Eq. 9, core/denoise.hpp) on generated clouds
// with clean points: for every BASE (a datagen cloud path without extension: BASE.xyz noisy,
// BASE.clean.xyz clean, BASE.gt.xyzn ground-truth normals) and every normal source, prints the
// mean distance of the noisy and of the denoised points to the clean surface (point-to-plane to
// the nearest clean point, metrics.hpp), in % of the clean cloud's bounding-box diagonal.
// Usage: denoise_accuracy [--methods pca,mfps,gt] [--radius-factors 3] [--iterations 20] BASE...
// (normal sources: pca / mfps = nhnet::estimate_normals with that method, automatic scales;
// gt = the ground-truth normals, an upper bound). See tools/README.md.
#include "nhnet/denoise.hpp"
#include "nhnet/estimate.hpp"
#include "nhnet/io.hpp"
#include "nhnet/metrics.hpp"

#include <chrono>
#include <cstdio>
#include <cstdlib>
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
  std::vector<std::string> bases;
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    if (arg == "--methods" && a + 1 < argc) {
      methods = split(argv[++a]);
    } else if (arg == "--radius-factors" && a + 1 < argc) {
      factors.clear();
      for (const auto& f : split(argv[++a])) factors.push_back(std::atof(f.c_str()));
    } else if (arg == "--iterations" && a + 1 < argc) {
      iterations = std::atoi(argv[++a]);
    } else if (!arg.empty() && arg[0] == '-') {
      std::fprintf(stderr,
                   "usage: denoise_accuracy [--methods pca,mfps,gt] [--radius-factors 3] "
                   "[--iterations 20] BASE...\n");
      return 2;
    } else {
      bases.push_back(arg);
    }
  }
  std::printf("%-36s %-5s %6s %10s %10s %7s %6s\n", "cloud", "norm", "factor", "before_%",
              "after_%", "ratio", "sec");
  for (const auto& base : bases) {
    const Cloud noisy = read_cloud(base + ".xyz");
    const Cloud clean = read_cloud(base + ".clean.xyz");
    const Cloud gt = read_cloud(base + ".gt.xyzn");
    const Eigen::Vector3d lo = clean.points.colwise().minCoeff(), hi = clean.points.colwise().maxCoeff();
    const double pct = 100.0 / (hi - lo).norm();
    const double before = surface_distances(noisy.points, clean.points, gt.normals).mean() * pct;
    const std::string name = base.substr(base.find_last_of('/') + 1);
    for (const auto& m : methods) {
      const auto t0 = std::chrono::steady_clock::now();
      Normals normals;
      if (m == "gt") {
        normals = gt.normals;
      } else {
        EstimateOptions eo;
        eo.method = method_from_string(m);
        normals = estimate_normals(noisy.points, eo).normals;
      }
      const double t_est = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      for (double f : factors) {
        const auto t1 = std::chrono::steady_clock::now();
        DenoiseOptions o;
        o.radius_factor = f;
        o.iterations = iterations;
        const DenoiseResult r = denoise_points(noisy.points, normals, o);
        const double after = surface_distances(r.points, clean.points, gt.normals).mean() * pct;
        const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
        std::printf("%-36s %-5s %6.2f %10.4f %10.4f %7.3f %6.2f\n", name.c_str(), m.c_str(), f,
                    before, after, after / before, t + t_est);
        std::fflush(stdout);
      }
    }
  }
  return 0;
}
