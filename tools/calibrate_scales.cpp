// Calibration of the noise-driven scale rule (scales.cpp): for each cloud with ground truth
// (x y z nx ny nz text), prints the estimated noise ratio and the RMS angle error of PCA at a
// range of k and of MFPS with the automatic and with fixed scales.
// Build: see tools/README.md. Usage: calibrate_scales MODE FILE.gt.xyzn...
#include "nhnet/bandwidth.hpp"
#include "nhnet/estimate.hpp"
#include "nhnet/metrics.hpp"
#include "nhnet/neighbors.hpp"
#include "nhnet/pca.hpp"
#include "nhnet/scales.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

using namespace nhnet;

static bool load(const char* path, Points& p, Normals& n) {
  FILE* f = std::fopen(path, "r");
  if (!f) return false;
  std::vector<double> v;
  double a[6];
  while (std::fscanf(f, "%lf %lf %lf %lf %lf %lf", a, a + 1, a + 2, a + 3, a + 4, a + 5) == 6)
    v.insert(v.end(), a, a + 6);
  std::fclose(f);
  const Eigen::Index m = Eigen::Index(v.size() / 6);
  p.resize(m, 3);
  n.resize(m, 3);
  for (Eigen::Index i = 0; i < m; ++i)
    for (int d = 0; d < 3; ++d) {
      p(i, d) = v[size_t(6 * i + d)];
      n(i, d) = v[size_t(6 * i + 3 + d)];
    }
  return m > 0;
}

int main(int argc, char** argv) {
  if (argc < 3) return 2;
  const std::string mode = argv[1];
  for (int a = 2; a < argc; ++a) {
    Points p;
    Normals gt;
    if (!load(argv[a], p, gt)) continue;
    std::string name = argv[a];
    name = name.substr(name.find_last_of('/') + 1);
    std::printf("%-40s n=%ld", name.c_str(), long(p.rows()));
    if (mode == "probe") {
      Neighbors tree(p);
      IndexMatrix knn;
      DistanceMatrix d2;
      tree.knn_all(250, knn, &d2);
      for (int k : {16, 35, 75, 150, 250}) {
        const PcaResult r = pca_normals(p, knn, PcaOptions{k});
        std::vector<double> res(r.residual_rms.data(), r.residual_rms.data() + r.residual_rms.size());
        std::vector<double> rk(size_t(p.rows()));
        for (Eigen::Index i = 0; i < p.rows(); ++i) rk[size_t(i)] = std::sqrt(double(d2(i, k - 1)));
        std::nth_element(res.begin(), res.begin() + long(res.size() / 2), res.end());
        std::nth_element(rk.begin(), rk.begin() + long(rk.size() / 2), rk.end());
        const double l = rk[rk.size() / 2] * std::sqrt(M_PI / double(k - 1));
        std::printf(" k%d: res/l=%.3f l=%.5f", k, res[res.size() / 2] / l, l);
      }
      std::printf("\n");
    } else if (mode == "pca") {
      Neighbors tree(p);
      IndexMatrix knn;
      DistanceMatrix d2;
      tree.knn_all(250, knn, &d2);
      {
        const PcaResult r = pca_normals(p, knn, PcaOptions{75});
        std::vector<double> res(r.residual_rms.data(), r.residual_rms.data() + r.residual_rms.size());
        std::vector<double> rk(size_t(p.rows()));
        for (Eigen::Index i = 0; i < p.rows(); ++i) rk[size_t(i)] = std::sqrt(double(d2(i, 74)));
        std::nth_element(rk.begin(), rk.begin() + long(rk.size() / 2), rk.end());
        const double l = rk[rk.size() / 2] * std::sqrt(M_PI / 74.0);
        for (double q : {0.5, 0.25, 0.1}) {
          std::nth_element(res.begin(), res.begin() + long(double(res.size()) * q), res.end());
          std::printf(" rho75q%d=%.3f", int(q * 100), res[size_t(double(res.size()) * q)] / l);
        }
      }
      for (int k : {8, 12, 18, 25, 35, 50, 75, 112, 150, 200, 250}) {
        const PcaResult r = pca_normals(p, knn, PcaOptions{k});
        std::printf(" k%d=%.2f", k, angle_stats(r.normals, gt).rms);
      }
      std::printf("\n");
    } else {
      // mode: "auto" or a comma list of EstimateOptions overrides: k=..,s=a/b/c,samples=..,
      // subset=..,rescore=..,refine=..,method=pca|mfps
      EstimateOptions o;
      std::string spec = mode == "auto" ? "" : mode;
      size_t pos = 0;
      while (pos < spec.size()) {
        size_t e = spec.find(',', pos);
        if (e == std::string::npos) e = spec.size();
        const std::string kv = spec.substr(pos, e - pos);
        const std::string key = kv.substr(0, kv.find('='));
        const std::string val = kv.substr(kv.find('=') + 1);
        if (key == "k") o.k = std::stoi(val);
        if (key == "samples") o.mfps_samples = std::stoi(val);
        if (key == "subset") o.mfps_score_subset = std::stoi(val);
        if (key == "rescore") o.mfps_rescore = std::stoi(val);
        if (key == "refine") o.mfps_refine_iterations = std::stoi(val);
        if (key == "method") o.method = method_from_string(val);
        if (key == "gamma") o.mfps_soft_gamma = std::stod(val);
        if (key == "s") {
          size_t q = 0;
          while (q < val.size()) {
            size_t r = val.find('/', q);
            if (r == std::string::npos) r = val.size();
            o.scales.push_back(std::stoi(val.substr(q, r - q)));
            q = r + 1;
          }
        }
        pos = e + 1;
      }
      const auto t0 = std::chrono::steady_clock::now();
      const EstimateResult r = estimate_normals(p, o);
      const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const AngleStats s = angle_stats(r.normals, gt);
      std::printf(" rho=%.3f k=%d scales=", r.noise_ratio, r.k_used);
      for (int k : r.scales_used) std::printf("%d/", k);
      std::printf(" cand=%ld rms=%.2f mean=%.2f pgp5=%.3f t=%.2fs\n", long(r.candidates), s.rms,
                  s.mean, s.pgp5, secs);
    }
    std::fflush(stdout);
  }
  return 0;
}
