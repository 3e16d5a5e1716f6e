// The default orientation (orient/auto.hpp) and the modes it resolves to beyond orient.cpp's:
// sensors (each point towards its own sensor), up (airborne: +z where not vertical, the walls by
// the MST seeded there), resolve_orientation's rule, and the sensor the PCD / PLY readers and
// writers keep.
#include "fixtures.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/io/io.hpp"
#include "nhnet/orient/auto.hpp"
#include "nhnet/orient/orient.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <unistd.h>

using namespace nhnet;
namespace fs = std::filesystem;

namespace {

/// A flat ground [-4, 4]^2 at z = 0 with a box building [-1, 1]^2 x [0, 1.5] on it: roof and
/// ground face +z, the walls outward; about one point per 0.05 x 0.05.
fixtures::Fixture town(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  fixtures::Fixture f;
  std::vector<Eigen::Vector3d> p, n;
  const double h = 0.05;
  for (double x = -4; x <= 4; x += h)
    for (double y = -4; y <= 4; y += h) {
      const Eigen::Vector3d q(x + h * u(rng) * 0.3, y + h * u(rng) * 0.3, 0);
      if (std::abs(q.x()) <= 1 && std::abs(q.y()) <= 1) {
        p.emplace_back(q.x(), q.y(), 1.5);  // roof
      } else {
        p.push_back(q);
      }
      n.emplace_back(0, 0, 1);
    }
  for (double s = -1 + h / 2; s < 1; s += h)  // four walls, corners not sampled twice
    for (double z = h; z < 1.5; z += h)
      for (int w = 0; w < 4; ++w) {
        const double side = w % 2 ? 1.0 : -1.0;
        const bool x_wall = w < 2;
        p.emplace_back(x_wall ? side : s, x_wall ? s : side, z);
        n.emplace_back(x_wall ? side : 0, x_wall ? 0 : side, 0);
      }
  f.points.resize(Eigen::Index(p.size()), 3);
  f.normals.resize(Eigen::Index(p.size()), 3);
  for (size_t i = 0; i < p.size(); ++i) {
    f.points.row(Eigen::Index(i)) = p[i].transpose();
    f.normals.row(Eigen::Index(i)) = n[i].transpose();
  }
  return f;
}

fs::path temp_file(const std::string& name) {
  return fs::temp_directory_path() / ("nhnet_orient_auto_" + std::to_string(::getpid()) + name);
}

}  // namespace

TEST(OrientSensors, EachPointFacesItsOwnSensor) {
  const fixtures::Fixture f = fixtures::sphere(3000, 1);
  Normals n = fixtures::random_signs(f.normals, 2);
  OrientOptions o;
  o.mode = OrientMode::Sensors;
  o.sensors = {Eigen::Vector3d(3, 0, 0), Eigen::Vector3d(-3, 0.5, 0)};
  for (Eigen::Index i = 0; i < f.points.rows(); ++i)
    o.sensor_index.push_back(f.points(i, 0) > 0 ? 0 : 1);
  const OrientResult r = orient_normals(f.points, n, o);
  EXPECT_EQ(r.unoriented, 0);
  for (Eigen::Index i = 0; i < f.points.rows(); ++i) {
    const Eigen::Vector3d s = o.sensors[size_t(o.sensor_index[size_t(i)])];
    ASSERT_GT((s.transpose() - f.points.row(i)).dot(n.row(i)), 0) << "row " << i;
  }
}

TEST(OrientSensors, BadSensorsAreRefused) {
  const fixtures::Fixture f = fixtures::sphere(100, 1);
  Normals n = f.normals;
  OrientOptions o;
  o.mode = OrientMode::Sensors;
  EXPECT_THROW(orient_normals(f.points, n, o), InvalidOptions);  // no sensor
  o.sensors = {Eigen::Vector3d::Zero()};
  o.sensor_index.assign(100, 1);  // out of range
  EXPECT_THROW(orient_normals(f.points, n, o), InvalidOptions);
  o.sensor_index.assign(99, 0);  // one short
  EXPECT_THROW(orient_normals(f.points, n, o), InvalidOptions);
  o.mode = OrientMode::Auto;  // must be resolved first
  EXPECT_THROW(orient_normals(f.points, n, o), InvalidOptions);
}

TEST(OrientUp, RoofsAndGroundUpWallsOutward) {
  const fixtures::Fixture f = town(3);
  Normals n = fixtures::random_signs(f.normals, 4);
  OrientOptions o;
  o.mode = OrientMode::Up;
  orient_normals(f.points, n, o);
  int64_t walls = 0, walls_out = 0;
  for (Eigen::Index i = 0; i < n.rows(); ++i) {
    if (f.normals(i, 2) > 0.5) {
      ASSERT_GT(n(i, 2), 0) << "row " << i;  // the rule itself: exact
    } else {
      ++walls;
      walls_out += n.row(i).dot(f.normals.row(i)) > 0;
    }
  }
  // The walls take their sign from the tree grown from the roof and the ground; exact normals
  // on a clean box: every wall point must come out outward (the reflection criterion carries
  // the sign over the 90-degree edges).
  ASSERT_GT(walls, 1000);
  EXPECT_EQ(walls_out, walls);
}

TEST(OrientAuto, ResolvesFromWhatTheCloudCarries) {
  Cloud c;
  c.points = fixtures::sphere(200, 1).points;
  OrientOptions req;
  req.mode = OrientMode::Auto;
  req.k = 7;
  OrientPlan p = resolve_orientation(c, req);
  EXPECT_EQ(p.options.mode, OrientMode::Mst);
  EXPECT_EQ(p.options.k, 7);  // the other options are kept
  EXPECT_EQ(p.source, "no sensor in the file: MST");
  c.airborne = true;
  EXPECT_EQ(resolve_orientation(c, req).options.mode, OrientMode::Up);
  c.grid_width = 20;
  c.grid_height = 10;
  p = resolve_orientation(c, req);
  EXPECT_EQ(p.options.mode, OrientMode::Viewpoint);
  EXPECT_TRUE(p.options.viewpoint.isZero(0));
  c.sensors.push_back(Sensor{Eigen::Vector3d(1, 2, 3), Eigen::Matrix3d::Identity(), "test"});
  p = resolve_orientation(c, req);
  EXPECT_EQ(p.options.mode, OrientMode::Viewpoint);
  EXPECT_EQ(p.options.viewpoint, Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(p.source, "sensor from test at (1, 2, 3)");
  c.sensors.push_back(Sensor{Eigen::Vector3d(-1, 0, 0), Eigen::Matrix3d::Identity(), "two"});
  c.sensor_index.assign(200, 0);
  c.sensor_index[5] = 1;
  p = resolve_orientation(c, req);
  EXPECT_EQ(p.options.mode, OrientMode::Sensors);
  EXPECT_EQ(p.options.sensors.size(), 2u);
  c.sensor_index[6] = 2;  // no such sensor
  EXPECT_THROW(resolve_orientation(c, req), InvalidOptions);
  c.normals = c.points;
  EXPECT_EQ(resolve_orientation(c, req).options.mode, OrientMode::Keep);
  req.mode = OrientMode::None;  // an explicit mode stays
  EXPECT_EQ(resolve_orientation(c, req).options.mode, OrientMode::None);
}

TEST(OrientAuto, PcdAndPlyKeepTheSensorAndGrid) {
  Cloud c;
  c.points = fixtures::sphere(12, 1).points;
  c.grid_width = 4;
  c.grid_height = 3;
  Sensor s;
  s.position = Eigen::Vector3d(0.5, -2, 3);
  const double a = 0.7;  // a turn about z
  s.rotation << std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1;
  c.sensors.push_back(s);
  for (const char* ext : {".pcd", ".ply"}) {
    const fs::path path = temp_file(ext);
    write_cloud(path.string(), c);
    const Cloud r = read_cloud(path.string());
    fs::remove(path);
    ASSERT_EQ(r.sensors.size(), 1u) << ext;
    EXPECT_TRUE(r.sensors[0].position.isApprox(s.position, 1e-6)) << ext;
    EXPECT_TRUE(r.sensors[0].rotation.isApprox(s.rotation, 1e-6)) << ext;
    EXPECT_EQ(r.grid_width, 4);
    EXPECT_EQ(r.grid_height, 3);
  }
}

TEST(OrientAuto, DefaultViewpointCountsOnlyOnAnOrganizedCloud) {
  const fixtures::Fixture f = fixtures::sphere(12, 1);
  const fs::path path = temp_file(".pcd");
  for (const int height : {1, 3}) {
    std::ofstream(path) << "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                        << "WIDTH " << 12 / height << "\nHEIGHT " << height
                        << "\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 12\nDATA ascii\n"
                        << f.points.format(Eigen::IOFormat(8, 0, " ", "\n")) << "\n";
    const Cloud r = read_cloud(path.string());
    EXPECT_EQ(r.sensors.size(), height > 1 ? 1u : 0u) << "HEIGHT " << height;
    EXPECT_EQ(r.organized(), height > 1);
  }
  std::ofstream(path) << "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                      << "WIDTH 1\nHEIGHT 1\nVIEWPOINT 0 0 0 nan 0 0 0\nPOINTS 1\nDATA ascii\n"
                      << "1 2 3\n";
  try {
    read_cloud(path.string());
    ADD_FAILURE() << "a NaN quaternion was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("not a rotation"), std::string::npos) << e.what();
  }
  fs::remove(path);
}
