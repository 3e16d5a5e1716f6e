// LAS / LAZ / E57 io (core/src/io/las.cpp, las_write.cpp, e57.cpp): round trips through our own
// writer, the LAS pass-through (a LAS read and written again is the same file), georeferenced
// coordinates, E57 sensors and poses, and malformed files (InputError naming the file and the
// problem). Independent readers (laspy, lazrs, pye57) check the same in
// tests/python/test_formats_las_e57.py.
#include "nhnet/errors.hpp"
#include "nhnet/io/io.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

using namespace nhnet;
namespace fs = std::filesystem;

namespace {

class LasE57Test : public ::testing::Test {
 protected:
  void SetUp() override {
    std::random_device rd;
    dir_ = fs::temp_directory_path() /
           ("nhnet_las_test_" + std::to_string(::getpid()) + "_" + std::to_string(rd()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  std::string bytes(const std::string& name) const {
    std::ifstream in(path(name), std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }
  std::string put(const std::string& name, const std::string& data) const {
    std::ofstream out(path(name), std::ios::binary);
    out.write(data.data(), std::streamsize(data.size()));
    return path(name);
  }
  /// The InputError message of reading `name`; fails the test when it reads.
  std::string read_error(const std::string& name) const {
    try {
      read_cloud(path(name));
    } catch (const InputError& e) {
      return e.what();
    }
    ADD_FAILURE() << name << " was read";
    return "";
  }
  fs::path dir_;
};

/// A terrain patch at UTM-like coordinates with normals and LAS-like extras.
Cloud terrain(int n, double east = 500000.0, double north = 4000000.0) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 50.0);
  Cloud c;
  c.points.resize(n, 3);
  c.normals.resize(n, 3);
  ExtraProperty intensity{"intensity", ScalarType::UInt16, {}};
  ExtraProperty red{"red", ScalarType::UInt16, {}}, green{"green", ScalarType::UInt16, {}},
      blue{"blue", ScalarType::UInt16, {}};
  ExtraProperty quality{"quality", ScalarType::Float32, {}};
  for (int i = 0; i < n; ++i) {
    const double x = u(rng), y = u(rng);
    c.points.row(i) << east + x, north + y, 100 + 0.2 * x + 0.1 * y;
    c.normals.row(i) = Eigen::Vector3d(-0.2, -0.1, 1).normalized().transpose();
    intensity.values.push_back(double(i % 65536));
    red.values.push_back(double((i * 7) % 65536));
    green.values.push_back(double((i * 13) % 65536));
    blue.values.push_back(double((i * 31) % 65536));
    quality.values.push_back(double(float(x / 50)));
  }
  c.extras = {intensity, red, green, blue, quality};
  return c;
}

const ExtraProperty* extra(const Cloud& c, const std::string& name) {
  for (const ExtraProperty& e : c.extras)
    if (e.name == name) return &e;
  return nullptr;
}

TEST_F(LasE57Test, FreshLasAndLazKeepPointsNormalsExtras) {
  const Cloud in = terrain(1500);
  for (const char* name : {"a.las", "a.laz"}) {
    write_cloud(path(name), in);
    const Cloud c = read_cloud(path(name));
    ASSERT_EQ(c.size(), in.size()) << name;
    ASSERT_TRUE(c.has_normals()) << name;
    EXPECT_TRUE(c.airborne);
    // Scale for a 25 m half extent: the power of ten above 25 m / 2e9, 1e-7 m, so half a step
    // (5e-8 m) plus the double rounding of x * scale + offset at 4e6 m (1e-9 m) bounds the error.
    EXPECT_LT((c.points - in.points).cwiseAbs().maxCoeff(), 5.1e-8) << name;
    EXPECT_LT((c.normals - in.normals).cwiseAbs().maxCoeff(), 1e-7) << name;  // float32
    for (const char* e : {"intensity", "red", "green", "blue", "quality"}) {
      ASSERT_NE(extra(c, e), nullptr) << e;
      EXPECT_EQ(extra(c, e)->values, extra(in, e)->values) << name << " " << e;
    }
  }
}

TEST_F(LasE57Test, LasReadAndWrittenAgainIsTheSameFile) {
  write_cloud(path("a.las"), terrain(1000));
  const Cloud c = read_cloud(path("a.las"));
  write_cloud(path("b.las"), c);
  EXPECT_EQ(bytes("a.las"), bytes("b.las"));
  // LAZ -> LAZ and LAS -> LAZ -> LAS keep the records too.
  write_cloud(path("c.laz"), c);
  write_cloud(path("d.las"), read_cloud(path("c.laz")));
  EXPECT_EQ(bytes("a.las"), bytes("d.las"));
}

TEST_F(LasE57Test, MovedPointIsRequantizedOthersKept) {
  write_cloud(path("a.las"), terrain(500));
  Cloud c = read_cloud(path("a.las"));
  const Points before = c.points;
  c.points(3, 0) += 1.0;
  write_cloud(path("b.las"), c);
  Cloud d = read_cloud(path("b.las"));
  EXPECT_NEAR(d.points(3, 0), before(3, 0) + 1.0, 1e-8);
  d.points.row(3) = before.row(3);
  EXPECT_EQ((d.points - before).cwiseAbs().maxCoeff(), 0.0);
}

TEST_F(LasE57Test, MalformedLasIsAnInputErrorNamingTheFile) {
  Cloud in = terrain(200);
  in.normals.resize(0, 3);
  in.extras.clear();
  write_cloud(path("ok.las"), in);
  const std::string ok = bytes("ok.las");
  put("trunc.las", ok.substr(0, ok.size() - 7));
  EXPECT_NE(read_error("trunc.las").find("truncated?"), std::string::npos);
  put("head.las", ok.substr(0, 100));
  EXPECT_NE(read_error("head.las").find("truncated LAS header"), std::string::npos);
  std::string lie = ok;
  const uint64_t huge = uint64_t(1) << 40;
  std::memcpy(&lie[247], &huge, 8);
  put("lie.las", lie);
  EXPECT_NE(read_error("lie.las").find("header declares 1099511627776 points"), std::string::npos);
  std::string fmt = ok;
  fmt[104] = 11;
  put("fmt.las", fmt);
  const std::string msg = read_error("fmt.las");
  EXPECT_NE(msg.find("unknown LAS point format 11"), std::string::npos) << msg;
  EXPECT_NE(msg.find(path("fmt.las")), std::string::npos) << msg;
  write_cloud(path("ok.laz"), in);
  const std::string laz = bytes("ok.laz");
  put("trunc.laz", laz.substr(0, laz.size() / 2));
  EXPECT_NE(read_error("trunc.laz").find("LAZ"), std::string::npos);
}

TEST_F(LasE57Test, E57SensorsPosesAndSensorIndexRoundTrip) {
  Cloud in = terrain(600, 0, 0);
  in.extras.resize(1);  // intensity only
  for (int k = 0; k < 2; ++k) {
    Sensor s;
    s.position = Eigen::Vector3d(10.0 * k, -3.0, 1.5);
    s.rotation =
        Eigen::AngleAxisd(0.7 + k, Eigen::Vector3d(0.3, 0.2, 1).normalized()).toRotationMatrix();
    s.source = "scan " + std::to_string(k);
    in.sensors.push_back(s);
  }
  for (int i = 0; i < 600; ++i) in.sensor_index.push_back(i < 250 ? 0 : 1);
  write_cloud(path("a.e57"), in);
  const Cloud c = read_cloud(path("a.e57"));
  ASSERT_EQ(c.size(), 600);
  ASSERT_EQ(c.sensors.size(), 2u);
  EXPECT_EQ(c.sensor_index, in.sensor_index);  // written scan by scan, in point order here
  EXPECT_FALSE(c.airborne);
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_LT((c.sensors[k].position - in.sensors[k].position).norm(), 1e-12);
    EXPECT_LT((c.sensors[k].rotation - in.sensors[k].rotation).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_EQ(c.sensors[k].source, "E57 scan 'scan " + std::to_string(k) + "'");
  }
  // Points go to the scan frame and back: double rounding of two rotations only.
  EXPECT_LT((c.points - in.points).cwiseAbs().maxCoeff(), 1e-9);
  ASSERT_TRUE(c.has_normals());
  EXPECT_LT((c.normals - in.normals).cwiseAbs().maxCoeff(), 1e-6);  // stored as float32
  ASSERT_NE(extra(c, "intensity"), nullptr);
  EXPECT_EQ(extra(c, "intensity")->values, in.extras[0].values);
}

TEST_F(LasE57Test, E57WriterRefusesANonRotationAndReaderATruncatedFile) {
  Cloud in = terrain(50, 0, 0);
  in.sensors.resize(1);
  in.sensors[0].rotation(0, 0) = 2.0;
  EXPECT_THROW(write_cloud(path("bad.e57"), in), OutputError);
  EXPECT_FALSE(fs::exists(path("bad.e57")));
  in.sensors.clear();
  write_cloud(path("ok.e57"), in);
  const std::string ok = bytes("ok.e57");
  put("trunc.e57", ok.substr(0, ok.size() / 2));
  const std::string msg = read_error("trunc.e57");
  EXPECT_NE(msg.find("E57"), std::string::npos) << msg;
  EXPECT_NE(msg.find(path("trunc.e57")), std::string::npos) << msg;
}

}  // namespace
