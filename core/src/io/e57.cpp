// E57 reader and writer through the e57 crate (core/rust, formats_ffi.hpp).
//
// Reader: every scan of the file (cartesian or spherical coordinates; points whose invalid-state
// flag is set are dropped with a warning), each moved into the file's frame by its pose; one
// Sensor per scan (position = pose translation, rotation from the quaternion) and each point's
// scan in sensor_index. Intensity and colour become extras, the normals of the E57 "nor"
// extension (normalX/Y/Z) the input normals. A pose whose quaternion is not a rotation is an
// InputError.
// Writer: one scan per sensor (its points put back into the sensor's frame, the pose written),
// else one scan; intensity and red/green/blue extras, the normals as the "nor" extension, the
// normals' confidence (Cloud::confidence) as the field "confidence" of the "nhnet" extension.
#include "io/detail.hpp"
#include "io/formats_ffi.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <memory>

namespace nhnet::io_detail {
namespace {

/// Largest distance of a pose quaternion's norm from 1 that is still taken for a rotation
/// (writers store 15+ significant digits; anything further off is not a rotation).
constexpr double kQuaternionTolerance = 1e-3;

struct E57Closer {
  void operator()(NhE57File* f) const { nhnet_e57_free(f); }
};

/// The rotation of a scan's pose; InputError naming the scan when it is not one.
Eigen::Matrix3d pose_rotation(const FileBytes& file, const NhE57ScanHead& s,
                              const std::string& name) {
  const Eigen::Quaterniond q(s.quat[0], s.quat[1], s.quat[2], s.quat[3]);
  const double norm = q.norm();
  if (!std::isfinite(norm) || std::fabs(norm - 1) > kQuaternionTolerance)
    input_error(file.path, "E57 scan '" + name + "': pose quaternion (w x y z) = (" +
                               std::to_string(s.quat[0]) + " " + std::to_string(s.quat[1]) + " " +
                               std::to_string(s.quat[2]) + " " + std::to_string(s.quat[3]) +
                               ") is not a rotation (norm " + std::to_string(norm) + ")");
  return q.normalized().toRotationMatrix();
}

/// The extra `name` of `cloud`, made (filled with `fill`) on first use.
ExtraProperty& extra(Cloud& cloud, const std::string& name, ScalarType type, size_t n) {
  for (ExtraProperty& e : cloud.extras)
    if (e.name == name) return e;
  cloud.extras.push_back({name, type, std::vector<double>(n, 0.0)});
  return cloud.extras.back();
}

/// Appends scan `v` (already validated) to `cloud` at rows [first, first + v.head.n).
void add_scan(Cloud& cloud, const NhE57ScanView& v, const Eigen::Matrix3d& r,
              const Eigen::Vector3d& t, Eigen::Index first, bool normals) {
  const NhE57ScanHead& s = v.head;
  const size_t total = size_t(cloud.points.rows());
  for (size_t i = 0; i < s.n; ++i) {
    const Eigen::Index row = first + Eigen::Index(i);
    const Eigen::Vector3d p(s.xyz[3 * i], s.xyz[3 * i + 1], s.xyz[3 * i + 2]);
    cloud.points.row(row) = (r * p + t).transpose();
    if (normals) {
      const Eigen::Vector3d nl(s.normals[3 * i], s.normals[3 * i + 1], s.normals[3 * i + 2]);
      cloud.normals.row(row) = (r * nl).transpose();
    }
    if (s.intensity)
      extra(cloud, "intensity", ScalarType::Float32, total).values[size_t(row)] = s.intensity[i];
    if (v.rgb) {
      const ScalarType type = v.color_max <= 255     ? ScalarType::UInt8
                              : v.color_max <= 65535 ? ScalarType::UInt16
                                                     : ScalarType::Float32;
      const char* names[] = {"red", "green", "blue"};
      for (int k = 0; k < 3; ++k)
        extra(cloud, names[k], type, total).values[size_t(row)] = v.rgb[3 * i + size_t(k)];
    }
  }
}

}  // namespace

Cloud read_e57(const FileBytes& file, std::vector<std::string>* warnings) {
  NhE57File* raw = nullptr;
  char err[512] = {0};
  if (nhnet_e57_read(reinterpret_cast<const uint8_t*>(file.bytes.data()), file.bytes.size(), &raw,
                     err, sizeof(err)) != 0)
    input_error(file.path, std::string("E57: ") + err);
  const std::unique_ptr<NhE57File, E57Closer> owner(raw);
  const size_t scans = nhnet_e57_scan_count(raw);
  if (scans == 0) input_error(file.path, "E57 file has no scans (data3D is empty)");
  std::vector<NhE57ScanView> views(scans);
  size_t total = 0;
  bool normals = true;
  uint64_t dropped = 0;
  for (size_t k = 0; k < scans; ++k) {
    nhnet_e57_scan(raw, k, &views[k]);
    total += views[k].head.n;
    normals = normals && views[k].head.normals;
    dropped += views[k].dropped;
  }
  Cloud cloud;
  cloud.points.resize(Eigen::Index(total), 3);
  if (normals) cloud.normals.resize(Eigen::Index(total), 3);
  cloud.sensor_index.reserve(total);
  Eigen::Index first = 0;
  for (size_t k = 0; k < scans; ++k) {
    const NhE57ScanHead& s = views[k].head;
    const std::string name(reinterpret_cast<const char*>(s.name), s.name_len);
    Sensor sensor;
    sensor.rotation = pose_rotation(file, s, name);
    sensor.position = Eigen::Vector3d(s.trans[0], s.trans[1], s.trans[2]);
    sensor.source = "E57 scan '" + name + "'";
    add_scan(cloud, views[k], sensor.rotation, sensor.position, first, normals);
    cloud.sensors.push_back(std::move(sensor));
    cloud.sensor_index.insert(cloud.sensor_index.end(), s.n, int32_t(k));
    first += Eigen::Index(s.n);
  }
  if (dropped) warn(warnings, std::to_string(dropped) + " E57 points flagged invalid were skipped");
  return cloud;
}

namespace {

/// Points of one scan to write, in the scan's own frame.
struct ScanOut {
  std::string name;
  bool pose = false;
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  std::vector<double> xyz;
  std::vector<float> intensity, normals, confidence;
  std::vector<uint16_t> rgb;
};

/// The scans of `cloud`: one per sensor, or one without a pose.
std::vector<ScanOut> split_scans(const std::string& path, const Cloud& cloud) {
  std::vector<ScanOut> scans(std::max<size_t>(cloud.sensors.size(), 1));
  for (size_t k = 0; k < cloud.sensors.size(); ++k) {
    const Sensor& s = cloud.sensors[k];
    const Eigen::Matrix3d& r = s.rotation;
    if (!r.allFinite() || !(r.transpose() * r).isApprox(Eigen::Matrix3d::Identity(), 1e-6) ||
        r.determinant() < 0)
      output_error(path, "sensor " + std::to_string(k) + " (" + s.source +
                             "): its rotation is not a rotation matrix");
    scans[k].pose = true;
    scans[k].q = Eigen::Quaterniond(r).normalized();
    scans[k].t = s.position;
    scans[k].name = s.source.empty() ? "scan " + std::to_string(k) : s.source;
  }
  if (cloud.sensors.empty()) scans[0].name = "nhnet";
  if (!cloud.sensor_index.empty() && cloud.sensor_index.size() != size_t(cloud.size()))
    output_error(path, "sensor_index has " + std::to_string(cloud.sensor_index.size()) +
                           " entries for " + std::to_string(cloud.size()) + " points");
  return scans;
}

const ExtraProperty* find(const Cloud& cloud, const char* name) {
  for (const ExtraProperty& e : cloud.extras)
    if (e.name == name) return &e;
  return nullptr;
}

/// Fills the scans' arrays with the points of `cloud`.
void fill_scans(const std::string& path, const Cloud& cloud, std::vector<ScanOut>& scans) {
  const ExtraProperty* intensity = find(cloud, "intensity");
  const ExtraProperty* rgb[3] = {find(cloud, "red"), find(cloud, "green"), find(cloud, "blue")};
  const bool color = rgb[0] && rgb[1] && rgb[2];
  for (Eigen::Index i = 0; i < cloud.size(); ++i) {
    const int32_t k = cloud.sensor_index.empty() ? 0 : cloud.sensor_index[size_t(i)];
    if (k < 0 || size_t(k) >= scans.size())
      output_error(path, "point " + std::to_string(i) + " has sensor index " + std::to_string(k) +
                             ", the cloud has " + std::to_string(cloud.sensors.size()) +
                             " sensors");
    ScanOut& s = scans[size_t(k)];
    const Eigen::Matrix3d rt = s.q.toRotationMatrix().transpose();
    const Eigen::Vector3d p = rt * (cloud.points.row(i).transpose() - s.t);
    s.xyz.insert(s.xyz.end(), {p.x(), p.y(), p.z()});
    if (cloud.has_normals()) {
      const Eigen::Vector3d n = rt * cloud.normals.row(i).transpose();
      s.normals.insert(s.normals.end(), {float(n.x()), float(n.y()), float(n.z())});
    }
    if (cloud.confidence.size() != 0) s.confidence.push_back(float(cloud.confidence[i]));
    if (intensity) s.intensity.push_back(float(intensity->values[size_t(i)]));
    for (int c = 0; c < 3 && color; ++c)
      s.rgb.push_back(uint16_t(std::clamp(rgb[c]->values[size_t(i)], 0.0, 65535.0)));
  }
}

}  // namespace

void write_e57(Sink& sink, const Cloud& cloud, const std::string& path) {
  std::vector<ScanOut> scans = split_scans(path, cloud);
  fill_scans(path, cloud, scans);
  int64_t rgb_max = 255;
  for (const ScanOut& s : scans)
    for (uint16_t v : s.rgb) rgb_max = v > 255 ? 65535 : rgb_max;
  std::vector<NhE57ScanIn> in;
  for (const ScanOut& s : scans) {
    NhE57ScanIn v{};
    NhE57ScanHead& h = v.head;
    h.name = reinterpret_cast<const uint8_t*>(s.name.data());
    h.name_len = s.name.size();
    h.has_pose = s.pose ? 1 : 0;
    const double quat[4] = {s.q.w(), s.q.x(), s.q.y(), s.q.z()};
    std::copy(quat, quat + 4, h.quat);
    std::copy(s.t.data(), s.t.data() + 3, h.trans);
    h.n = s.xyz.size() / 3;
    h.xyz = s.xyz.data();
    h.intensity = s.intensity.empty() ? nullptr : s.intensity.data();
    v.rgb = s.rgb.empty() ? nullptr : s.rgb.data();
    v.rgb_max = rgb_max;
    h.normals = cloud.has_normals() ? s.normals.data() : nullptr;
    v.confidence = cloud.confidence.size() != 0 ? s.confidence.data() : nullptr;
    in.push_back(v);
  }
  RustBuf out;
  char err[512] = {0};
  if (nhnet_e57_write(in.data(), in.size(), &out.buf, err, sizeof(err)) != 0)
    output_error(path, std::string("E57: ") + err);
  sink.write(reinterpret_cast<const char*>(out.buf.ptr), out.buf.len);
}

}  // namespace nhnet::io_detail
