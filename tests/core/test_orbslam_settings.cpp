// ORB-SLAM settings reader on synthetic files in both layouts, each sensor mode, and every kind of bad
// input (each error must name the file and the key); writer round trips in every mode and its refusals.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/orbslam_settings.hpp"

namespace fleetslam::core {
namespace {

namespace fs = std::filesystem;

// ORB-SLAM2's TUM1.yaml (RGB-D), abridged.
const char* const kOldRgbd = R"(%YAML:1.0
Camera.fx: 517.306408
Camera.fy: 516.469215
Camera.cx: 318.643040
Camera.cy: 255.313989
Camera.k1: 0.262383
Camera.k2: -0.953104
Camera.p1: -0.005358
Camera.p2: 0.002628
Camera.k3: 1.163314
Camera.width: 640
Camera.height: 480
Camera.fps: 30.0
Camera.bf: 40.0
Camera.RGB: 1
ThDepth: 40.0
DepthMapFactor: 5000.0
ORBextractor.nFeatures: 1000
ORBextractor.scaleFactor: 1.2
ORBextractor.nLevels: 8
ORBextractor.iniThFAST: 20
ORBextractor.minThFAST: 7
Viewer.PointSize:2
)";

// ORB-SLAM2's monocular layout.
const char* const kOldMono = R"(%YAML:1.0
Camera.fx: 458.654
Camera.fy: 457.296
Camera.cx: 367.215
Camera.cy: 248.375
Camera.k1: -0.28340811
Camera.k2: 0.07395907
Camera.p1: 0.00019359
Camera.p2: 1.76187114e-05
Camera.width: 752
Camera.height: 480
Camera.fps: 20.0
Camera.RGB: 0
ORBextractor.nFeatures: 1500
ORBextractor.scaleFactor: 1.25
ORBextractor.nLevels: 6
ORBextractor.iniThFAST: 25
ORBextractor.minThFAST: 9
)";

// ORB-SLAM2's rectified stereo layout (KITTI-like): one camera and bf.
const char* const kOldStereo = R"(%YAML:1.0
Camera.fx: 718.856
Camera.fy: 718.856
Camera.cx: 607.1928
Camera.cy: 185.2157
Camera.k1: 0.0
Camera.k2: 0.0
Camera.p1: 0.0
Camera.p2: 0.0
Camera.width: 1241
Camera.height: 376
Camera.fps: 10.0
Camera.bf: 386.1448
Camera.RGB: 1
ThDepth: 35
)";

const char* const kV1Camera1 = R"(%YAML:1.0
File.version: "1.0"
Camera.type: "PinHole"
Camera1.fx: 458.654
Camera1.fy: 457.296
Camera1.cx: 367.215
Camera1.cy: 248.375
Camera1.k1: -0.28340811
Camera1.k2: 0.07395907
Camera1.p1: 0.00019359
Camera1.p2: 1.76187114e-05
Camera.width: 752
Camera.height: 480
Camera.fps: 20
Camera.RGB: 1
)";

const char* const kV1Camera2 = R"(Camera2.fx: 457.587
Camera2.fy: 456.134
Camera2.cx: 379.999
Camera2.cy: 255.238
Camera2.k1: -0.28368365
Camera2.k2: 0.07451284
Camera2.p1: -0.00010473
Camera2.p2: -3.55590700e-05
Stereo.ThDepth: 60.0
)";

std::string matrix(const std::string& key, const std::string& data, int rows = 4, int cols = 4,
                   const std::string& dt = "f") {
  return key + ": !!opencv-matrix\n  rows: " + std::to_string(rows) + "\n  cols: " + std::to_string(cols) +
         "\n  dt: " + dt + "\n  data: [" + data + "]\n";
}

const std::string kEurocT_c1_c2 =
    "0.999997256477797,-0.002317135723275,-0.000343393120620,0.110074137800478,"
    "0.002312067192432,0.999898048507103,-0.014090668452683,-0.000156612054392,"
    "0.000376008102320,0.014089835846691,0.999900662638081,0.000889382785432,0,0,0,1.0";

const std::string kEurocT_b_c1 =
    "0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,"
    "0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,"
    "-0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949, 0.0, 0.0, 0.0, 1.0";

const std::string kImuNoise =
    "IMU.NoiseGyro: 1.7e-04\nIMU.NoiseAcc: 2.0e-03\nIMU.GyroWalk: 1.9393e-05\nIMU.AccWalk: 3.e-03\n"
    "IMU.Frequency: 200.0\n";

std::string v1_stereo() { return std::string(kV1Camera1) + kV1Camera2 + matrix("Stereo.T_c1_c2", kEurocT_c1_c2); }
std::string v1_imu() { return matrix("IMU.T_b_c1", kEurocT_b_c1) + kImuNoise; }

// The text with the line of `key` replaced by "key: value" (or removed when value is empty).
std::string with(const std::string& text, const std::string& key, const std::string& value) {
  std::istringstream in(text);
  std::string out;
  std::string line;
  bool found = false;
  while (std::getline(in, line)) {
    if (line.rfind(key + ":", 0) == 0) {
      found = true;
      if (!value.empty()) out += key + ": " + value + "\n";
    } else {
      out += line + "\n";
    }
  }
  EXPECT_TRUE(found) << key;
  return out;
}
std::string without(const std::string& text, const std::string& key) { return with(text, key, ""); }

class OrbSlamSettingsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("fleetslam_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path write(const std::string& name, const std::string& text) const {
    const fs::path path = dir_ / name;
    std::ofstream(path) << text;
    return path;
  }

  OrbSlamSettings read(const std::string& text, std::optional<SensorMode> mode = std::nullopt) const {
    return read_orbslam_settings(write("settings.yaml", text), mode);
  }

  // Reads a bad file, expects an InputError at "<file>:<key>" whose reason contains `why_part`.
  void expect_error(const std::string& text, const std::string& key, const std::string& why_part,
                    std::optional<SensorMode> mode = std::nullopt) const {
    const fs::path path = write("bad.yaml", text);
    try {
      read_orbslam_settings(path, mode);
      ADD_FAILURE() << "no error for key " << key;
    } catch (const InputError& e) {
      const std::string where = key.empty() ? path.string() : path.string() + ":" + key;
      EXPECT_EQ(e.where(), where) << e.what();
      EXPECT_NE(e.why().find(why_part), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("bad.yaml"), std::string::npos) << e.what();
    }
  }

  fs::path dir_;
};

TEST_F(OrbSlamSettingsTest, OldLayoutRgbd) {
  const OrbSlamSettings s = read(kOldRgbd);
  EXPECT_EQ(s.rig.mode, SensorMode::kRgbd);
  EXPECT_EQ(s.rig.cam0.width(), 640);
  EXPECT_EQ(s.rig.cam0.height(), 480);
  EXPECT_DOUBLE_EQ(s.rig.cam0.fx(), 517.306408);
  EXPECT_DOUBLE_EQ(s.rig.cam0.fy(), 516.469215);
  EXPECT_DOUBLE_EQ(s.rig.cam0.cx(), 318.643040);
  EXPECT_DOUBLE_EQ(s.rig.cam0.cy(), 255.313989);
  EXPECT_DOUBLE_EQ(s.rig.cam0.distortion().k1, 0.262383);
  EXPECT_DOUBLE_EQ(s.rig.cam0.distortion().k2, -0.953104);
  EXPECT_DOUBLE_EQ(s.rig.cam0.distortion().p1, -0.005358);
  EXPECT_DOUBLE_EQ(s.rig.cam0.distortion().p2, 0.002628);
  EXPECT_DOUBLE_EQ(s.rig.cam0.distortion().k3, 1.163314);
  EXPECT_DOUBLE_EQ(s.rig.depth_scale, 5000.0);
  EXPECT_DOUBLE_EQ(s.rig.bf, 40.0);
  EXPECT_DOUBLE_EQ(s.rig.fps, 30.0);
  EXPECT_TRUE(s.rig.rgb_order);
  EXPECT_DOUBLE_EQ(s.th_depth, 40.0);
  EXPECT_NEAR(s.close_depth_m(), 40.0 * 40.0 / 517.306408, 1e-12);
  EXPECT_FALSE(s.rig.cam1.has_value());
  EXPECT_FALSE(s.rig.imu.has_value());
  EXPECT_FALSE(s.rig.T_body_cam0.has_value());
  EXPECT_EQ(s.orb.num_features, 1000);
  EXPECT_DOUBLE_EQ(s.orb.scale_factor, 1.2);
  EXPECT_EQ(s.orb.num_levels, 8);
  EXPECT_EQ(s.orb.ini_fast_threshold, 20);
  EXPECT_EQ(s.orb.min_fast_threshold, 7);
  EXPECT_EQ(s.new_width, 0);
}

TEST_F(OrbSlamSettingsTest, OldLayoutMonocular) {
  const OrbSlamSettings s = read(kOldMono);
  EXPECT_EQ(s.rig.mode, SensorMode::kMonocular);
  EXPECT_DOUBLE_EQ(s.rig.cam0.fx(), 458.654);
  EXPECT_DOUBLE_EQ(s.rig.cam0.distortion().k3, 0.0);  // absent -> 0
  EXPECT_FALSE(s.rig.rgb_order);
  EXPECT_DOUBLE_EQ(s.rig.fps, 20.0);
  EXPECT_EQ(s.orb.num_features, 1500);
  EXPECT_DOUBLE_EQ(s.orb.scale_factor, 1.25);
  EXPECT_EQ(s.orb.num_levels, 6);
  EXPECT_EQ(s.orb.ini_fast_threshold, 25);
  EXPECT_EQ(s.orb.min_fast_threshold, 9);
  EXPECT_FALSE(s.rig.cam1.has_value());
  EXPECT_EQ(s.th_depth, 0.0);
}

TEST_F(OrbSlamSettingsTest, DefaultsForOptionalKeys) {
  std::string text = kOldMono;
  for (const char* key : {"Camera.k1", "Camera.k2", "Camera.p1", "Camera.p2", "Camera.fps", "Camera.RGB",
                          "ORBextractor.nFeatures", "ORBextractor.scaleFactor", "ORBextractor.nLevels",
                          "ORBextractor.iniThFAST", "ORBextractor.minThFAST"}) {
    text = without(text, key);
  }
  const OrbSlamSettings s = read(text);
  EXPECT_TRUE(s.rig.cam0.distortion().is_zero());
  EXPECT_DOUBLE_EQ(s.rig.fps, SensorRig{}.fps);
  EXPECT_FALSE(s.rig.rgb_order);  // an absent Camera.RGB reads as 0, as ORB-SLAM's FileStorage read does
  EXPECT_EQ(s.orb.num_features, OrbExtractorSettings{}.num_features);
  EXPECT_DOUBLE_EQ(s.orb.scale_factor, OrbExtractorSettings{}.scale_factor);
}

TEST_F(OrbSlamSettingsTest, OldLayoutRectifiedStereoFromBf) {
  const OrbSlamSettings s = read(kOldStereo);
  EXPECT_EQ(s.rig.mode, SensorMode::kStereo);
  ASSERT_TRUE(s.rig.cam1.has_value());
  EXPECT_DOUBLE_EQ(s.rig.cam1->fx(), s.rig.cam0.fx());
  EXPECT_DOUBLE_EQ(s.rig.cam1->cx(), s.rig.cam0.cx());
  EXPECT_DOUBLE_EQ(s.rig.bf, 386.1448);
  EXPECT_TRUE(s.rig.T_cam0_cam1.linear().isIdentity(0.0));
  EXPECT_NEAR(s.rig.T_cam0_cam1.translation().x(), 386.1448 / 718.856, 1e-15);
  EXPECT_EQ(s.rig.T_cam0_cam1.translation().y(), 0.0);
  EXPECT_EQ(s.rig.T_cam0_cam1.translation().z(), 0.0);
  EXPECT_DOUBLE_EQ(s.th_depth, 35.0);  // an integer is accepted where a number is expected
}

// ORB-SLAM2's EuRoC.yaml: Camera.* is the rectified camera the LEFT/RIGHT maps produce, for raw images.
// Read as a rectified pair, raw images were stereo-matched as if rectified: refused, naming the key.
TEST_F(OrbSlamSettingsTest, OldLayoutRectificationMatricesAreRefused) {
  const std::string left_k =
      "LEFT.K: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [458.654, 0.0, 367.215, 0.0, 457.296, "
      "248.375, 0.0, 0.0, 1.0]\n";
  expect_error(kOldStereo + left_k, "LEFT.K", "rectification (LEFT.*/RIGHT.* K, D, R, P) is not supported");
}

TEST_F(OrbSlamSettingsTest, V1Stereo) {
  const OrbSlamSettings s = read(v1_stereo());
  EXPECT_EQ(s.rig.mode, SensorMode::kStereo);
  EXPECT_DOUBLE_EQ(s.rig.cam0.fx(), 458.654);
  ASSERT_TRUE(s.rig.cam1.has_value());
  EXPECT_DOUBLE_EQ(s.rig.cam1->fx(), 457.587);
  EXPECT_DOUBLE_EQ(s.rig.cam1->cy(), 255.238);
  EXPECT_DOUBLE_EQ(s.rig.cam1->distortion().p2, -3.55590700e-05);
  EXPECT_EQ(s.rig.cam1->width(), 752);
  // Stereo.T_c1_c2 is the pose of camera 2 in camera 1: cam1 sits 11 cm along +x of cam0.
  const Eigen::Vector3d t = s.rig.T_cam0_cam1.translation();
  EXPECT_NEAR(t.x(), 0.110074137800478, 1e-7);
  EXPECT_NEAR(t.y(), -0.000156612054392, 1e-7);
  EXPECT_NEAR(s.rig.T_cam0_cam1.linear()(1, 2), -0.014090668452683, 1e-6);
  const Eigen::Matrix3d R = s.rig.T_cam0_cam1.linear();
  EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_NEAR(s.rig.bf, t.norm() * 458.654, 1e-9);
  EXPECT_DOUBLE_EQ(s.th_depth, 60.0);
  EXPECT_FALSE(s.rig.imu.has_value());
}

// ORB-SLAM3's TUM-VI settings: KannalaBrandt8 cameras (the equidistant model), k1..k4 each.
TEST_F(OrbSlamSettingsTest, V1FisheyeStereo) {
  std::string text = with(v1_stereo(), "Camera.type", "\"KannalaBrandt8\"");
  for (const char* camera : {"Camera1.", "Camera2."}) {
    const std::string c(camera);
    text = without(without(text, c + "p1"), c + "p2");
    text = with(text, c + "k1", "0.0034823894022493434");
    text = with(text, c + "k2", "0.0007150348452162257");
    text += c + "k3: -0.0020532361418706202\n" + c + "k4: 0.00020293673591811182\n";
  }
  const OrbSlamSettings s = read(text);
  EXPECT_EQ(s.rig.mode, SensorMode::kStereo);
  for (const PinholeCamera* camera : {&s.rig.cam0, &*s.rig.cam1}) {
    const Distortion& d = camera->distortion();
    EXPECT_TRUE(d.is_equidistant());
    EXPECT_FALSE(d.is_zero());
    EXPECT_DOUBLE_EQ(d.k1, 0.0034823894022493434);
    EXPECT_DOUBLE_EQ(d.k3, -0.0020532361418706202);
    EXPECT_DOUBLE_EQ(d.k4, 0.00020293673591811182);
    EXPECT_EQ(d.p1, 0.0);
  }
}

TEST_F(OrbSlamSettingsTest, V1StereoInertial) {
  const OrbSlamSettings s = read(v1_stereo() + v1_imu());
  EXPECT_EQ(s.rig.mode, SensorMode::kStereoInertial);
  ASSERT_TRUE(s.rig.imu.has_value());
  EXPECT_DOUBLE_EQ(s.rig.imu->gyro_noise_density, 1.7e-4);
  EXPECT_DOUBLE_EQ(s.rig.imu->accel_noise_density, 2.0e-3);
  EXPECT_DOUBLE_EQ(s.rig.imu->gyro_random_walk, 1.9393e-05);
  EXPECT_DOUBLE_EQ(s.rig.imu->accel_random_walk, 3.0e-3);
  EXPECT_DOUBLE_EQ(s.rig.imu->rate_hz, 200.0);
  ASSERT_TRUE(s.rig.T_body_cam0.has_value());
  EXPECT_NEAR(s.rig.T_body_cam0->translation().x(), -0.0216401454975, 1e-8);
  EXPECT_NEAR(s.rig.T_body_cam0->translation().y(), -0.064676986768, 1e-8);
  EXPECT_NEAR(s.rig.T_body_cam0->linear()(0, 1), -0.999880929698, 1e-6);
}

TEST_F(OrbSlamSettingsTest, V1MonoInertialWithResize) {
  const OrbSlamSettings s = read(std::string(kV1Camera1) + "Camera.newWidth: 600\nCamera.newHeight: 350\n" + v1_imu());
  EXPECT_EQ(s.rig.mode, SensorMode::kMonoInertial);
  EXPECT_FALSE(s.rig.cam1.has_value());
  EXPECT_TRUE(s.rig.imu.has_value());
  EXPECT_EQ(s.new_width, 600);
  EXPECT_EQ(s.new_height, 350);
  EXPECT_EQ(s.rig.cam0.width(), 752);  // the recorded calibration is kept
}

TEST_F(OrbSlamSettingsTest, V1Rectified) {
  std::string camera = with(kV1Camera1, "Camera.type", "\"Rectified\"");
  // ORB-SLAM3 ignores a Rectified camera's distortion: such keys are a contradiction, named.
  expect_error(camera + "Stereo.b: 0.0745\nStereo.ThDepth: 40.0\n", "Camera1.k1", "ideal pinhole");
  for (const char* key : {"Camera1.k1", "Camera1.k2", "Camera1.p1", "Camera1.p2"}) camera = without(camera, key);
  const std::string text = camera + "Stereo.b: 0.0745\nStereo.ThDepth: 40.0\n";
  const OrbSlamSettings s = read(text);
  EXPECT_EQ(s.rig.mode, SensorMode::kStereo);
  ASSERT_TRUE(s.rig.cam1.has_value());
  EXPECT_DOUBLE_EQ(s.rig.T_cam0_cam1.translation().x(), 0.0745);
  EXPECT_DOUBLE_EQ(s.rig.bf, 0.0745 * 458.654);
}

TEST_F(OrbSlamSettingsTest, V1Rgbd) {
  const std::string text =
      std::string(kV1Camera1) + "Stereo.ThDepth: 40.0\nStereo.b: 0.07732\nRGBD.DepthMapFactor: 5000.0\n";
  const OrbSlamSettings s = read(text);
  EXPECT_EQ(s.rig.mode, SensorMode::kRgbd);  // Stereo.b is the virtual baseline here, not a second camera
  EXPECT_DOUBLE_EQ(s.rig.depth_scale, 5000.0);
  EXPECT_DOUBLE_EQ(s.rig.bf, 0.07732 * 458.654);
  EXPECT_DOUBLE_EQ(s.th_depth, 40.0);
  EXPECT_FALSE(s.rig.cam1.has_value());
}

TEST_F(OrbSlamSettingsTest, GivenModeOverridesInference) {
  const OrbSlamSettings mono = read(kOldRgbd, SensorMode::kMonocular);
  EXPECT_EQ(mono.rig.mode, SensorMode::kMonocular);
  EXPECT_FALSE(mono.rig.cam1.has_value());
  const OrbSlamSettings stereo = read(v1_stereo() + v1_imu(), SensorMode::kStereo);
  EXPECT_EQ(stereo.rig.mode, SensorMode::kStereo);
  EXPECT_TRUE(stereo.rig.imu.has_value());  // present keys are still read
  // A mode needs its keys.
  expect_error(kOldMono, "Camera.bf", "required key is missing", SensorMode::kStereo);
  expect_error(kOldMono, "DepthMapFactor", "required key is missing", SensorMode::kRgbd);
  expect_error(kOldMono, "Tbc", "required key is missing", SensorMode::kMonoInertial);
  expect_error(kV1Camera1, "Camera2.fx", "required key is missing", SensorMode::kStereo);
}

TEST_F(OrbSlamSettingsTest, OldLayoutInertialWithTbc) {
  const std::string text = std::string(kOldMono) + matrix("Tbc", kEurocT_b_c1) + kImuNoise;
  const OrbSlamSettings s = read(text);
  EXPECT_EQ(s.rig.mode, SensorMode::kMonoInertial);
  ASSERT_TRUE(s.rig.T_body_cam0.has_value());
  EXPECT_NEAR(s.rig.T_body_cam0->translation().z(), 0.00981073058949, 1e-8);
}

TEST_F(OrbSlamSettingsTest, NearlyRigidMatrixIsOrthonormalised) {
  // A rotation about z by 0.1 rad written with 4 digits: off orthonormal by ~1e-5.
  const std::string data = "0.9950,-0.0998,0,0.11, 0.0998,0.9950,0,0, 0,0,1,0, 0,0,0,1";
  const OrbSlamSettings s = read(std::string(kV1Camera1) + kV1Camera2 + matrix("Stereo.T_c1_c2", data, 4, 4, "d"));
  const Eigen::Matrix3d R = s.rig.T_cam0_cam1.linear();
  EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-14);
  EXPECT_NEAR(R(0, 1), -0.0998, 1e-4);
}

TEST_F(OrbSlamSettingsTest, MissingFile) {
  const fs::path path = dir_ / "nope.yaml";
  try {
    read_orbslam_settings(path);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), path.string());
    EXPECT_NE(e.why().find("not found"), std::string::npos) << e.what();
  }
  EXPECT_THROW(read_orbslam_settings(dir_), InputError);  // a directory
}

TEST_F(OrbSlamSettingsTest, MalformedFiles) {
  expect_error("", "", "%YAML:1.0");
  expect_error("Camera.fx: 500\n", "", "%YAML:1.0");  // plain YAML without the FileStorage header
  // Parse errors name the line OpenCV stopped at.
  for (const char* text : {"%YAML:1.0\nCamera.fx: [1, 2\nCamera.fy: 3\n", "%YAML:1.0\nCamera.fx: 1\n  Camera.fy: 3\nfoo\n"}) {
    const fs::path path = write("malformed.yaml", text);
    try {
      read_orbslam_settings(path);
      ADD_FAILURE() << "no error for " << text;
    } catch (const InputError& e) {
      EXPECT_EQ(e.where(), path.string() + ":3") << e.what();
      EXPECT_NE(e.why().find("malformed OpenCV YAML"), std::string::npos) << e.what();
    }
  }
}

TEST_F(OrbSlamSettingsTest, MissingRequiredKeyNamesFileAndKey) {
  const fs::path path = write("TUM1.yaml", without(kOldRgbd, "Camera.fx"));
  try {
    read_orbslam_settings(path);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), path.string() + ":Camera.fx: required key is missing");
  }
  for (const char* key : {"Camera.fy", "Camera.cx", "Camera.cy", "Camera.width", "Camera.height", "ThDepth"}) {
    expect_error(without(kOldRgbd, key), key, "required key is missing");
  }
  expect_error(without(kOldRgbd, "Camera.bf"), "Camera.bf", "required key is missing");  // RGB-D needs bf
  expect_error(without(kOldStereo, "ThDepth"), "ThDepth", "required key is missing");
  expect_error(std::string(kV1Camera1) + kV1Camera2, "Stereo.T_c1_c2", "required key is missing");
  expect_error(without(v1_stereo(), "Camera2.cy"), "Camera2.cy", "required key is missing");
  expect_error(without(v1_stereo() + v1_imu(), "IMU.NoiseAcc"), "IMU.NoiseAcc", "required key is missing");
  expect_error(std::string(kV1Camera1) + kImuNoise, "IMU.T_b_c1", "required key is missing");
  expect_error(with(kV1Camera1, "Camera.type", "\"Rectified\""), "Stereo.b", "required key is missing");
}

TEST_F(OrbSlamSettingsTest, MissingKeyOfTheOtherLayoutGivesAHint) {
  expect_error(without(kV1Camera1, "File.version"), "Camera.fx", "File.version");
  std::string v1_with_old_names = kOldMono;
  v1_with_old_names = "%YAML:1.0\nFile.version: \"1.0\"\n" + v1_with_old_names.substr(10);
  expect_error(v1_with_old_names, "Camera1.fx", "old layout");
}

TEST_F(OrbSlamSettingsTest, WrongTypes) {
  expect_error(with(kOldRgbd, "Camera.fx", "\"abc\""), "Camera.fx", "expected a number, got the string 'abc'");
  expect_error(with(kOldRgbd, "Camera.cx", "[1, 2]"), "Camera.cx", "expected a number, got a list");
  expect_error(with(kOldRgbd, "Camera.width", "640.5"), "Camera.width", "expected an integer");
  expect_error(with(kOldRgbd, "ORBextractor.nLevels", "\"eight\""), "ORBextractor.nLevels", "expected an integer");
  expect_error(with(kOldRgbd, "Camera.k1", ".nan"), "Camera.k1", "finite");
  expect_error(with(kOldRgbd, "Camera.RGB", "2"), "Camera.RGB", "0 (BGR) or 1 (RGB)");
  expect_error(std::string(kV1Camera1) + kV1Camera2 + "Stereo.T_c1_c2: 0.11\n", "Stereo.T_c1_c2",
               "expected a 4x4 !!opencv-matrix");
  // A width written as 640.0 is still an integer.
  EXPECT_EQ(read(with(kOldRgbd, "Camera.width", "640.0")).rig.cam0.width(), 640);
}

TEST_F(OrbSlamSettingsTest, OutOfRangeValues) {
  expect_error(with(kOldRgbd, "Camera.fx", "-517.3"), "Camera.fx", "focal length must be positive");
  expect_error(with(kOldRgbd, "Camera.fy", "0"), "Camera.fy", "focal length must be positive");
  expect_error(with(kOldRgbd, "Camera.height", "0"), "Camera.height", "positive");
  expect_error(with(kOldRgbd, "DepthMapFactor", "0.0"), "DepthMapFactor", "must be positive");
  expect_error(with(kOldRgbd, "Camera.fps", "-1"), "Camera.fps", "must be positive");
  expect_error(with(kOldStereo, "Camera.bf", "0"), "Camera.bf", "must be positive");
  expect_error(with(kOldRgbd, "ORBextractor.scaleFactor", "0.9"), "ORBextractor.scaleFactor", "greater than 1");
  expect_error(with(kOldRgbd, "ORBextractor.nFeatures", "0"), "ORBextractor.nFeatures", "positive");
  expect_error(with(v1_stereo() + v1_imu(), "IMU.Frequency", "0"), "IMU.Frequency", "must be positive");
  expect_error(with(kV1Camera1, "File.version", "\"2.0\""), "File.version", "unsupported version");
  // A fisheye camera reads all four Kannala-Brandt coefficients (ORB-SLAM3 needs them).
  expect_error(with(kV1Camera1, "Camera.type", "\"KannalaBrandt8\""), "Camera1.k3", "missing");
  expect_error(std::string(kOldStereo) + "Camera.type: \"KannalaBrandt8\"\nCamera.k3: 0\nCamera.k4: 0\n",
               "Camera.type", "Stereo.T_c1_c2");
  expect_error(with(kV1Camera1, "Camera.type", "\"Fancy\""), "Camera.type", "unknown camera type");
}

TEST_F(OrbSlamSettingsTest, BadMatrices) {
  const std::string base = std::string(kV1Camera1) + kV1Camera2;
  expect_error(base + matrix("Stereo.T_c1_c2", "1,0,0, 0,1,0, 0,0,1", 3, 3), "Stereo.T_c1_c2",
               "expected a 4x4 matrix, got 3x3");
  expect_error(base + matrix("Stereo.T_c1_c2", "1,0,0,0, 0,1,0,0, 0,0,1,0", 3, 4), "Stereo.T_c1_c2",
               "expected a 4x4 matrix, got 3x4");
  expect_error(base + matrix("Stereo.T_c1_c2", "1,0,0,0.1, 0,1,0,0"), "Stereo.T_c1_c2", "malformed !!opencv-matrix");
  expect_error(base + "Stereo.T_c1_c2: {rows: 4, cols: 4}\n", "Stereo.T_c1_c2", "malformed !!opencv-matrix");
  // Far from rigid: scaled rotation.
  expect_error(base + matrix("Stereo.T_c1_c2", "1.1,0,0,0.1, 0,1.1,0,0, 0,0,1.1,0, 0,0,0,1"), "Stereo.T_c1_c2",
               "not orthonormal");
  // Off by 2e-3, beyond the tolerance.
  expect_error(base + matrix("Stereo.T_c1_c2", "1,0.002,0,0.1, 0,1,0,0, 0,0,1,0, 0,0,0,1", 4, 4, "d"),
               "Stereo.T_c1_c2", "not orthonormal");
  expect_error(base + matrix("Stereo.T_c1_c2", "1,0,0,0.1, 0,1,0,0, 0,0,-1,0, 0,0,0,1"), "Stereo.T_c1_c2",
               "reflection");
  expect_error(base + matrix("Stereo.T_c1_c2", "1,0,0,0.1, 0,1,0,0, 0,0,1,0, 0,0.5,0,1"), "Stereo.T_c1_c2",
               "bottom row");
  expect_error(base + matrix("Stereo.T_c1_c2", "1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1"), "Stereo.T_c1_c2",
               "non-zero");  // zero baseline
  expect_error(std::string(kV1Camera1) + kImuNoise + matrix("IMU.T_b_c1", "2,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1"),
               "IMU.T_b_c1", "not orthonormal");
}


// ---- writer ---------------------------------------------------------------------------------------

// Awkward values (no short decimal) so that an inexact writer shows.
PinholeCamera distorted_camera(double fx) {
  return PinholeCamera(752, 480, fx, fx * (1.0 + 1.0 / 3e3), 367.215 + 1.0 / 7.0, 248.375 - 1.0 / 9.0,
                       Distortion{-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, -1.0 / 3e4});
}

Eigen::Isometry3d pose(double angle_rad, const Eigen::Vector3d& axis, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(angle_rad, axis.normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}

ImuNoise imu_noise() {
  ImuNoise imu;
  imu.gyro_noise_density = 1.6968e-4 / 3.0;
  imu.accel_noise_density = 2.0e-3 * std::sqrt(2.0);
  imu.gyro_random_walk = 1.9393e-05;
  imu.accel_random_walk = 3.0e-3 / 7.0;
  imu.rate_hz = 200.0;
  return imu;
}

OrbSlamSettings base_settings(SensorMode mode) {
  OrbSlamSettings s;
  s.rig.mode = mode;
  s.rig.cam0 = distorted_camera(458.654 + 1.0 / 3.0);
  s.rig.fps = 20.0;
  s.rig.rgb_order = false;
  s.orb = OrbExtractorSettings{1234, 1.2 + 1e-9, 7, 19, 6};
  return s;
}

void add_imu(OrbSlamSettings& s) {
  s.rig.imu = imu_noise();
  s.rig.T_body_cam0 = pose(1.9, {0.3, -1.0, 0.2}, {-0.0216401454975 / 3.0, -0.064676986768, 0.00981073058949});
}

// A stereo pair of two different cameras; bf as the readers derive it.
void add_second_camera(OrbSlamSettings& s) {
  s.rig.cam1 = distorted_camera(457.587 + 1.0 / 7.0);
  s.rig.T_cam0_cam1 = pose(0.0141, {1.0, 0.02, -0.3}, {0.110074137800478, -0.000156612054392, 0.000889382785432});
  s.rig.bf = s.rig.T_cam0_cam1.translation().norm() * s.rig.cam0.fx();
  s.th_depth = 60.0 / 7.0;
}

// One settings value per mode and layout the writer knows.
std::vector<std::pair<std::string, OrbSlamSettings>> settings_of_every_mode() {
  std::vector<std::pair<std::string, OrbSlamSettings>> all;
  OrbSlamSettings mono = base_settings(SensorMode::kMonocular);
  mono.new_width = 600;
  mono.new_height = 350;
  all.emplace_back("monocular", mono);

  OrbSlamSettings mono_fractional_fps = base_settings(SensorMode::kMonocular);
  mono_fractional_fps.rig.fps = 30000.0 / 1001.0;
  mono_fractional_fps.th_depth = 35.5;
  mono_fractional_fps.rig.cam0 = PinholeCamera(640, 480, 525.0, 525.0, 319.5, 239.5);
  all.emplace_back("monocular, fractional fps, no distortion", mono_fractional_fps);

  OrbSlamSettings mono_inertial = base_settings(SensorMode::kMonoInertial);
  add_imu(mono_inertial);
  all.emplace_back("mono_inertial", mono_inertial);

  OrbSlamSettings stereo = base_settings(SensorMode::kStereo);
  add_second_camera(stereo);
  all.emplace_back("stereo, two cameras", stereo);

  OrbSlamSettings rectified = base_settings(SensorMode::kStereo);
  rectified.rig.cam0 = PinholeCamera(64, 48, 57.94112549695428, 57.94112549695428, 31.5, 23.5);
  rectified.rig.cam1 = rectified.rig.cam0;
  rectified.rig.T_cam0_cam1.translation() = Eigen::Vector3d(0.11, 0.0, 0.0);
  rectified.rig.bf = 0.11 * rectified.rig.cam0.fx();
  rectified.th_depth = 60.0;
  all.emplace_back("stereo, rectified", rectified);

  OrbSlamSettings fisheye = base_settings(SensorMode::kStereoInertial);
  add_second_camera(fisheye);
  add_imu(fisheye);
  fisheye.rig.cam0 = PinholeCamera(512, 512, 190.97847715128717, 190.9733070521226, 254.93170605935475,
                                   256.8974428996504,
                                   Distortion::equidistant(0.0034823894022493434, 0.0007150348452162257,
                                                           -0.0020532361418706202, 0.00020293673591811182));
  fisheye.rig.cam1 = PinholeCamera(512, 512, 190.44236969414825, 190.4344384721956, 252.59949716835982,
                                   254.91723064636983,
                                   Distortion::equidistant(0.0034003170790442797, 0.001766278153469831,
                                                           -0.00266312569781606, 0.0003299517423931039));
  fisheye.rig.bf = fisheye.rig.T_cam0_cam1.translation().norm() * fisheye.rig.cam0.fx();
  all.emplace_back("stereo_inertial, fisheye (TUM-VI)", fisheye);

  OrbSlamSettings stereo_inertial = base_settings(SensorMode::kStereoInertial);
  add_second_camera(stereo_inertial);
  add_imu(stereo_inertial);
  all.emplace_back("stereo_inertial", stereo_inertial);

  OrbSlamSettings rgbd = base_settings(SensorMode::kRgbd);
  rgbd.rig.depth_scale = 1000.0 / 3.0;
  rgbd.rig.bf = 0.08 * rgbd.rig.cam0.fx();
  rgbd.th_depth = 40.0;
  rgbd.rig.rgb_order = true;
  all.emplace_back("rgbd", rgbd);

  OrbSlamSettings rgbd_inertial = rgbd;
  add_imu(rgbd_inertial);
  all.emplace_back("rgbd with an IMU", rgbd_inertial);
  return all;
}

void expect_same_camera(const PinholeCamera& a, const PinholeCamera& b) {
  EXPECT_EQ(a.width(), b.width());
  EXPECT_EQ(a.height(), b.height());
  EXPECT_EQ(a.fx(), b.fx());
  EXPECT_EQ(a.fy(), b.fy());
  EXPECT_EQ(a.cx(), b.cx());
  EXPECT_EQ(a.cy(), b.cy());
  EXPECT_EQ(a.distortion().k1, b.distortion().k1);
  EXPECT_EQ(a.distortion().k2, b.distortion().k2);
  EXPECT_EQ(a.distortion().p1, b.distortion().p1);
  EXPECT_EQ(a.distortion().p2, b.distortion().p2);
  EXPECT_EQ(a.distortion().k3, b.distortion().k3);
  EXPECT_EQ(a.distortion().k4, b.distortion().k4);
  EXPECT_EQ(a.distortion().model, b.distortion().model);
}

// Every field, compared exactly.
void expect_same(const OrbSlamSettings& a, const OrbSlamSettings& b) {
  EXPECT_EQ(a.rig.mode, b.rig.mode);
  expect_same_camera(a.rig.cam0, b.rig.cam0);
  ASSERT_EQ(a.rig.cam1.has_value(), b.rig.cam1.has_value());
  if (a.rig.cam1) expect_same_camera(*a.rig.cam1, *b.rig.cam1);
  EXPECT_EQ(a.rig.T_cam0_cam1.matrix(), b.rig.T_cam0_cam1.matrix());
  ASSERT_EQ(a.rig.T_body_cam0.has_value(), b.rig.T_body_cam0.has_value());
  if (a.rig.T_body_cam0) {
    EXPECT_EQ(a.rig.T_body_cam0->matrix(), b.rig.T_body_cam0->matrix());
  }
  ASSERT_EQ(a.rig.imu.has_value(), b.rig.imu.has_value());
  if (a.rig.imu) {
    EXPECT_EQ(a.rig.imu->gyro_noise_density, b.rig.imu->gyro_noise_density);
    EXPECT_EQ(a.rig.imu->gyro_random_walk, b.rig.imu->gyro_random_walk);
    EXPECT_EQ(a.rig.imu->accel_noise_density, b.rig.imu->accel_noise_density);
    EXPECT_EQ(a.rig.imu->accel_random_walk, b.rig.imu->accel_random_walk);
    EXPECT_EQ(a.rig.imu->rate_hz, b.rig.imu->rate_hz);
  }
  EXPECT_EQ(a.rig.depth_scale, b.rig.depth_scale);
  EXPECT_EQ(a.rig.bf, b.rig.bf);
  EXPECT_EQ(a.rig.fps, b.rig.fps);
  EXPECT_EQ(a.rig.rgb_order, b.rig.rgb_order);
  EXPECT_EQ(a.orb.num_features, b.orb.num_features);
  EXPECT_EQ(a.orb.scale_factor, b.orb.scale_factor);
  EXPECT_EQ(a.orb.num_levels, b.orb.num_levels);
  EXPECT_EQ(a.orb.ini_fast_threshold, b.orb.ini_fast_threshold);
  EXPECT_EQ(a.orb.min_fast_threshold, b.orb.min_fast_threshold);
  EXPECT_EQ(a.th_depth, b.th_depth);
  EXPECT_EQ(a.new_width, b.new_width);
  EXPECT_EQ(a.new_height, b.new_height);
}

TEST_F(OrbSlamSettingsTest, WriteThenReadGivesTheSameSettingsInEveryMode) {
  for (const auto& [name, written] : settings_of_every_mode()) {
    SCOPED_TRACE(name);
    const fs::path path = dir_ / "written.yaml";
    write_orbslam_settings(path, written);
    expect_same(read_orbslam_settings(path), written);                   // mode inferred
    expect_same(read_orbslam_settings(path, written.rig.mode), written);  // mode given
  }
}

// What ORB-SLAM3's Settings.cc checks: File.version, types (it exits on an integer where it reads an
// int and on a string where it reads a number), float matrices, the keys of each mode, Viewer.*.
TEST_F(OrbSlamSettingsTest, WrittenFileHasTheKeysAndTypesOrbSlam3Reads) {
  for (const auto& [name, written] : settings_of_every_mode()) {
    SCOPED_TRACE(name);
    const fs::path path = dir_ / "written.yaml";
    write_orbslam_settings(path, written);
    cv::FileStorage file(path.string(), cv::FileStorage::READ);
    ASSERT_TRUE(file.isOpened());
    EXPECT_EQ(static_cast<std::string>(file["File.version"]), "1.0");
    const auto expect_real = [&](const char* key) { EXPECT_TRUE(file[key].isReal()) << key; };
    const auto expect_int = [&](const char* key) { EXPECT_TRUE(file[key].isInt()) << key; };
    for (const char* key : {"Camera1.fx", "Camera1.fy", "Camera1.cx", "Camera1.cy", "ORBextractor.scaleFactor",
                            "Viewer.KeyFrameSize", "Viewer.ViewpointF", "Viewer.ViewpointX"}) {
      expect_real(key);
    }
    for (const char* key : {"Camera.width", "Camera.height", "Camera.RGB", "ORBextractor.nFeatures",
                            "ORBextractor.nLevels", "ORBextractor.iniThFAST", "ORBextractor.minThFAST"}) {
      expect_int(key);
    }
    if (written.rig.fps == std::floor(written.rig.fps)) expect_int("Camera.fps");
    const SensorMode mode = written.rig.mode;
    const bool stereo = mode == SensorMode::kStereo || mode == SensorMode::kStereoInertial;
    const bool rectified = stereo && written.rig.cam1->fx() == written.rig.cam0.fx();
    const bool fisheye = written.rig.cam0.distortion().is_equidistant();
    EXPECT_EQ(static_cast<std::string>(file["Camera.type"]),
              rectified ? "Rectified" : fisheye ? "KannalaBrandt8" : "PinHole");
    if (fisheye) {
      for (const char* key : {"Camera1.k1", "Camera1.k2", "Camera1.k3", "Camera1.k4"}) expect_real(key);
      EXPECT_TRUE(file["Camera1.p1"].empty());
    }
    if (fisheye && stereo) {  // required by ORB-SLAM3 for a fisheye pair (it exits without them)
      for (const char* key : {"Camera1.overlappingBegin", "Camera1.overlappingEnd", "Camera2.overlappingBegin",
                              "Camera2.overlappingEnd"}) {
        expect_int(key);
      }
      EXPECT_EQ(static_cast<int>(file["Camera1.overlappingEnd"]), written.rig.cam0.width() - 1);
    }
    if (stereo || mode == SensorMode::kRgbd) expect_real("Stereo.ThDepth");
    if (mode == SensorMode::kRgbd) {
      expect_real("RGBD.DepthMapFactor");
      expect_real("Stereo.b");
      EXPECT_EQ(static_cast<double>(file["Stereo.b"]) * written.rig.cam0.fx(), written.rig.bf);
    }
    if (rectified) {
      expect_real("Stereo.b");
    }
    if (stereo && !rectified) {
      expect_real("Camera2.fx");
      expect_real("Camera2.k1");
      // ORB-SLAM3 reads the matrix entries as floats (cv::Mat::at<float>).
      const cv::Mat T = file["Stereo.T_c1_c2"].mat();
      ASSERT_EQ(T.type(), CV_32FC1);
      EXPECT_EQ(T.at<float>(0, 3), static_cast<float>(written.rig.T_cam0_cam1.translation().x()));
      EXPECT_EQ(T.at<float>(1, 2), static_cast<float>(written.rig.T_cam0_cam1.linear()(1, 2)));
    }
    if (written.rig.imu) {
      for (const char* key : {"IMU.NoiseGyro", "IMU.NoiseAcc", "IMU.GyroWalk", "IMU.AccWalk", "IMU.Frequency"}) {
        expect_real(key);
      }
      EXPECT_EQ(file["IMU.T_b_c1"].mat().type(), CV_32FC1);
    }
  }
}

TEST_F(OrbSlamSettingsTest, MonocularOrStereoRigsDoNotWriteTheirImu) {
  OrbSlamSettings mono = base_settings(SensorMode::kMonocular);
  add_imu(mono);
  const fs::path path = dir_ / "mono.yaml";
  write_orbslam_settings(path, mono);
  const OrbSlamSettings read_back = read_orbslam_settings(path);
  EXPECT_EQ(read_back.rig.mode, SensorMode::kMonocular);
  EXPECT_FALSE(read_back.rig.imu.has_value());
}

// A writer error names the file and the key that could not be written.
void expect_write_error(const fs::path& path, const OrbSlamSettings& s, const std::string& key,
                        const std::string& why_part) {
  try {
    write_orbslam_settings(path, s);
    ADD_FAILURE() << "no error for key " << key;
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), key.empty() ? path.string() : path.string() + ":" + key) << e.what();
    EXPECT_NE(e.why().find(why_part), std::string::npos) << e.what();
  }
}

TEST_F(OrbSlamSettingsTest, SettingsThatWouldNotReadBackAreNotWritten) {
  const fs::path path = dir_ / "bad.yaml";
  expect_write_error(path, base_settings(SensorMode::kStereo), "Camera2.fx", "needs cam1");
  OrbSlamSettings stereo = base_settings(SensorMode::kStereo);
  add_second_camera(stereo);
  stereo.th_depth = 0.0;
  expect_write_error(path, stereo, "Stereo.ThDepth", "th_depth");
  stereo.th_depth = 40.0;
  stereo.rig.cam1 = PinholeCamera(640, 480, 500.0, 500.0, 320.0, 240.0);
  expect_write_error(path, stereo, "Camera.width", "same image size");
  add_second_camera(stereo);
  stereo.rig.cam1 = PinholeCamera(stereo.rig.cam0.width(), stereo.rig.cam0.height(), 500.0, 500.0, 320.0, 240.0,
                                  Distortion::equidistant(0.01, 0.0, 0.0, 0.0));
  expect_write_error(path, stereo, "Camera.type", "same model");
  OrbSlamSettings rgbd = base_settings(SensorMode::kRgbd);
  rgbd.th_depth = 40.0;
  expect_write_error(path, rgbd, "Stereo.b", "bf");
  OrbSlamSettings inertial = base_settings(SensorMode::kMonoInertial);
  expect_write_error(path, inertial, "IMU.NoiseGyro", "IMU noise");
  add_imu(inertial);
  inertial.rig.T_body_cam0.reset();
  expect_write_error(path, inertial, "IMU.T_b_c1", "T_body_cam0");
  add_imu(inertial);
  inertial.rig.imu->accel_random_walk = 0.0;
  expect_write_error(path, inertial, "IMU.AccWalk", "positive");
  OrbSlamSettings half_resize = base_settings(SensorMode::kMonocular);
  half_resize.new_width = 320;
  expect_write_error(path, half_resize, "Camera.newWidth", "both");
  expect_write_error(dir_ / "no_such_folder" / "settings.yaml", base_settings(SensorMode::kMonocular), "",
                     "cannot write");
  EXPECT_FALSE(fs::exists(dir_ / "no_such_folder"));
}

}  // namespace
}  // namespace fleetslam::core
