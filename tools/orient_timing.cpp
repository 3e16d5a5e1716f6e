// Times the MST orientation (orient_normals, OrientMode::Mst, default options) of a cloud's PCA
// normals and prints a digest of the resulting signs, so a speed change can be checked to keep
// the result. Not a test: a developer tool for issue 23 (docs/design/decisions.md).
//   orient_timing CLOUD [--threads T] [--repeat R] [--pca-k K]
#include "nhnet/geometry/pca.hpp"
#include "nhnet/io/io.hpp"
#include "nhnet/neighbors/neighbors.hpp"
#include "nhnet/orient/orient.hpp"

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: orient_timing CLOUD [--threads T] [--repeat R] [--pca-k K]\n");
    return 2;
  }
  int threads = 2, repeat = 3, pca_k = 30;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    const int v = std::atoi(argv[i + 1]);
    if (a == "--threads")
      threads = v;
    else if (a == "--repeat")
      repeat = v;
    else if (a == "--pca-k")
      pca_k = v;
    else {
      std::fprintf(stderr, "unknown option %s\n", a.c_str());
      return 2;
    }
  }
  const nhnet::Cloud cloud = nhnet::read_cloud(argv[1]);
  nhnet::RunContext run;
  run.threads = threads;
  nhnet::IndexMatrix knn;
  nhnet::Neighbors(cloud.points).knn_all(pca_k, knn, nullptr, run);
  const nhnet::Normals start =
      nhnet::pca_normals(cloud.points, knn, nhnet::PcaOptions{pca_k}, run).normals;
  double best = 1e300;
  for (int r = 0; r < repeat; ++r) {
    nhnet::Normals normals = start;
    nhnet::OrientOptions options;
    options.mode = nhnet::OrientMode::Mst;
    options.run.threads = threads;
    const auto t0 = std::chrono::steady_clock::now();
    const nhnet::OrientResult res = nhnet::orient_normals(cloud.points, normals, options);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    best = std::min(best, s);
    uint64_t digest = 1469598103934665603ull;  // FNV-1a over the signs
    for (Eigen::Index i = 0; i < normals.rows(); ++i) {
      digest ^= uint64_t(normals.row(i).dot(start.row(i)) < 0 ? 1 : 0);
      digest *= 1099511628211ull;
    }
    std::printf("run %d: %.3f s  flipped %lld unoriented %lld components %lld digest %016llx\n", r,
                s, (long long)res.flipped, (long long)res.unoriented, (long long)res.components,
                (unsigned long long)digest);
  }
  std::printf("points %lld threads %d best %.3f s\n", (long long)cloud.points.rows(), threads,
              best);
  return 0;
}
