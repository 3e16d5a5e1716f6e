// Out-of-core estimation (core/src/pipeline/stream.cpp): an XYZ file processed in tiles through
// temporary files gets the normals of the in-memory run, in the input's order; non-finite points
// fail and are reported; bad input, PLY input and MST orientation are refused without an output;
// progress reaches 1 and cancelling leaves neither an output nor temporary files.
#include "fixtures.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/eval/metrics.hpp"
#include "nhnet/io/io.hpp"
#include "nhnet/learned/confidence.hpp"
#include "nhnet/pipeline/estimate.hpp"
#include "nhnet/pipeline/stream.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>

using namespace nhnet;
namespace fs = std::filesystem;

namespace {

class Stream : public ::testing::Test {
 protected:
  void SetUp() override {
    std::random_device rd;
    dir_ = fs::temp_directory_path() /
           ("nhnet_stream_test_" + std::to_string(::getpid()) + "_" + std::to_string(rd()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  // Files left in the folder besides `keep`.
  int others(const std::vector<std::string>& keep) const {
    int n = 0;
    for (const auto& e : fs::directory_iterator(dir_))
      n += std::find(keep.begin(), keep.end(), e.path().filename().string()) == keep.end();
    return n;
  }
  std::string write_xyz(const std::string& name, const Points& p) const {
    Cloud c;
    c.points = p;
    write_cloud(path(name), c);
    return path(name);
  }
  fs::path dir_;
};

StreamOptions options(Method m, int64_t tile_points) {
  StreamOptions o;
  o.estimate.method = m;
  o.estimate.tiles.points = tile_points;
  o.estimate.run.threads = 2;
  o.orient.mode = OrientMode::None;
  return o;
}

// Share of rows whose unoriented normals differ by more than `deg` degrees (NaN in both = equal).
double share_differing(const Normals& a, const Normals& b, double deg) {
  const Eigen::VectorXd e = angle_errors_deg(a, b);
  int64_t bad = 0;
  for (Eigen::Index i = 0; i < e.size(); ++i) {
    const bool fa = a.row(i).allFinite(), fb = b.row(i).allFinite();
    if (!fa && !fb) continue;
    if (fa != fb || !(e[i] <= deg)) ++bad;
  }
  return double(bad) / double(e.size());
}

}  // namespace

// The cube in 4 streamed tiles. What differs from the in-memory run: the tile boundaries (placed
// on a sample: here the sample is the whole cloud) and where the noise probe's neighbourhoods are
// searched (each tile with a halo of twice a rough probe radius instead of the whole cloud: the
// same points, the same neighbours but for the rare point beyond the halo), so the noise ratio
// may move in the last digits; the sizes (k, scales) it picks must be the same, and then the
// normals are the in-memory ones but for rounding (they are stored as float: 1e-4 degrees) and
// the few points whose candidate flag moves with the threshold: 1e-3 degrees for 99 % of the
// points, and the mean error against the truth within 0.05 degrees.
TEST_F(Stream, MfpsEqualsTheInMemoryRun) {
  const auto f = fixtures::cube(30000, 0.004, 11);
  const std::string in = write_xyz("cube.xyz", f.points);
  EstimateOptions eo = options(Method::Mfps, 0).estimate;
  const EstimateResult whole = estimate_normals(f.points, eo);
  const StreamResult sr = estimate_stream(in, path("out.xyzn"), options(Method::Mfps, 8000));
  EXPECT_EQ(sr.points, 30000);
  EXPECT_EQ(sr.tiles, 4);
  EXPECT_EQ(sr.k_used, whole.k_used);
  EXPECT_EQ(sr.scales_used, whole.scales_used);
  EXPECT_NEAR(sr.noise_ratio, whole.noise_ratio, 0.02 * whole.noise_ratio);
  EXPECT_NEAR(sr.spacing, whole.spacing, 0.02 * whole.spacing);
  EXPECT_EQ(sr.failed, whole.failed);
  EXPECT_NEAR(double(sr.candidates), double(whole.candidates), 0.01 * 30000);
  const Cloud out = read_cloud(path("out.xyzn"));
  ASSERT_EQ(out.size(), 30000);
  EXPECT_EQ(out.points, f.points);  // input order and coordinates kept exactly
  EXPECT_LT(share_differing(out.normals, whole.normals, 1e-3), 0.01);
  EXPECT_NEAR(angle_stats(out.normals, f.normals).mean, angle_stats(whole.normals, f.normals).mean,
              0.05);
  EXPECT_EQ(others({"cube.xyz", "out.xyzn"}), 0);  // no temporary files left
}

// A cloud whose noise reaches the cell means' threshold goes through them in the streamed tiles
// too (the in-memory run did, the stream did not: 3.4x the time on 3M noisy fandisk points).
// Each tile places its own cubes and measures its own means' sizes (tiles.hpp), so the normals
// are not the in-memory run's (most move by over 1 degree: other cubes, other means) but as
// accurate: RMS and mean error against the truth within 0.15 degrees of the in-memory run's
// (5 % of its 3.2 degrees; measured: +0.08 and +0.06, the spread of another cube placement).
TEST_F(Stream, NoisyDenseCloudThroughCellMeansAsAccurateAsInMemory) {
  fixtures::Fixture f = fixtures::sphere(40000, 7);
  f.points = fixtures::with_noise(f.points, 0.025, 8);
  const std::string in = write_xyz("sphere.xyz", f.points);
  StreamOptions so = options(Method::Mfps, 12000);
  so.estimate.cell_means.min_points = 1000;  // as test_cell_means.cpp: a small cloud
  so.estimate.cell_means.noise_ratio = 1.0;
  EstimateOptions eo = so.estimate;
  eo.tiles.points = 0;
  const EstimateResult whole = estimate_normals(f.points, eo);
  ASSERT_GT(whole.cell_means, 0);
  const StreamResult sr = estimate_stream(in, path("out.xyzn"), so);
  EXPECT_EQ(sr.tiles, 4);
  EXPECT_GT(sr.cell_means, whole.cell_means);      // means near a border count in both tiles
  EXPECT_LT(sr.cell_means, 4 * whole.cell_means);  // no tile holds the whole sphere
  EXPECT_EQ(sr.failed, 0);
  const Cloud out = read_cloud(path("out.xyzn"));
  const AngleStats a = angle_stats(out.normals, f.normals);
  const AngleStats b = angle_stats(whole.normals, f.normals);
  EXPECT_NEAR(a.rms, b.rms, 0.15);
  EXPECT_NEAR(a.mean, b.mean, 0.15);

  so.estimate.cell_means.noise_ratio = 0;  // off: the points themselves, as before
  EXPECT_EQ(estimate_stream(in, path("off.xyzn"), so).cell_means, 0);
}

// PCA, binary PLY output, non-finite rows: they fail (NaN normal), are counted and warned about,
// and every other point keeps its place.
TEST_F(Stream, PcaPlyOutputWithNonFinitePoints) {
  auto f = fixtures::sphere(12000, 3);
  for (int i = 0; i < 12000; i += 97) f.points(i, i % 3) = std::numeric_limits<double>::quiet_NaN();
  const std::string in = write_xyz("s.xyz", f.points);
  EstimateOptions eo = options(Method::Pca, 0).estimate;
  const EstimateResult whole = estimate_normals(f.points, eo);
  const StreamResult sr = estimate_stream(in, path("s.ply"), options(Method::Pca, 3000));
  EXPECT_EQ(sr.tiles, 4);
  EXPECT_EQ(sr.failed, whole.failed);
  EXPECT_EQ(sr.failed, (12000 + 96) / 97);
  EXPECT_NE(
      std::find(sr.warnings.begin(), sr.warnings.end(),
                std::to_string(sr.failed) + " non-finite points skipped (reported as failed)"),
      sr.warnings.end());
  const Cloud out = read_cloud(path("s.ply"));
  ASSERT_EQ(out.size(), 12000);
  for (Eigen::Index i = 0; i < 12000; ++i)
    for (int k = 0; k < 3; ++k)
      if (std::isfinite(f.points(i, k))) {
        EXPECT_EQ(out.points(i, k), f.points(i, k));  // doubles stay doubles
      }
  EXPECT_LT(share_differing(out.normals, whole.normals, 1e-3), 0.005);
  EXPECT_LT(angle_stats(out.normals, f.normals).mean, 1.0);  // noise-free sphere (test_pca's bar)
}

// With the confidence asked for, every streamed point carries the in-memory run's: the tiles'
// normals are the in-memory ones but for float rounding (previous test), and a point's 16
// scoring neighbours lie in its tile's halo, so the scores agree to 1e-4 (float storage) but for
// the few points next to a tile boundary whose normal or neighbours move (under 1 %). Binary PLY
// (a float property 'confidence') and XYZ text (a 7th column) both; non-finite points get NaN;
// without the option neither output has the column.
TEST_F(Stream, ConfidenceInPlyAndXyzFollowsTheInMemoryRun) {
  auto f = fixtures::cube(12000, 0.004, 4);
  for (int i = 0; i < 12000; i += 211) f.points(i, 0) = std::numeric_limits<double>::quiet_NaN();
  const std::string in = write_xyz("c.xyz", f.points);
  EstimateOptions eo = options(Method::Pca, 0).estimate;
  eo.confidence = true;
  const EstimateResult whole = estimate_normals(f.points, eo);
  StreamOptions o = options(Method::Pca, 3000);
  o.estimate.confidence = true;
  const StreamResult sr = estimate_stream(in, path("c.ply"), o);
  estimate_stream(in, path("c7.xyz"), o);
  const Cloud ply = read_cloud(path("c.ply"));
  ASSERT_EQ(ply.extras.size(), 1u);
  EXPECT_EQ(sr.low_confidence,
            count_low_confidence(Eigen::Map<const Eigen::VectorXd>(
                ply.extras[0].values.data(), Eigen::Index(ply.extras[0].values.size()))));
  EXPECT_EQ(ply.extras[0].name, "confidence");
  EXPECT_EQ(ply.extras[0].type, ScalarType::Float32);
  std::ifstream text(path("c7.xyz"));
  int64_t rows = 0, differ = 0;
  for (std::string line; std::getline(text, line); ++rows) {
    double v[8];
    int n = 0;
    for (const char* at = line.c_str(); n < 8; ++n) {  // strtod reads "nan", istream does not
      char* end = nullptr;
      v[n] = std::strtod(at, &end);
      if (end == at) break;
      at = end;
    }
    ASSERT_EQ(n, 7) << "line " << rows + 1 << ": " << line;
    const double c = ply.extras[0].values[size_t(rows)];
    if (!whole.valid[size_t(rows)]) {
      EXPECT_TRUE(std::isnan(c) && std::isnan(v[6])) << rows;
      continue;
    }
    EXPECT_FLOAT_EQ(float(c), float(v[6])) << rows;  // the same float in both outputs
    differ += !(std::abs(c - whole.confidence[rows]) <= 1e-4);
  }
  EXPECT_EQ(rows, 12000);
  EXPECT_LT(double(differ), 0.01 * 12000);
  o.estimate.confidence = false;
  EXPECT_EQ(estimate_stream(in, path("off.ply"), o).low_confidence, -1);
  EXPECT_TRUE(read_cloud(path("off.ply")).extras.empty());
}

// Viewpoint orientation is per point, so it streams: every normal of a sphere seen from its
// centre points inwards.
TEST_F(Stream, ViewpointOrientation) {
  const auto f = fixtures::sphere(9000, 5);
  const std::string in = write_xyz("s.xyz", f.points);
  StreamOptions o = options(Method::Pca, 3000);
  o.orient.mode = OrientMode::Viewpoint;
  o.orient.viewpoint = Eigen::Vector3d::Zero();
  const StreamResult sr = estimate_stream(in, path("o.xyzn"), o);
  EXPECT_EQ(sr.orient.unoriented, 0);
  const Cloud out = read_cloud(path("o.xyzn"));
  int inward = 0;
  for (Eigen::Index i = 0; i < out.size(); ++i)
    inward += out.normals.row(i).dot(-out.points.row(i)) > 0;
  EXPECT_EQ(inward, 9000);
}

TEST_F(Stream, RefusesWhatItCannotStream) {
  const auto f = fixtures::sphere(3000, 5);
  const std::string in = write_xyz("s.xyz", f.points);
  Cloud c;
  c.points = f.points;
  write_cloud(path("s.ply"), c);
  StreamOptions o = options(Method::Pca, 1000);
  EXPECT_THROW(estimate_stream(path("s.ply"), path("o.xyzn"), o), InvalidOptions);
  EXPECT_THROW(estimate_stream(in, path("o.pcd"), o), InvalidOptions);
  EXPECT_THROW(estimate_stream(in, in, o), InvalidOptions);
  o.orient.mode = OrientMode::Mst;
  EXPECT_THROW(estimate_stream(in, path("o.xyzn"), o), InvalidOptions);
  EXPECT_EQ(others({"s.xyz", "s.ply"}), 0);
}

// A malformed line far into the file (in a later pass than the first would be too late, so the
// scan finds it): InputError naming the file and the line, no output, no temporary files.
TEST_F(Stream, MalformedLineNamesFileAndLine) {
  const auto f = fixtures::sphere(5000, 5);
  const std::string in = write_xyz("bad.xyz", f.points);
  {
    std::ofstream app(in, std::ios::app);
    app << "1 2 x3\n";
  }
  try {
    estimate_stream(in, path("o.xyzn"), options(Method::Pca, 2000));
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(in), std::string::npos) << m;
    EXPECT_NE(m.find("line 5001"), std::string::npos) << m;
  }
  EXPECT_EQ(others({"bad.xyz"}), 0);
}

TEST_F(Stream, ProgressReachesOneAndCancelLeavesNothing) {
  const auto f = fixtures::cube(12000, 0.004, 2);
  const std::string in = write_xyz("c.xyz", f.points);
  StreamOptions o = options(Method::Mfps, 4000);
  double last = -1;
  bool monotone = true;
  o.estimate.run.progress = [&](double x, const std::string&) {
    monotone = monotone && x >= last - 1e-12;
    last = x;
    return true;
  };
  estimate_stream(in, path("o.xyzn"), o);
  EXPECT_TRUE(monotone);
  EXPECT_DOUBLE_EQ(last, 1.0);
  fs::remove(path("o.xyzn"));
  o.estimate.run.progress = [](double x, const std::string&) { return x < 0.5; };
  EXPECT_THROW(estimate_stream(in, path("o.xyzn"), o), Cancelled);
  EXPECT_EQ(others({"c.xyz"}), 0);
}
