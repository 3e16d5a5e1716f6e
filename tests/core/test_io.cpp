// Point cloud io: round trips for every format and PLY encoding, hand-built big-endian PLY and
// LZF-compressed PCD, and the bad-input rows of the reliability matrix (one-line InputError
// naming the file and the problem), plus atomic-write failure behaviour.
#include "fixtures.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/io/io.hpp"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <functional>

#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>

using namespace nhnet;
namespace fs = std::filesystem;

namespace {

/// A fresh directory under the system temp dir, removed afterwards.
class IoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::random_device rd;
    dir_ = fs::temp_directory_path() /
           ("nhnet_io_test_" + std::to_string(::getpid()) + "_" + std::to_string(rd()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::permissions(dir_, fs::perms::owner_all, fs::perm_options::add, ec);
    fs::remove_all(dir_, ec);
  }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  /// Writes raw bytes to `name` and returns its path.
  std::string put(const std::string& name, const std::string& bytes) const {
    const std::string p = path(name);
    std::ofstream out(p, std::ios::binary);
    out.write(bytes.data(), std::streamsize(bytes.size()));
    return p;
  }

  /// Names of the files in the directory.
  std::vector<std::string> listing() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir_))
      names.push_back(e.path().filename().string());
    return names;
  }

  fs::path dir_;
};

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Bit-exact equality of doubles (NaN equal to NaN of the same bits).
bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; }

/// Equality treating NaN == NaN.
bool same_value(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

void expect_same_points(const Points& a, const Points& b) {
  ASSERT_EQ(a.rows(), b.rows());
  for (Eigen::Index i = 0; i < a.size(); ++i)
    ASSERT_TRUE(same_value(a.data()[i], b.data()[i]))
        << "index " << i << ": " << a.data()[i] << " vs " << b.data()[i];
}

/// A cloud of n points with float-exact or full-double coordinates, unit normals, some NaNs.
Cloud make_cloud(int n, bool double_coords, bool normals) {
  const auto f = fixtures::sphere(n, 3);
  Cloud c;
  c.points = f.points * 12.5;
  if (!double_coords)
    for (Eigen::Index i = 0; i < c.points.size(); ++i)
      c.points.data()[i] = double(float(c.points.data()[i]));
  else
    c.points(0, 0) = 0.1;  // not a float
  if (normals) {
    c.normals = f.normals;
    for (Eigen::Index i = 0; i < c.normals.size(); ++i)
      c.normals.data()[i] = double(float(c.normals.data()[i]));
    c.normals.row(1).setConstant(std::numeric_limits<double>::quiet_NaN());
  }
  return c;
}

/// Adds uchar red/green/blue and float intensity extras.
void add_colour_extras(Cloud& c) {
  const char* rgb[3] = {"red", "green", "blue"};
  for (int k = 0; k < 3; ++k) {
    ExtraProperty e{rgb[k], ScalarType::UInt8, {}};
    for (Eigen::Index i = 0; i < c.size(); ++i) e.values.push_back(double((i * 37 + k * 11) % 256));
    c.extras.push_back(e);
  }
  ExtraProperty intensity{"intensity", ScalarType::Float32, {}};
  for (Eigen::Index i = 0; i < c.size(); ++i) intensity.values.push_back(double(float(i) * 0.25f));
  c.extras.push_back(intensity);
}

void expect_same_extras(const Cloud& a, const Cloud& b) {
  ASSERT_EQ(a.extras.size(), b.extras.size());
  for (size_t k = 0; k < a.extras.size(); ++k) {
    EXPECT_EQ(a.extras[k].name, b.extras[k].name);
    EXPECT_EQ(a.extras[k].type, b.extras[k].type) << a.extras[k].name;
    ASSERT_EQ(a.extras[k].values.size(), b.extras[k].values.size());
    for (size_t i = 0; i < a.extras[k].values.size(); ++i)
      ASSERT_TRUE(same_value(a.extras[k].values[i], b.extras[k].values[i])) << a.extras[k].name;
  }
}

/// Asserts that reading `path` throws one InputError line naming the file and `keyword`.
void expect_input_error(const std::string& path, const std::string& keyword) {
  try {
    read_cloud(path);
    ADD_FAILURE() << "no InputError for " << path << " (expected '" << keyword << "')";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(fs::path(path).filename().string()), std::string::npos) << msg;
    EXPECT_NE(msg.find(keyword), std::string::npos) << "missing '" << keyword << "' in: " << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "wrong exception type for " << path << ": " << e.what();
  }
}

/// Big-endian bytes of a value.
template <typename T>
std::string be(T v) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  std::string s(sizeof(T), '\0');
  const uint16_t probe = 1;
  const bool little = *reinterpret_cast<const unsigned char*>(&probe) == 1;
  for (size_t i = 0; i < sizeof(T); ++i) s[i] = char(b[little ? sizeof(T) - 1 - i : i]);
  return s;
}

/// Little-endian bytes of a value.
template <typename T>
std::string le(T v) {
  std::string s = be(v);
  return std::string(s.rbegin(), s.rend());
}

/// LZF stream of literal runs only (valid LZF input).
std::string lzf_literals(const std::string& raw) {
  std::string out;
  for (size_t i = 0; i < raw.size(); i += 32) {
    const size_t n = std::min<size_t>(32, raw.size() - i);
    out += char(n - 1);
    out += raw.substr(i, n);
  }
  return out;
}

/// LZF stream for `count` copies of one byte: a literal, then overlapping back references.
std::string lzf_repeat(char byte, size_t count) {
  std::string out;
  out += char(0);
  out += byte;
  size_t left = count - 1;
  while (left > 0) {
    const size_t len = std::min<size_t>(left, 264);
    if (len < 3) {  // too short for a back reference
      out += char(len - 1);
      out += std::string(len, byte);
      break;
    }
    if (len - 2 < 7) {
      out += char((len - 2) << 5);
    } else {
      out += char(7 << 5);
      out += char(len - 2 - 7);
    }
    out += char(0);  // distance 1
    left -= len;
  }
  return out;
}

const char* kPlyHeaderStart = "ply\nformat ascii 1.0\n";

}  // namespace

// ---------------------------------------------------------------------------------------------
// format_from_extension

TEST(IoFormat, FromExtension) {
  EXPECT_EQ(format_from_extension("a.ply"), FileFormat::Ply);
  EXPECT_EQ(format_from_extension("dir/A.PLY"), FileFormat::Ply);
  EXPECT_EQ(format_from_extension("a.pcd"), FileFormat::Pcd);
  for (const char* p : {"a.xyz", "a.xyzn", "a.txt", "b/a.pts"})
    EXPECT_EQ(format_from_extension(p), FileFormat::Xyz) << p;
  EXPECT_EQ(format_from_extension("a.obj"), FileFormat::Auto);
  EXPECT_EQ(format_from_extension("noext"), FileFormat::Auto);
}

// ---------------------------------------------------------------------------------------------
// Round trips

TEST_F(IoTest, RoundTripEveryFormatBitExact) {
  struct Case {
    const char* name;
    WriteOptions options;
  };
  const Case cases[] = {{"rt.ply", {}}, {"rt_ascii.ply", {FileFormat::Auto, true}},
                        {"rt.pcd", {}}, {"rt_ascii.pcd", {FileFormat::Auto, true}},
                        {"rt.xyz", {}}, {"rt.dat", {FileFormat::Ply, false}}};
  for (const bool double_coords : {false, true}) {
    const Cloud in = make_cloud(500, double_coords, true);
    for (const Case& c : cases) {
      SCOPED_TRACE(std::string(c.name) + (double_coords ? " double" : " float"));
      write_cloud(path(c.name), in, c.options);
      ReadOptions ro;
      ro.format = c.options.format;
      const Cloud out = read_cloud(path(c.name), ro);
      expect_same_points(in.points, out.points);
      ASSERT_TRUE(out.has_normals());
      expect_same_points(in.normals, out.normals);
      for (Eigen::Index i = 0; i < in.points.size(); ++i)
        ASSERT_TRUE(same_bits(in.points.data()[i], out.points.data()[i]));
    }
  }
}

TEST_F(IoTest, PlyCoordinateTypeFollowsPrecision) {
  write_cloud(path("f.ply"), make_cloud(10, false, false), {FileFormat::Auto, true});
  write_cloud(path("d.ply"), make_cloud(10, true, false), {FileFormat::Auto, true});
  EXPECT_NE(slurp(path("f.ply")).find("property float x"), std::string::npos);
  EXPECT_NE(slurp(path("d.ply")).find("property double x"), std::string::npos);
  const Cloud d = read_cloud(path("d.ply"));
  EXPECT_EQ(d.points(0, 0), 0.1);
  EXPECT_FALSE(d.has_normals());
}

TEST_F(IoTest, ExtrasSurvivePlyAndPcdRoundTrips) {
  Cloud in = make_cloud(300, false, true);
  add_colour_extras(in);
  for (const char* name : {"e.ply", "e.pcd"}) {
    for (const bool ascii : {false, true}) {
      SCOPED_TRACE(std::string(name) + (ascii ? " ascii" : " binary"));
      write_cloud(path(name), in, {FileFormat::Auto, ascii});
      const Cloud once = read_cloud(path(name));
      expect_same_extras(in, once);
      // read -> write -> read again
      write_cloud(path(std::string("again_") + name), once, {FileFormat::Auto, ascii});
      const Cloud twice = read_cloud(path(std::string("again_") + name));
      expect_same_points(in.points, twice.points);
      expect_same_extras(in, twice);
    }
  }
  EXPECT_NE(slurp(path("e.ply")).find("property uchar red"), std::string::npos);
}

TEST_F(IoTest, EmptyCloudRoundTrips) {
  Cloud empty;
  write_cloud(path("empty.ply"), empty);
  write_cloud(path("empty.pcd"), empty);
  EXPECT_EQ(read_cloud(path("empty.ply")).size(), 0);
  EXPECT_EQ(read_cloud(path("empty.pcd")).size(), 0);
}

// ---------------------------------------------------------------------------------------------
// PLY specifics

TEST_F(IoTest, PlyBigEndianHandBuilt) {
  // vertex: short a, float x, double y, float z, uchar red, int count; face: list uint int
  std::string b =
      "ply\nformat binary_big_endian 1.0\ncomment hand built\nelement vertex 2\n"
      "property short a\nproperty float x\nproperty double y\nproperty float32 z\n"
      "property uchar red\nproperty int32 count\n"
      "element face 1\nproperty list uint int vertex_indices\nend_header\n";
  b += be<int16_t>(-300) + be<float>(1.5f) + be<double>(0.1) + be<float>(-2.25f) + char(200) +
       be<int32_t>(-70000);
  b += be<int16_t>(7) + be<float>(1e30f) + be<double>(-1e-300) + be<float>(3.0f) + char(0) +
       be<int32_t>(123456789);
  b += be<uint32_t>(3) + be<int32_t>(0) + be<int32_t>(1) + be<int32_t>(1);
  std::vector<std::string> warnings;
  const Cloud c = read_cloud(put("be.ply", b), {}, &warnings);
  ASSERT_EQ(c.size(), 2);
  EXPECT_EQ(c.points(0, 0), 1.5);
  EXPECT_EQ(c.points(0, 1), 0.1);
  EXPECT_EQ(c.points(0, 2), -2.25);
  EXPECT_EQ(c.points(1, 0), double(1e30f));
  EXPECT_EQ(c.points(1, 1), -1e-300);
  EXPECT_EQ(c.points(1, 2), 3.0);
  ASSERT_EQ(c.extras.size(), 3u);
  EXPECT_EQ(c.extras[0].name, "a");
  EXPECT_EQ(c.extras[0].type, ScalarType::Int16);
  EXPECT_EQ(c.extras[0].values, (std::vector<double>{-300, 7}));
  EXPECT_EQ(c.extras[1].name, "red");
  EXPECT_EQ(c.extras[1].type, ScalarType::UInt8);
  EXPECT_EQ(c.extras[1].values, (std::vector<double>{200, 0}));
  EXPECT_EQ(c.extras[2].type, ScalarType::Int32);
  EXPECT_EQ(c.extras[2].values, (std::vector<double>{-70000, 123456789}));
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], "face element (1 faces) not carried to the output");
}

TEST_F(IoTest, PlyBigEndianRoundTripThroughTestWriter) {
  // Serialise a cloud as big-endian PLY here and compare with the little-endian write.
  Cloud in = make_cloud(200, true, true);
  std::string b =
      "ply\nformat binary_big_endian 1.0\nelement vertex 200\n"
      "property double x\nproperty double y\nproperty double z\n"
      "property float nx\nproperty float ny\nproperty float nz\nend_header\n";
  for (Eigen::Index i = 0; i < in.size(); ++i) {
    for (int k = 0; k < 3; ++k) b += be<double>(in.points(i, k));
    for (int k = 0; k < 3; ++k) b += be<float>(float(in.normals(i, k)));
  }
  const Cloud out = read_cloud(put("rt_be.ply", b));
  expect_same_points(in.points, out.points);
  expect_same_points(in.normals, out.normals);
}

TEST_F(IoTest, PlyFaceElementSkippedWithWarning) {
  // binary little endian with a face list after the vertices, then an edge element
  std::string b =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
      "property float y\nproperty float z\nelement face 2\nproperty uchar flags\n"
      "property list uchar int vertex_indices\nelement edge 1\nproperty int v1\nproperty int v2\n"
      "end_header\n";
  for (int i = 0; i < 9; ++i) b += le<float>(float(i));
  b += char(1) + std::string(1, char(3)) + le<int32_t>(0) + le<int32_t>(1) + le<int32_t>(2);
  b += char(0) + std::string(1, char(0));  // empty list
  b += le<int32_t>(0) + le<int32_t>(2);
  std::vector<std::string> warnings;
  const Cloud c = read_cloud(put("faces.ply", b), {}, &warnings);
  ASSERT_EQ(c.size(), 3);
  EXPECT_EQ(c.points(2, 2), 8.0);
  EXPECT_TRUE(c.extras.empty());
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_EQ(warnings[0], "face element (2 faces) not carried to the output");
  EXPECT_EQ(warnings[1], "edge element (1 edges) not carried to the output");

  // the same in ascii, faces before vertices, plus a list property on the vertex element
  const std::string a =
      "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar uint vertex_indices\n"
      "element vertex 2\nproperty float x\nproperty list uchar float extra\nproperty float y\n"
      "property float z\nend_header\n3 0 1 1\n1 2 0.5 0.25 2 3\n4 0 5 6\n";
  warnings.clear();
  const Cloud d = read_cloud(put("faces_ascii.ply", a), {}, &warnings);
  ASSERT_EQ(d.size(), 2);
  EXPECT_EQ(d.points.row(0), Eigen::RowVector3d(1, 2, 3).eval().row(0));
  EXPECT_EQ(d.points.row(1), Eigen::RowVector3d(4, 5, 6).eval().row(0));
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_NE(warnings[0].find("list property 'extra'"), std::string::npos);
  EXPECT_EQ(warnings[1], "face element (1 faces) not carried to the output");
}

TEST_F(IoTest, PlyCrlfHeaderCommentsAndEmptyFaceElement) {
  const std::string a =
      "ply\r\nformat ascii 1.0\r\ncomment\r\ncomment made by hand\r\nobj_info scanner 3\r\n"
      "element vertex 2\r\nproperty float x\r\nproperty float y\r\nproperty float z\r\n"
      "property float nx\r\nproperty float ny\r\nproperty float nz\r\nproperty float curvature\r\n"
      "element face 0\r\nproperty list uchar int vertex_indices\r\nend_header\r\n"
      "1 2 3 0 0 1 0.5\r\n-1 nan inf 1 0 0 0.25\r\n";
  std::vector<std::string> warnings;
  const Cloud c = read_cloud(put("crlf.ply", a), {}, &warnings);
  ASSERT_EQ(c.size(), 2);
  EXPECT_TRUE(c.has_normals());
  EXPECT_TRUE(std::isnan(c.points(1, 1)));
  EXPECT_TRUE(std::isinf(c.points(1, 2)));
  EXPECT_EQ(c.normals(0, 2), 1.0);
  ASSERT_EQ(c.extras.size(), 1u);
  EXPECT_EQ(c.extras[0].name, "curvature");
  EXPECT_TRUE(warnings.empty());

  // binary body after a CRLF header, including a first data byte of '\n'
  std::string b =
      "ply\r\nformat binary_little_endian 1.0\r\nelement vertex 1\r\nproperty uchar q\r\n"
      "property float x\r\nproperty float y\r\nproperty float z\r\nend_header\r\n";
  b += char('\n') + le<float>(1) + le<float>(2) + le<float>(3);
  const Cloud d = read_cloud(put("crlf_bin.ply", b));
  ASSERT_EQ(d.size(), 1);
  EXPECT_EQ(d.extras[0].values[0], 10.0);
  EXPECT_EQ(d.points(0, 2), 3.0);
}

TEST_F(IoTest, PlyPartialNormalsAreExtras) {
  const std::string a = std::string(kPlyHeaderStart) +
                        "element vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                        "property float nx\nend_header\n1 2 3 4\n";
  const Cloud c = read_cloud(put("nx.ply", a));
  EXPECT_FALSE(c.has_normals());
  ASSERT_EQ(c.extras.size(), 1u);
  EXPECT_EQ(c.extras[0].name, "nx");
}

// ---------------------------------------------------------------------------------------------
// PCD specifics

TEST_F(IoTest, PcdBinaryCompressedHandBuilt) {
  const int n = 40;
  // structure of arrays: x (float), y (float), z (float, all zero), intensity (uchar), _ pad
  std::string xs, ys, zs, is, pads;
  for (int i = 0; i < n; ++i) {
    xs += le<float>(float(i) * 0.5f);
    ys += le<float>(-float(i));
    zs += le<float>(0.0f);
    is += char(i * 3);
    pads += std::string(2, 'p');
  }
  const std::string raw = xs + ys + zs + is + pads;
  const std::string stream =
      lzf_literals(xs + ys) + lzf_repeat('\0', zs.size()) + lzf_literals(is + pads);
  std::string b =
      "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z intensity _\n"
      "SIZE 4 4 4 1 1\nTYPE F F F U U\nCOUNT 1 1 1 1 2\nWIDTH 40\nHEIGHT 1\n"
      "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 40\nDATA binary_compressed\n";
  b += le<uint32_t>(uint32_t(stream.size())) + le<uint32_t>(uint32_t(raw.size())) + stream;
  const Cloud c = read_cloud(put("c.pcd", b));
  ASSERT_EQ(c.size(), n);
  for (int i = 0; i < n; ++i) {
    EXPECT_EQ(c.points(i, 0), i * 0.5);
    EXPECT_EQ(c.points(i, 1), -i);
    EXPECT_EQ(c.points(i, 2), 0.0);
  }
  ASSERT_EQ(c.extras.size(), 1u);
  EXPECT_EQ(c.extras[0].name, "intensity");
  EXPECT_EQ(c.extras[0].type, ScalarType::UInt8);
  EXPECT_EQ(c.extras[0].values[5], 15.0);
}

TEST_F(IoTest, PcdAsciiNormalsCountFieldsAndPadding) {
  const std::string a =
      "# .PCD v.7\nVERSION .7\nFIELDS x y z normal_x normal_y normal_z curvature fpfh _\n"
      "SIZE 4 4 4 4 4 4 4 4 1\nTYPE F F F F F F F F U\nCOUNT 1 1 1 1 1 1 1 3 1\nWIDTH 2\n"
      "HEIGHT 1\nPOINTS 2\nDATA ascii\n1 2 3 0 0 1 0.5 9 9 9 0\nnan 5 6 1 0 0 0.25 8 8 8 0\n";
  std::vector<std::string> warnings;
  const Cloud c = read_cloud(put("n.pcd", a), {}, &warnings);
  ASSERT_EQ(c.size(), 2);
  EXPECT_TRUE(c.has_normals());
  EXPECT_TRUE(std::isnan(c.points(1, 0)));
  EXPECT_EQ(c.normals(1, 0), 1.0);
  ASSERT_EQ(c.extras.size(), 1u);
  EXPECT_EQ(c.extras[0].name, "curvature");
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("fpfh"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// XYZ specifics

TEST_F(IoTest, XyzCommentsBlankLinesNanAndColumns) {
  const std::string a = "# header comment\n\n1 2 3\n  \t\n4.5e0 -inf nan\n# more\n+7 8 9\n";
  const Cloud c = read_cloud(put("a.xyz", a));
  ASSERT_EQ(c.size(), 3);
  EXPECT_FALSE(c.has_normals());
  EXPECT_TRUE(std::isinf(c.points(1, 1)));
  EXPECT_TRUE(std::isnan(c.points(1, 2)));
  EXPECT_EQ(c.points(2, 0), 7.0);

  const Cloud n = read_cloud(put("n.xyzn", "1 2 3 0 0 1\r\n4 5 6 1 0 0\r\n"));
  ASSERT_EQ(n.size(), 2);
  EXPECT_TRUE(n.has_normals());
  EXPECT_EQ(n.normals(1, 0), 1.0);

  const Cloud e = read_cloud(put("e.txt", "1 2 3 0 0 1 7 8\n4 5 6 1 0 0 9 10\n"));
  ASSERT_EQ(e.extras.size(), 2u);
  EXPECT_EQ(e.extras[0].name, "scalar_6");
  EXPECT_EQ(e.extras[1].values[1], 10.0);

  // 4 or 5 columns: x y z plus extras (no partial normals)
  const Cloud i4 = read_cloud(put("i.xyz", "1 2 3 0.5\n4 5 6 0.75\n"));
  EXPECT_FALSE(i4.has_normals());
  ASSERT_EQ(i4.extras.size(), 1u);
  EXPECT_EQ(i4.extras[0].name, "scalar_3");
  EXPECT_EQ(i4.extras[0].values[1], 0.75);

  // out-of-range magnitudes are non-finite / zero, never an error or 0 for huge values
  const Cloud r = read_cloud(put("r.xyz", "1e400 -1e400 1e-400\n"));
  EXPECT_TRUE(std::isinf(r.points(0, 0)));
  EXPECT_LT(r.points(0, 1), 0);
  EXPECT_EQ(r.points(0, 2), 0.0);
}

TEST_F(IoTest, XyzPtsCountLineAndSniffing) {
  const Cloud c = read_cloud(put("a.pts", "2\n1 2 3\n4 5 6\n"));
  EXPECT_EQ(c.size(), 2);
  // numeric content with an unknown extension is XYZ
  EXPECT_EQ(read_cloud(put("scan.dat", "1 2 3\n4 5 6\n")).size(), 2);
  // PCD content with a .ply extension is read as PCD (content beats extension)
  const std::string pcd =
      "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nPOINTS 1\nDATA ascii\n1 2 3\n";
  EXPECT_EQ(read_cloud(put("really_pcd.ply", pcd)).size(), 1);
}

// Runs `check` (returns true on the expected outcome) with the permissions of an unprivileged
// user: directly when not root, else in a child process that drops to uid/gid 65534 (nobody),
// because root bypasses file permissions. Returns true when the check held.
static bool as_unprivileged(const std::function<bool()>& check) {
  if (::geteuid() != 0) return check();
  const pid_t pid = ::fork();
  if (pid == 0) {
    if (::setgid(65534) != 0 || ::setuid(65534) != 0) ::_exit(3);
    bool ok = false;
    try {
      ok = check();
    } catch (...) {
      ok = false;
    }
    ::_exit(ok ? 0 : 1);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

// ---------------------------------------------------------------------------------------------
// Bad input: files

TEST_F(IoTest, MissingDirectoryPermissionEmpty) {
  expect_input_error(path("nonexistent.ply"), "No such file");
  fs::create_directories(path("adir.ply"));
  expect_input_error(path("adir.ply"), "directory");
  expect_input_error(put("empty.ply", ""), "empty file");
  expect_input_error(put("empty.xyz", ""), "empty file");
  const std::string locked = put("locked.ply", "ply\n");
  ::chmod(locked.c_str(), 0);
  ::chmod(path("").c_str(), 0755);  // the unprivileged reader must reach the file
  EXPECT_TRUE(as_unprivileged([&] {
    try {
      read_cloud(locked);
    } catch (const InputError& e) {
      return std::string(e.what()).find("Permission denied") != std::string::npos &&
             std::string(e.what()).find("locked.ply") != std::string::npos;
    }
    return false;
  })) << "reading a mode-000 file must fail with 'Permission denied'";
}

TEST_F(IoTest, WrongMagicAndUnknownFormat) {
  const std::string jpeg("\xFF\xD8\xFF\xE0\x00\x10JFIF\x00\x01\x01", 13);
  expect_input_error(put("photo.ply", jpeg), "magic");
  expect_input_error(put("photo.pcd", jpeg), "magic");
  expect_input_error(put("photo.bin", jpeg), "unrecognised format");
  expect_input_error(put("notes.md", "hello world\n"), "unrecognised format");
  // an explicit format is checked against the content too
  ReadOptions ply;
  ply.format = FileFormat::Ply;
  EXPECT_THROW(read_cloud(put("x.xyz", "1 2 3\n"), ply), InputError);
}

// ---------------------------------------------------------------------------------------------
// Bad input: PLY headers

TEST_F(IoTest, PlyHeaderErrors) {
  const std::string v = "element vertex 1\nproperty float x\nproperty float y\nproperty float z\n";
  expect_input_error(put("noend.ply", std::string(kPlyHeaderStart) + v), "header not terminated");
  expect_input_error(put("noend2.ply", std::string(kPlyHeaderStart) + v + "1 2 3\n"),
                     "unknown header keyword '1' (line 7)");
  std::string huge = std::string(kPlyHeaderStart) + v;
  while (huge.size() < 70000) huge += "comment padding padding padding padding\n";
  expect_input_error(put("huge.ply", huge + "end_header\n1 2 3\n"), "64 KiB");
  expect_input_error(put("fmt0.ply", "ply\nformat\n" + v + "end_header\n"), "format");
  expect_input_error(put("fmt1.ply", "ply\nformat ascii\n" + v + "end_header\n"), "format");
  expect_input_error(put("fmt2.ply", "ply\nformat ascii 2.0\n" + v + "end_header\n"), "version");
  expect_input_error(put("fmt3.ply", "ply\nformat binary_middle_endian 1.0\n" + v + "end_header\n"),
                     "format");
  expect_input_error(put("nofmt.ply", "ply\n" + v + "end_header\n1 2 3\n"), "format");
  expect_input_error(put("f128.ply", std::string(kPlyHeaderStart) +
                                         "element vertex 1\nproperty float128 x\nend_header\n"),
                     "unknown property type 'float128'");
  expect_input_error(put("early.ply", std::string(kPlyHeaderStart) +
                                          "property float x\nelement vertex 1\nend_header\n"),
                     "property before any element");
  expect_input_error(put("noy.ply", std::string(kPlyHeaderStart) +
                                        "element vertex 1\nproperty float x\nproperty float z\n"
                                        "end_header\n1 2\n"),
                     "no 'y' property");
  expect_input_error(
      put("dup.ply", std::string(kPlyHeaderStart) + v + "property float x\nend_header\n1 2 3 4\n"),
      "duplicate property 'x'");
  expect_input_error(
      put("novertex.ply", std::string(kPlyHeaderStart) + "element face 0\nend_header\n"),
      "no vertex element");
  expect_input_error(put("keyword.ply", std::string(kPlyHeaderStart) + v + "bogus 1\nend_header\n"),
                     "unknown header keyword 'bogus'");
  expect_input_error(put("flist.ply", std::string(kPlyHeaderStart) + v +
                                          "element face 1\nproperty list float int idx\n"
                                          "end_header\n1 2 3\n1 0\n"),
                     "not an integer type");
}

TEST_F(IoTest, PlyBadCounts) {
  for (const char* count : {"-1", "abc", "1e3", "1.5", "4294967296000", "99999999999999999999"}) {
    SCOPED_TRACE(count);
    const std::string text = std::string(kPlyHeaderStart) + "element vertex " + count +
                             "\nproperty float x\nproperty float y\nproperty float z\n"
                             "end_header\n1 2 3\n";
    expect_input_error(put("count.ply", text), "element count");
  }
}

// ---------------------------------------------------------------------------------------------
// Bad input: PLY bodies

TEST_F(IoTest, PlyAsciiFewerRowsThanDeclared) {
  std::string a =
      "ply\nformat ascii 1.0\nelement vertex 1000\nproperty float x\n"
      "property float y\nproperty float z\nend_header\n";
  for (int i = 0; i < 12; ++i) a += "1 2 3\n";
  expect_input_error(put("short.ply", a), "expected 1000 vertices, file ends after 12 (line 19)");
  a += std::string(8000, ' ');  // enough bytes that the size pre-check passes
  expect_input_error(put("short.ply", a), "expected 1000 vertices, file ends after 12");
}

TEST_F(IoTest, PlyAsciiMalformedValues) {
  const std::string h =
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
      "property float y\nproperty float z\nproperty uchar red\nend_header\n";
  expect_input_error(put("comma.ply", h + "1 2 3 4\n1,5 2 3 4\n"), "malformed number '1,5'");
  expect_input_error(put("comma.ply", h + "1 2 3 4\n1,5 2 3 4\n"), "line 10");
  expect_input_error(put("few.ply", h + "1 2 3\n1 2 3 4\n"), "too few values");
  expect_input_error(put("many.ply", h + "1 2 3 4 5\n1 2 3 4\n"), "too many values");
  expect_input_error(put("range.ply", h + "1 2 3 256\n1 2 3 4\n"), "not a valid uchar");
}

TEST_F(IoTest, PlyBinaryTruncatedNeverZeroFilled) {
  std::string b =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\n"
      "property float y\nproperty float z\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n";
  for (int i = 0; i < 6; ++i) b += le<float>(1.0f);
  b += char(3) + le<int32_t>(0) + le<int32_t>(1);  // list cut short
  expect_input_error(put("trunc_list.ply", b), "unexpected end of file");

  // faces first: the size pre-check counts 1 byte per face row, so a file cut inside the
  // vertices passes it and must fail while reading
  std::string t =
      "ply\nformat binary_little_endian 1.0\nelement face 1\n"
      "property list uchar int vertex_indices\nelement vertex 3\nproperty float x\n"
      "property float y\nproperty float z\nproperty uchar q\nend_header\n";
  t += char(3) + le<int32_t>(0) + le<int32_t>(1) + le<int32_t>(2);
  for (int i = 0; i < 3; ++i) t += le<float>(1.0f) + le<float>(2.0f) + le<float>(3.0f) + char(1);
  t.resize(t.size() - 7);
  expect_input_error(put("trunc.ply", t),
                     "unexpected end of file at byte " + std::to_string(t.size()));
  expect_input_error(put("trunc.ply", t), "vertex 2");
}

TEST_F(IoTest, PlyBinaryCutInsideVerticesNamesTheEndByte) {
  // Caught by the size check before any allocation; the message still gives the end-of-file byte.
  std::string b =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
      "property float y\nproperty float z\nend_header\n";
  for (int i = 0; i < 9; ++i) b += le<float>(float(i));
  b.resize(b.size() - 5);
  expect_input_error(put("cut.ply", b),
                     "unexpected end of file at byte " + std::to_string(b.size()));
}

TEST_F(IoTest, PlyDeclaredSizeRefusedBeforeAllocating) {
  std::string b =
      "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\n"
      "property double x\nproperty double y\nproperty double z\nend_header\n";
  b += std::string(100, '\0');
  const auto start = std::chrono::steady_clock::now();
  expect_input_error(put("big.ply", b), "declares 1000000000000 vertices");
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(2));
  std::string a =
      "ply\nformat ascii 1.0\nelement vertex 1000000000\nproperty float x\n"
      "property float y\nproperty float z\nend_header\n1 2 3\n";
  expect_input_error(put("biga.ply", a), "expected 1000000000 vertices, file ends after 1");
}

TEST_F(IoTest, PlyHugeListLengthBounded) {
  std::string b =
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n"
      "property float y\nproperty float z\nelement face 1\n"
      "property list uint int vertex_indices\nend_header\n";
  b += le<float>(1) + le<float>(2) + le<float>(3) + le<uint32_t>(0xFFFFFFF0u) + le<int32_t>(5);
  expect_input_error(put("list.ply", b), "runs past the end of the file");

  std::string s =
      "ply\nformat binary_big_endian 1.0\nelement vertex 1\nproperty float x\n"
      "property float y\nproperty float z\nelement face 1\n"
      "property list short int vertex_indices\nend_header\n";
  s += be<float>(1) + be<float>(2) + be<float>(3) + be<int16_t>(-5);
  expect_input_error(put("neglist.ply", s), "negative list length");

  std::string a =
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uint int vertex_indices\n"
      "end_header\n1 2 3\n4294967280 1 2\n";
  expect_input_error(put("lista.ply", a), "runs past the line");
}

// ---------------------------------------------------------------------------------------------
// Bad input: PCD

TEST_F(IoTest, PcdErrors) {
  const std::string head = "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";
  expect_input_error(put("empty.pcd", ""), "empty file");
  expect_input_error(put("headonly.pcd", head + "WIDTH 5\nHEIGHT 1\nPOINTS 5\n"), "no DATA line");
  expect_input_error(put("nodata.pcd", head + "WIDTH 5\nHEIGHT 1\nPOINTS 5\nDATA binary\n"),
                     "declares 5 points");
  expect_input_error(
      put("nodata_a.pcd", head + "WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n1 2 3\n   \n"),
      "expected 2 points, file ends after 1");
  expect_input_error(put("wh.pcd", head + "WIDTH 5\nHEIGHT 2\nPOINTS 5\nDATA ascii\n"),
                     "does not match WIDTH*HEIGHT");
  expect_input_error(put("len.pcd",
                         "VERSION .7\nFIELDS x y z\nSIZE 4 4\nTYPE F F F\nWIDTH 1\n"
                         "POINTS 1\nDATA ascii\n1 2 3\n"),
                     "SIZE has 2");
  expect_input_error(put("lenc.pcd",
                         "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"
                         "COUNT 1 1 1 1\nWIDTH 1\nPOINTS 1\nDATA ascii\n1 2 3\n"),
                     "COUNT has 4");
  expect_input_error(put("noz.pcd",
                         "VERSION .7\nFIELDS x y\nSIZE 4 4\nTYPE F F\nWIDTH 1\n"
                         "POINTS 1\nDATA ascii\n1 2\n"),
                     "no 'z' field");
  expect_input_error(put("type.pcd",
                         "VERSION .7\nFIELDS x y z\nSIZE 4 4 3\nTYPE F F F\nWIDTH 1\n"
                         "POINTS 1\nDATA ascii\n1 2 3\n"),
                     "unsupported SIZE 3");
  expect_input_error(put("bad.pcd", head + "WIDTH 1\nPOINTS 1\nDATA ascii\n1 abc 3\n"),
                     "malformed number 'abc'");
  expect_input_error(put("neg.pcd", head + "WIDTH -1\nPOINTS 1\nDATA ascii\n1 2 3\n"), "WIDTH");
  expect_input_error(put("kind.pcd", head + "WIDTH 1\nPOINTS 1\nDATA zip\n1 2 3\n"), "DATA");
}

TEST_F(IoTest, PcdCorruptCompressedSizes) {
  const std::string head =
      "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 4\nHEIGHT 1\n"
      "POINTS 4\nDATA binary_compressed\n";
  std::string raw;
  for (int i = 0; i < 12; ++i) raw += le<float>(float(i));
  const std::string good = lzf_literals(raw);
  // sanity: the good stream reads
  EXPECT_EQ(read_cloud(
                put("ok.pcd", head + le<uint32_t>(uint32_t(good.size())) + le<uint32_t>(48) + good))
                .points(3, 2),
            11.0);
  expect_input_error(put("usize.pcd", head + le<uint32_t>(uint32_t(good.size())) +
                                          le<uint32_t>(0xFFFFFFF0u) + good),
                     "corrupt binary_compressed");
  expect_input_error(put("csize.pcd", head + le<uint32_t>(0xFFFFFFF0u) + le<uint32_t>(48) + good),
                     "corrupt binary_compressed");
  std::string bad = good;
  ASSERT_EQ(bad[33], char(15));
  bad[33] = char(31);  // second literal run longer than the data
  expect_input_error(
      put("stream.pcd", head + le<uint32_t>(uint32_t(bad.size())) + le<uint32_t>(48) + bad),
      "corrupt binary_compressed");
  const std::string backref = std::string("\x20\x05", 2);  // reference before the output start
  expect_input_error(put("ref.pcd", head + le<uint32_t>(2) + le<uint32_t>(48) + backref),
                     "corrupt binary_compressed");
  expect_input_error(put("nosizes.pcd", head + "ab"), "unexpected end of file");
}

// ---------------------------------------------------------------------------------------------
// Bad input: XYZ

TEST_F(IoTest, XyzErrorsNameTheLine) {
  expect_input_error(put("ragged.xyz", "1 2 3\n4 5 6\n7 8\n"), "ragged line");
  expect_input_error(put("ragged.xyz", "1 2 3\n4 5 6\n7 8\n"), "line 3");
  expect_input_error(put("comma.xyz", "1 2 3\n1,5 2 3\n"), "malformed number '1,5'");
  expect_input_error(put("comma.xyz", "1 2 3\n1,5 2 3\n"), "line 2");
  expect_input_error(put("abc.xyz", "# c\nabc 1 2\n"), "line 2");
  expect_input_error(put("trail.xyz", "1 2 3x\n"), "malformed number '3x'");
  expect_input_error(put("two.xyz", "1 2\n3 4\n"), "at least 3 columns");
  expect_input_error(put("comments.xyz", "# only\n\n"), "no points");
}

// ---------------------------------------------------------------------------------------------
// Writing failures

TEST_F(IoTest, WriteToMissingDirectoryLeavesNothing) {
  const Cloud c = make_cloud(10, false, true);
  const std::string target = path("missing/out.ply");
  try {
    write_cloud(target, c);
    ADD_FAILURE() << "no OutputError";
  } catch (const OutputError& e) {
    EXPECT_NE(std::string(e.what()).find("out.ply"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(target));
  EXPECT_TRUE(listing().empty());
  EXPECT_THROW(write_cloud(path("out.unknown"), c), OutputError);
  EXPECT_TRUE(listing().empty());
}

TEST_F(IoTest, FailedWriteKeepsExistingTargetAndRemovesTemp) {
  const std::string target = path("keep.ply");
  const std::string original = "original content\n";
  put("keep.ply", original);

  // 1. an inconsistent cloud is refused
  Cloud bad = make_cloud(10, false, true);
  bad.normals.conservativeResize(5, 3);
  EXPECT_THROW(write_cloud(target, bad), OutputError);
  EXPECT_EQ(slurp(target), original);

  // 2. a write that fails mid-way (file size limit, i.e. "disk full") removes its temp file
  const Cloud big = make_cloud(20000, true, true);
  struct rlimit old {};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
  const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
  struct rlimit limited = old;
  limited.rlim_cur = 4096;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &limited), 0);
  std::string message;
  try {
    write_cloud(target, big);
  } catch (const OutputError& e) {
    message = e.what();
  }
  ::setrlimit(RLIMIT_FSIZE, &old);
  std::signal(SIGXFSZ, old_handler);
  EXPECT_NE(message.find("keep.ply"), std::string::npos) << message;
  EXPECT_NE(message.find("write failed"), std::string::npos) << message;
  EXPECT_EQ(slurp(target), original);
  EXPECT_EQ(listing(), std::vector<std::string>{"keep.ply"});

  // 3. a successful write replaces the target and keeps its permission bits
  ::chmod(target.c_str(), 0640);
  write_cloud(target, big);
  EXPECT_EQ(read_cloud(target).size(), big.size());
  struct stat st {};
  ASSERT_EQ(::stat(target.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0640u);
  EXPECT_EQ(listing(), std::vector<std::string>{"keep.ply"});
}

TEST_F(IoTest, WriteIntoReadOnlyDirectory) {
  fs::create_directories(path("ro"));
  ::chmod(path("").c_str(), 0755);
  ::chmod(path("ro").c_str(), 0555);
  const Cloud cloud = make_cloud(5, false, false);
  EXPECT_TRUE(as_unprivileged([&] {
    try {
      write_cloud(path("ro/out.xyz"), cloud);
    } catch (const OutputError& e) {
      return std::string(e.what()).find("Permission denied") != std::string::npos;
    }
    return false;
  })) << "writing into a read-only directory must fail with 'Permission denied'";
  EXPECT_FALSE(fs::exists(path("ro/out.xyz")));
}
