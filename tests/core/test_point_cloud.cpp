#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <tuple>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/point_cloud.hpp"

namespace fleetslam::core {
namespace {

namespace fs = std::filesystem;

// A fresh folder per test so that tests may run in parallel.
fs::path test_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = std::string(info->test_suite_name()) + "." + info->name();
  for (char& c : name) {
    if (c == '/') c = '_';
  }
  const fs::path dir = fs::temp_directory_path() / "fleetslam_test_point_cloud" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string write_file(const fs::path& path, const std::string& data) {
  std::ofstream(path, std::ios::binary) << data;
  return path.string();
}

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

PointCloud random_cloud(std::size_t n, bool with_colors, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-50.0f, 50.0f);
  std::uniform_int_distribution<int> channel(0, 255);
  PointCloud cloud;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f p(u(rng), u(rng), u(rng) * 1e-3f);
    const PointCloud::Rgb rgb = {static_cast<std::uint8_t>(channel(rng)), static_cast<std::uint8_t>(channel(rng)),
                                 static_cast<std::uint8_t>(channel(rng))};
    if (with_colors) {
      cloud.push_back(p, rgb);
    } else {
      cloud.push_back(p);
    }
  }
  // Values that a careless text format loses.
  const Eigen::Vector3f extremes(std::numeric_limits<float>::max(), std::numeric_limits<float>::denorm_min(), -0.1f);
  if (with_colors) {
    cloud.push_back(extremes, {0, 255, 128});
  } else {
    cloud.push_back(extremes);
  }
  return cloud;
}

void expect_same(const PointCloud& expected, const PointCloud& actual) {
  ASSERT_EQ(expected.size(), actual.size());
  ASSERT_EQ(expected.has_colors(), actual.has_colors());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    for (int axis = 0; axis < 3; ++axis) {
      const float e = expected.points[i][axis];
      const float a = actual.points[i][axis];
      if (std::isnan(e)) {
        EXPECT_TRUE(std::isnan(a)) << i;
      } else {
        EXPECT_EQ(e, a) << "point " << i << " axis " << axis;  // bit for bit
      }
    }
    if (expected.has_colors()) {
      EXPECT_EQ(expected.colors[i], actual.colors[i]) << i;
    }
  }
}

// ---------------------------------------------------------------------------------------------------
// Round trips: {PLY, PCD} x {binary, ASCII} x {with, without colours}

enum class Format { kPly, kPcd };
using RoundTripParam = std::tuple<Format, CloudEncoding, bool>;

class PointCloudRoundTrip : public ::testing::TestWithParam<RoundTripParam> {};

TEST_P(PointCloudRoundTrip, PointsAndColoursComeBackExactly) {
  const auto [format, encoding, with_colors] = GetParam();
  PointCloud cloud = random_cloud(500, with_colors, 11);
  cloud.points[3].y() = std::numeric_limits<float>::quiet_NaN();  // organised clouds carry NaN points
  const fs::path dir = test_dir();
  const std::string path = (dir / (format == Format::kPly ? "cloud.ply" : "cloud.pcd")).string();
  if (format == Format::kPly) {
    write_ply(path, cloud, encoding);
    expect_same(cloud, read_ply(path));
  } else {
    write_pcd(path, cloud, encoding);
    expect_same(cloud, read_pcd(path));
  }
  expect_same(cloud, read_point_cloud(path));
}

TEST_P(PointCloudRoundTrip, EmptyCloud) {
  const auto [format, encoding, with_colors] = GetParam();
  (void)with_colors;
  const fs::path dir = test_dir();
  const std::string path = (dir / (format == Format::kPly ? "empty.ply" : "empty.pcd")).string();
  if (format == Format::kPly) {
    write_ply(path, PointCloud{}, encoding);
  } else {
    write_pcd(path, PointCloud{}, encoding);
  }
  EXPECT_TRUE(read_point_cloud(path).empty());
}

std::string round_trip_name(const ::testing::TestParamInfo<RoundTripParam>& param_info) {
  const Format format = std::get<0>(param_info.param);
  const CloudEncoding encoding = std::get<1>(param_info.param);
  return std::string(format == Format::kPly ? "ply" : "pcd") +
         (encoding == CloudEncoding::kBinary ? "_binary" : "_ascii") + (std::get<2>(param_info.param) ? "_rgb" : "_xyz");
}

INSTANTIATE_TEST_SUITE_P(AllFormats, PointCloudRoundTrip,
                         ::testing::Combine(::testing::Values(Format::kPly, Format::kPcd),
                                            ::testing::Values(CloudEncoding::kBinary, CloudEncoding::kAscii),
                                            ::testing::Bool()),
                         round_trip_name);

TEST(PointCloudIo, WritersUseTheDocumentedHeaders) {
  const fs::path dir = test_dir();
  PointCloud cloud;
  cloud.push_back({1.0f, 2.0f, 3.0f}, {10, 20, 30});
  write_ply((dir / "a.ply").string(), cloud, CloudEncoding::kAscii);
  EXPECT_EQ(read_bytes(dir / "a.ply"),
            "ply\nformat ascii 1.0\ncomment fleetslam\nelement vertex 1\nproperty float x\nproperty float y\n"
            "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n"
            "1 2 3 10 20 30\n");
  write_pcd((dir / "a.pcd").string(), cloud, CloudEncoding::kAscii);
  // PCL 1.13's convention: rgb is an unsigned 4-byte field holding 0xAARRGGBB.
  EXPECT_EQ(read_bytes(dir / "a.pcd"),
            "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\n"
            "TYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 1\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1\nDATA ascii\n"
            "1 2 3 4278850590\n");
  write_ply((dir / "b.ply").string(), cloud);  // binary by default: header + 3 floats + 3 bytes
  const std::string binary = read_bytes(dir / "b.ply");
  EXPECT_NE(binary.find("format binary_little_endian 1.0\n"), std::string::npos);
  const std::size_t body = binary.find("end_header\n") + 11;
  ASSERT_EQ(binary.size() - body, 15u);
  float x = 0.0f;
  std::memcpy(&x, binary.data() + body, 4);
  EXPECT_EQ(x, 1.0f);
  EXPECT_EQ(static_cast<unsigned char>(binary[body + 12]), 10);
}

TEST(PointCloudIo, WritersCreateParentFoldersAndDispatchOnExtension) {
  const fs::path dir = test_dir();
  const PointCloud cloud = random_cloud(20, true, 3);
  const fs::path ply = dir / "deep" / "er" / "map.PLY";
  const fs::path pcd = dir / "other" / "map.pcd";
  write_point_cloud(ply.string(), cloud);
  write_point_cloud(pcd.string(), cloud);
  EXPECT_EQ(read_bytes(ply).rfind("ply\n", 0), 0u);
  EXPECT_EQ(read_bytes(pcd).rfind("# .PCD", 0), 0u);
  expect_same(cloud, read_point_cloud(ply.string()));
  expect_same(cloud, read_point_cloud(pcd.string()));
}

// ---------------------------------------------------------------------------------------------------
// Errors name the file

void expect_input_error(const std::function<void()>& call, const std::string& file, const std::string& why_part) {
  try {
    call();
    ADD_FAILURE() << "no InputError for " << file;
  } catch (const InputError& error) {
    EXPECT_EQ(error.where().rfind(file, 0), 0u) << error.what();
    EXPECT_NE(error.why().find(why_part), std::string::npos) << error.what();
  }
}

TEST(PointCloudIo, UnknownExtensionIsAnInputErrorNamingTheFile) {
  const fs::path dir = test_dir();
  const std::string path = write_file(dir / "cloud.xyz", "1 2 3\n");
  expect_input_error([&] { read_point_cloud(path); }, path, "unknown point cloud format '.xyz'");
  expect_input_error([&] { write_point_cloud(path, PointCloud{}); }, path, "unknown point cloud format");
  const std::string bare = (dir / "cloud").string();
  expect_input_error([&] { read_point_cloud(bare); }, bare, "unknown point cloud format");
}

TEST(PointCloudIo, MissingFileAndFolder) {
  const fs::path dir = test_dir();
  const std::string missing = (dir / "missing.ply").string();
  expect_input_error([&] { read_ply(missing); }, missing, "cannot open");
  fs::create_directories(dir / "folder.pcd");
  const std::string folder = (dir / "folder.pcd").string();
  expect_input_error([&] { read_pcd(folder); }, folder, "is a folder");
}

TEST(PointCloudIo, TruncatedBodiesAreInputErrors) {
  const fs::path dir = test_dir();
  const PointCloud cloud = random_cloud(100, true, 5);
  for (const char* name : {"t.ply", "t.pcd"}) {
    for (const CloudEncoding encoding : {CloudEncoding::kBinary, CloudEncoding::kAscii}) {
      const fs::path path = dir / name;
      if (path.extension() == ".ply") {
        write_ply(path.string(), cloud, encoding);
      } else {
        write_pcd(path.string(), cloud, encoding);
      }
      std::string data = read_bytes(path);
      data.resize(data.size() - data.size() / 4);
      if (encoding == CloudEncoding::kAscii) data.resize(data.rfind('\n') + 1);  // whole lines missing
      write_file(path, data);
      SCOPED_TRACE(path.string() + (encoding == CloudEncoding::kAscii ? " ascii" : " binary"));
      expect_input_error([&] { read_point_cloud(path.string()); }, path.string(), "truncated body");
    }
  }
}

TEST(PointCloudIo, BadHeadersAreInputErrors) {
  const fs::path dir = test_dir();
  struct Case {
    const char* name;
    std::string text;
    const char* why;
  };
  const Case cases[] = {
      {"magic.ply", "plx\nformat ascii 1.0\nend_header\n", "not a PLY file"},
      {"format.ply", "ply\nformat binary_middle_endian 1.0\nelement vertex 0\nend_header\n", "unknown format"},
      {"no_end.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", "no 'end_header'"},
      {"no_format.ply", "ply\nelement vertex 0\nend_header\n", "no 'format'"},
      {"type.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n1\n", "unknown property type"},
      {"no_xyz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n",
       "no x, y and z"},
      {"no_vertex.ply", "ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n",
       "no 'vertex' element"},
      {"number.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                     "end_header\n1 two 3\n",
       "bad number 'two'"},
      // Integer types take whole numbers in range: a list count of 2.5 misaligned the row it was in.
      {"count.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar float tags\nproperty float x\n"
                    "property float y\nproperty float z\nend_header\n2.5 7 8 1 2 3\n",
       "bad number '2.5'"},
      {"uchar.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                    "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n1 2 3 300 0 0\n",
       "bad number '300'"},
      {"int.pcd", "FIELDS x y z label\nSIZE 4 4 4 4\nTYPE F F F I\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3 0.5\n",
       "bad number '0.5'"},
      {"no_data.pcd", "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nPOINTS 1\n", "no DATA line"},
      {"sizes.pcd", "FIELDS x y z\nSIZE 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n",
       "different numbers of fields"},
      {"type.pcd", "FIELDS x y z\nSIZE 4 4 2\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n",
       "unsupported TYPE F with SIZE 2"},
      {"points.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 1\nPOINTS 3\nDATA ascii\n1 2 3\n",
       "POINTS is not WIDTH * HEIGHT"},
      {"data.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA zipped\n", "unknown DATA"},
      {"no_z.pcd", "FIELDS x y\nSIZE 4 4\nTYPE F F\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2\n", "no x, y and z"},
      {"width.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH -1\nHEIGHT 1\nDATA ascii\n", "WIDTH expects"},
      {"binary.pcd", "\x89PNG\r\n\x1a\n", "unknown keyword"},
      // Absurd counts fail as truncated bodies or header errors, without allocating for them.
      {"huge.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 999999999999999\nproperty float x\n"
                   "property float y\nproperty float z\nend_header\n\x01\x02",
       "truncated body"},
      {"huge.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 99999999999\nHEIGHT 99999999999\nDATA ascii\n1 2 3\n",
       "WIDTH * HEIGHT is too large"},
      {"huge_ascii.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 999999999999\nHEIGHT 1\nDATA ascii\n1 2 3\n",
       "truncated body"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = write_file(dir / c.name, c.text);
    expect_input_error([&] { read_point_cloud(path); }, path, c.why);
  }
}

// ---------------------------------------------------------------------------------------------------
// Variants other tools write

TEST(PointCloudIo, ReadsAsciiPlyWithDoublesNormalsExtraElementsAndFloatColours) {
  const fs::path dir = test_dir();
  const std::string path = write_file(dir / "meshlab.ply",
                                      "ply\r\n"
                                      "format ascii 1.0\r\n"
                                      "comment written by hand\r\n"
                                      "obj_info made for a test\r\n"
                                      "element camera 1\r\n"
                                      "property list uchar float view\r\n"
                                      "property float focal\r\n"
                                      "element vertex 2\r\n"
                                      "property double x\r\n"
                                      "property double y\r\n"
                                      "property double z\r\n"
                                      "property float nx\r\n"
                                      "property float ny\r\n"
                                      "property float nz\r\n"
                                      "property float red\r\n"
                                      "property float green\r\n"
                                      "property float blue\r\n"
                                      "property list uchar int extra\r\n"
                                      "property uchar alpha\r\n"
                                      "element face 1\r\n"
                                      "property list uchar int vertex_indices\r\n"
                                      "end_header\r\n"
                                      "3 0.1 0.2 0.3 525.0\r\n"
                                      "1.25 -2.5 +3e2 0 0 1 1.0 0.5 0 2 7 8 255\r\n"
                                      "0.1 0.2 0.3 0 1 0 0 0 1 0.0 1.28e2\r\n"  // whole numbers
                                      "3 0 1 1\r\n");
  const PointCloud cloud = read_ply(path);
  ASSERT_EQ(cloud.size(), 2u);
  ASSERT_TRUE(cloud.has_colors());
  EXPECT_EQ(cloud.points[0], Eigen::Vector3f(1.25f, -2.5f, 300.0f));
  EXPECT_EQ(cloud.points[1], Eigen::Vector3f(0.1f, 0.2f, 0.3f));
  EXPECT_EQ(cloud.colors[0], (PointCloud::Rgb{255, 128, 0}));  // float colours in [0, 1]
  EXPECT_EQ(cloud.colors[1], (PointCloud::Rgb{0, 0, 255}));
  ASSERT_TRUE(cloud.has_normals());
  EXPECT_EQ(cloud.normals[0], Eigen::Vector3f(0, 0, 1));
  EXPECT_EQ(cloud.normals[1], Eigen::Vector3f(0, 1, 0));
}

// The central unit tells the faces of a thin wall apart by their normals: a map written and read back
// keeps them, with and without colours, in both encodings; PCD has no normals (they are dropped).
TEST(PointCloudIo, PlyKeepsNormals) {
  const fs::path dir = test_dir();
  for (const bool with_colors : {true, false}) {
    PointCloud cloud = random_cloud(200, with_colors, 5);
    std::mt19937 rng(9);
    std::normal_distribution<float> gauss;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      cloud.normals.push_back(Eigen::Vector3f(gauss(rng), gauss(rng), gauss(rng)).normalized());
    }
    cloud.normals[7] = Eigen::Vector3f::Zero();  // unknown
    for (const CloudEncoding encoding : {CloudEncoding::kBinary, CloudEncoding::kAscii}) {
      const std::string path = (dir / "normals.ply").string();
      write_ply(path, cloud, encoding);
      const std::string bytes = read_bytes(path);
      EXPECT_NE(bytes.find("property float nx\nproperty float ny\nproperty float nz\nend_header"), std::string::npos);
      const PointCloud back = read_ply(path);
      expect_same(cloud, back);
      ASSERT_TRUE(back.has_normals());
      for (std::size_t i = 0; i < cloud.size(); ++i) EXPECT_EQ(cloud.normals[i], back.normals[i]) << i;  // bit for bit
    }
    write_pcd((dir / "normals.pcd").string(), cloud);
    const PointCloud pcd = read_pcd((dir / "normals.pcd").string());
    expect_same(cloud, pcd);
    EXPECT_FALSE(pcd.has_normals());
  }
  // A cloud without normals is written without the properties.
  write_ply((dir / "plain.ply").string(), random_cloud(3, true, 1));
  EXPECT_EQ(read_bytes(dir / "plain.ply").find("nx"), std::string::npos);
  EXPECT_FALSE(read_ply((dir / "plain.ply").string()).has_normals());
}

// Appends a value to a binary body in big-endian byte order.
template <class T>
void append_big_endian(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  for (std::size_t i = 0; i < sizeof(T); ++i) out += bytes[sizeof(T) - 1 - i];
}

TEST(PointCloudIo, ReadsBigEndianBinaryPlyWithDoublesAndExtraProperties) {
  const fs::path dir = test_dir();
  std::string data =
      "ply\nformat binary_big_endian 1.0\nelement vertex 2\nproperty double x\nproperty double y\n"
      "property double z\nproperty int label\nproperty uchar r\nproperty uchar g\nproperty uchar b\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const double xyz[2][3] = {{1.5, -2.25, 1e6}, {0.1, 0.2, 0.3}};
  for (int i = 0; i < 2; ++i) {
    for (double v : xyz[i]) append_big_endian(data, v);
    append_big_endian(data, std::int32_t{-7});
    data += static_cast<char>(10 * i + 1);
    data += static_cast<char>(10 * i + 2);
    data += static_cast<char>(200);
  }
  data += static_cast<char>(2);  // the face: two indices
  append_big_endian(data, std::int32_t{0});
  append_big_endian(data, std::int32_t{1});
  const std::string path = write_file(dir / "big.ply", data);
  const PointCloud cloud = read_point_cloud(path);
  ASSERT_EQ(cloud.size(), 2u);
  EXPECT_EQ(cloud.points[0], Eigen::Vector3f(1.5f, -2.25f, 1e6f));
  EXPECT_EQ(cloud.points[1], Eigen::Vector3d(0.1, 0.2, 0.3).cast<float>());
  EXPECT_EQ(cloud.colors[1], (PointCloud::Rgb{11, 12, 200}));
}

TEST(PointCloudIo, ReadsPclStyleAsciiPcdWithExtraFieldsAndBothRgbSpellings) {
  const fs::path dir = test_dir();
  // The second point's rgb is the float whose bits are 0x00FF8000 (older writers print that).
  float packed_as_float = 0.0f;
  const std::uint32_t packed = 0x00ff8000u;
  std::memcpy(&packed_as_float, &packed, 4);
  char float_text[64];
  std::snprintf(float_text, sizeof(float_text), "%.9g", static_cast<double>(packed_as_float));
  const std::string path = write_file(dir / "pcl.pcd",
                                      "# .PCD v0.7 - Point Cloud Data file format\n"
                                      "VERSION 0.7\n"
                                      "FIELDS normal_x x y z rgb histogram curvature\n"
                                      "SIZE 4 8 8 8 4 4 4\n"
                                      "TYPE F F F F F F F\n"
                                      "COUNT 1 1 1 1 1 3 1\n"
                                      "WIDTH 2\n"
                                      "HEIGHT 1\n"
                                      "VIEWPOINT 0 0 0 1 0 0 0\n"
                                      "POINTS 2\n"
                                      "DATA ascii\n"
                                      "0.5 1 2 3 4278190335 1 2 3 0.01\n"
                                      "nan 4.5 -5 6e-3 " +
                                          std::string(float_text) + " 1 2 3 nan\n");
  const PointCloud cloud = read_pcd(path);
  ASSERT_EQ(cloud.size(), 2u);
  ASSERT_TRUE(cloud.has_colors());
  EXPECT_EQ(cloud.points[0], Eigen::Vector3f(1.0f, 2.0f, 3.0f));
  EXPECT_EQ(cloud.points[1], Eigen::Vector3f(4.5f, -5.0f, 6e-3f));
  EXPECT_EQ(cloud.colors[0], (PointCloud::Rgb{0, 0, 255}));  // 0xFF0000FF: alpha dropped
  EXPECT_EQ(cloud.colors[1], (PointCloud::Rgb{255, 128, 0}));
}

TEST(PointCloudIo, ReadsBinaryPcdWithDoublesAndRgba) {
  const fs::path dir = test_dir();
  std::string data = "VERSION .7\nFIELDS x y z _ rgba\nSIZE 8 8 8 1 4\nTYPE F F F U U\nCOUNT 1 1 1 4 1\n"
                     "WIDTH 1\nHEIGHT 2\nPOINTS 2\nDATA binary\n";
  for (int i = 0; i < 2; ++i) {
    for (double v : {1.0 + i, 2.0, -3.5}) data.append(reinterpret_cast<const char*>(&v), 8);
    data.append(4, '\0');  // padding
    const std::uint32_t rgba = 0x80102030u + static_cast<std::uint32_t>(i);
    data.append(reinterpret_cast<const char*>(&rgba), 4);
  }
  const std::string path = write_file(dir / "organised.pcd", data);
  const PointCloud cloud = read_pcd(path);
  ASSERT_EQ(cloud.size(), 2u);
  EXPECT_EQ(cloud.points[1], Eigen::Vector3f(2.0f, 2.0f, -3.5f));
  EXPECT_EQ(cloud.colors[1], (PointCloud::Rgb{0x10, 0x20, 0x31}));
}

TEST(PointCloudIo, ReadsBinaryCompressedPcd) {
  // Two points, fields stored one after the other (x0 x1 y0 y1 z0 z1) and LZF-compressed: a literal
  // run of x, a back reference copying x for y (y == x), a literal run of z.
  const float x[2] = {1.5f, -2.0f};
  const float z[2] = {7.0f, 8.25f};
  std::string lzf;
  lzf += static_cast<char>(7);  // literal run of 8 bytes
  lzf.append(reinterpret_cast<const char*>(x), 8);
  lzf += static_cast<char>(0xC0);  // back reference: length 6 + 2 = 8 ...
  lzf += static_cast<char>(7);     // ... from 7 + 1 = 8 bytes back
  lzf += static_cast<char>(7);
  lzf.append(reinterpret_cast<const char*>(z), 8);
  std::string data = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA binary_compressed\n";
  const std::uint32_t sizes[2] = {static_cast<std::uint32_t>(lzf.size()), 24u};
  data.append(reinterpret_cast<const char*>(sizes), 8);
  data += lzf;
  const fs::path dir = test_dir();
  const PointCloud cloud = read_pcd(write_file(dir / "compressed.pcd", data));
  ASSERT_EQ(cloud.size(), 2u);
  EXPECT_FALSE(cloud.has_colors());
  EXPECT_EQ(cloud.points[0], Eigen::Vector3f(1.5f, 1.5f, 7.0f));
  EXPECT_EQ(cloud.points[1], Eigen::Vector3f(-2.0f, -2.0f, 8.25f));

  std::string corrupt = data;
  corrupt[corrupt.size() - 10] = static_cast<char>(200);  // the back reference now points before the start
  const std::string path = write_file(dir / "corrupt.pcd", corrupt);
  expect_input_error([&] { read_pcd(path); }, path, "corrupt LZF data");

  // A header claiming more than LZF can expand its compressed bytes into is refused before the allocation
  // (357913941 points of 12 bytes from 0 compressed bytes: 4 GiB).
  std::string huge = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 357913941\nHEIGHT 1\nPOINTS 357913941\nDATA binary_compressed\n";
  const std::uint32_t huge_sizes[2] = {0u, 357913941u * 12u};
  huge.append(reinterpret_cast<const char*>(huge_sizes), 8);
  const std::string huge_path = write_file(dir / "huge.pcd", huge);
  expect_input_error([&] { read_pcd(huge_path); }, huge_path, "0 compressed bytes cannot hold the 4294967292 bytes");
}

// ---------------------------------------------------------------------------------------------------
// Cloud operations

TEST(PointCloud, TransformMapsPointsAndKeepsColours) {
  const PointCloud cloud = random_cloud(200, true, 7);
  Eigen::Isometry3d T_world_robot = Eigen::Isometry3d::Identity();
  T_world_robot.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  T_world_robot.translation() = Eigen::Vector3d(1.0, -2.0, 0.5);
  PointCloud small = cloud;
  small.points.pop_back();  // drop the float-max point: its image overflows
  small.colors.pop_back();
  const PointCloud cloud_world = transformed(small, T_world_robot);
  ASSERT_EQ(cloud_world.size(), small.size());
  EXPECT_EQ(cloud_world.colors, small.colors);
  for (std::size_t i = 0; i < small.size(); ++i) {
    const Eigen::Vector3d expected = T_world_robot * small.points[i].cast<double>();
    EXPECT_LT((cloud_world.points[i].cast<double>() - expected).norm(), 1e-4) << i;
  }
  PointCloud in_place = small;
  transform_in_place(in_place, T_world_robot);
  expect_same(cloud_world, in_place);
  const PointCloud back = transformed(cloud_world, T_world_robot.inverse());
  for (std::size_t i = 0; i < small.size(); ++i) EXPECT_LT((back.points[i] - small.points[i]).norm(), 1e-4f) << i;
}

TEST(PointCloud, RemoveNonFiniteKeepsColoursAligned) {
  PointCloud cloud;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  cloud.push_back({0, 0, 0}, {0, 0, 0});
  cloud.push_back({nan, 0, 0}, {1, 1, 1});
  cloud.push_back({1, 1, 1}, {2, 2, 2});
  cloud.push_back({0, -inf, 0}, {3, 3, 3});
  cloud.push_back({0, 0, nan}, {4, 4, 4});
  cloud.push_back({2, 2, 2}, {5, 5, 5});
  EXPECT_EQ(remove_non_finite(cloud), 3u);
  ASSERT_EQ(cloud.size(), 3u);
  ASSERT_TRUE(cloud.has_colors());
  EXPECT_EQ(cloud.points[1], Eigen::Vector3f(1, 1, 1));
  EXPECT_EQ(cloud.colors[1], (PointCloud::Rgb{2, 2, 2}));
  EXPECT_EQ(cloud.colors[2], (PointCloud::Rgb{5, 5, 5}));
  EXPECT_EQ(remove_non_finite(cloud), 0u);

  PointCloud plain;
  plain.push_back({nan, nan, nan});
  EXPECT_EQ(remove_non_finite(plain), 1u);
  EXPECT_TRUE(plain.empty());
}

TEST(PointCloud, BoundsIgnoreNonFinitePoints) {
  EXPECT_EQ(bounds(PointCloud{}).min, Eigen::Vector3f::Zero());
  EXPECT_EQ(bounds(PointCloud{}).max, Eigen::Vector3f::Zero());
  PointCloud cloud;
  cloud.push_back({std::numeric_limits<float>::quiet_NaN(), 100, 100});
  cloud.push_back({1, -2, 3});
  cloud.push_back({-4, 5, 0.5f});
  cloud.push_back({0, 0, std::numeric_limits<float>::infinity()});
  const Bounds3f b = bounds(cloud);
  EXPECT_EQ(b.min, Eigen::Vector3f(-4, -2, 0.5f));
  EXPECT_EQ(b.max, Eigen::Vector3f(1, 5, 3));
}

TEST(PointCloud, AppendKeepsColoursOnlyWhenBothHaveThem) {
  PointCloud coloured;
  coloured.push_back({0, 0, 0}, {1, 2, 3});
  PointCloud plain;
  plain.push_back({1, 1, 1});
  PointCloud a;
  a.append(coloured);
  a.append(coloured);
  EXPECT_EQ(a.size(), 2u);
  EXPECT_TRUE(a.has_colors());
  a.append(plain);
  EXPECT_EQ(a.size(), 3u);
  EXPECT_FALSE(a.has_colors());
}

TEST(PointCloud, NormalsFollowTransformsAppendsAndRemovals) {
  PointCloud cloud;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cloud.push_back({1, 0, 0}, {1, 1, 1}, Eigen::Vector3f(1, 0, 0));
  cloud.push_back({nan, 0, 0}, {2, 2, 2}, Eigen::Vector3f(0, 1, 0));
  cloud.push_back({0, 0, 1}, {3, 3, 3}, Eigen::Vector3f(0, 0, 1));
  cloud.push_back({0, 2, 0}, {4, 4, 4}, Eigen::Vector3f(nan, 0, 1));
  ASSERT_TRUE(cloud.has_normals());
  EXPECT_EQ(remove_non_finite(cloud), 1u);
  ASSERT_TRUE(cloud.has_normals());
  EXPECT_EQ(cloud.normals[1], Eigen::Vector3f(0, 0, 1));
  // A finite point's NaN normal becomes unknown (zero); the point stays.
  ASSERT_EQ(cloud.size(), 3u);
  EXPECT_EQ(cloud.points[2], Eigen::Vector3f(0, 2, 0));
  EXPECT_EQ(cloud.normals[2], Eigen::Vector3f::Zero());
  cloud.points.pop_back();
  cloud.colors.pop_back();
  cloud.normals.pop_back();

  // Rotated with the points, not translated.
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(1.5707963267948966, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(5, 6, 7);
  const PointCloud moved = transformed(cloud, T);
  EXPECT_LT((moved.normals[0] - Eigen::Vector3f(0, 1, 0)).norm(), 1e-6f);
  EXPECT_LT((moved.normals[1] - Eigen::Vector3f(0, 0, 1)).norm(), 1e-6f);

  // push_back_from copies whatever the source has.
  PointCloud copy;
  copy.push_back_from(cloud, 1);
  EXPECT_TRUE(copy.has_colors());
  ASSERT_TRUE(copy.has_normals());
  EXPECT_EQ(copy.normals[0], cloud.normals[1]);

  // Appending keeps normals while every part has them; an empty part changes nothing.
  PointCloud all;
  all.append(cloud);
  all.append(PointCloud{});
  all.append(cloud);
  EXPECT_TRUE(all.has_normals());
  EXPECT_EQ(all.size(), 4u);
  // A part without normals gets unknown (zero) ones: the others' stay, in either order.
  PointCloud plain;
  plain.push_back({1, 1, 1}, {0, 0, 0});
  all.append(plain);
  ASSERT_TRUE(all.has_normals());
  EXPECT_TRUE(all.has_colors());
  EXPECT_EQ(all.normals[0], cloud.normals[0]);
  EXPECT_EQ(all.normals[4], Eigen::Vector3f::Zero());
  PointCloud plain_first = plain;
  plain_first.append(cloud);
  ASSERT_TRUE(plain_first.has_normals());
  EXPECT_EQ(plain_first.normals[0], Eigen::Vector3f::Zero());
  EXPECT_EQ(plain_first.normals[1], cloud.normals[0]);
  EXPECT_EQ(plain_first.normals[2], cloud.normals[1]);
  // Without normals on either side there are none.
  PointCloud none = plain;
  none.append(plain);
  EXPECT_FALSE(none.has_normals());
  EXPECT_TRUE(none.normals.empty());
  all.clear();
  EXPECT_TRUE(all.normals.empty());
}

}  // namespace
}  // namespace fleetslam::core
