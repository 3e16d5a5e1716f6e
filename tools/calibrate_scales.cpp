// Calibration of the noise-driven scale rule (scales.cpp): for each cloud with ground truth
// (x y z nx ny nz text), mode `pca` prints the noise ratio rho (as the pipeline computes it) and
// the RMS angle error of PCA at a range of k (input of tools/fit_scale_table.py); any other
// mode runs estimate_normals with the given overrides and prints its accuracy and time; mode
// `blend=DIR` writes the MFPS PCA blend's features of every cloud to DIR (input of
// tools/fit_mfps_blend.py).
// Usage: see tools/README.md.
#include "nhnet/eval/metrics.hpp"
#include "nhnet/geometry/mfps.hpp"
#include "nhnet/geometry/pca.hpp"
#include "nhnet/geometry/scales.hpp"
#include "nhnet/neighbors/neighbors.hpp"
#include "nhnet/pipeline/estimate.hpp"

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
    if (mode == "pca") {
      Neighbors tree(p);
      IndexMatrix knn;
      DistanceMatrix d2;
      tree.knn_all(250, knn, &d2);
      {
        // The noise ratio exactly as the pipeline computes it (scales.hpp).
        const int kp = kNoiseProbeK;
        ProbeResiduals residual(p.rows(), 2);
        for (Eigen::Index i = 0; i < p.rows(); ++i)
          residual.row(i) = probe_residuals(p, &knn(i, 0), kp).transpose();
        const DistanceMatrix d2p = d2.leftCols(kp);
        std::printf(" rho=%.3f", estimate_noise(d2p, residual).ratio);
      }
      for (int k : {8, 12, 18, 25, 35, 50, 75, 112, 150, 200, 250}) {
        const PcaResult r = pca_normals(p, knn, PcaOptions{k});
        std::printf(" k%d=%.2f", k, angle_stats(r.normals, gt).rms);
      }
      std::printf("\n");
    } else if (mode.rfind("blend=", 0) == 0) {
      // Per candidate with blend features: input row, the features, the MFPS normal before the
      // blend, the PCA normal and the ground truth; the header has the squared error summed
      // over every other point (where the blend changes nothing).
      EstimateOptions o;
      o.mfps.record_blend_features = true;
      const EstimateResult r = estimate_normals(p, o);
      o.method = Method::Pca;
      o.k = r.k_used;
      const EstimateResult pca = estimate_normals(p, o);
      Eigen::VectorXd err = angle_errors_deg(r.normals, gt);
      for (const int64_t i : r.mfps_blend_rows) err[i] = 0;  // summed in the fit instead
      double rest_sq = 0;
      for (Eigen::Index i = 0; i < err.size(); ++i)
        if (std::isfinite(err[i])) rest_sq += err[i] * err[i];
      const std::string out = mode.substr(6) + "/" + name + ".blend.txt";
      FILE* f = std::fopen(out.c_str(), "w");
      if (!f) return 6;
      std::fprintf(f, "# points %ld rest_sq_sum %.9g\n", long(p.rows()), rest_sq);
      auto put = [f](const Normals& m, Eigen::Index row) {
        for (int d = 0; d < 3; ++d) std::fprintf(f, " %.9g", m(row, d));
      };
      for (size_t t = 0; t < r.mfps_blend_rows.size(); ++t) {
        const int64_t i = r.mfps_blend_rows[t];
        std::fprintf(f, "%ld", long(i));
        for (int q = 0; q < kMfpsBlendFeatures; ++q)
          std::fprintf(f, " %.9g", r.mfps_blend_features(Eigen::Index(t), q));
        put(r.mfps_unblended, Eigen::Index(t));
        put(pca.normals, i);
        put(gt, i);
        std::fprintf(f, "\n");
      }
      std::fclose(f);
      std::printf(" rows=%zu -> %s\n", r.mfps_blend_rows.size(), out.c_str());
    } else {
      // mode: "auto" or a comma list of EstimateOptions overrides: k=..,s=a/b/c,samples=..,
      // subset=..,members=..,rescore=..,refine=..,method=pca|mfps
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
        if (key == "samples") o.mfps.samples = std::stoi(val);
        if (key == "subset") o.mfps.score_subset = std::stoi(val);
        if (key == "members") o.mfps.fit_members = std::stoi(val);
        if (key == "rescore") o.mfps.rescore = std::stoi(val);
        if (key == "refine") o.mfps.refine_iterations = std::stoi(val);
        if (key == "method") o.method = method_from_string(val);
        if (key == "beta") o.mfps.posterior_beta = std::stod(val);
        if (key == "geo") o.mfps.edge_sigma_factor = std::stod(val);
        if (key == "fpt") o.mfps.point_sigma_factor = std::stod(val);
        if (key == "pcablend") o.mfps.pca_blend = std::stoi(val) != 0;
        if (key == "s") {
          size_t q = 0;
          while (q < val.size()) {
            size_t r = val.find('/', q);
            if (r == std::string::npos) r = val.size();
            o.mfps.scales.push_back(std::stoi(val.substr(q, r - q)));
            q = r + 1;
          }
        }
        pos = e + 1;
      }
      const auto t0 = std::chrono::steady_clock::now();
      const EstimateResult r = estimate_normals(p, o);
      const double secs =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
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
