// The ORB-SLAM settings reader on the real files users bring (../shared/data/calib): ORB-SLAM2's TUM1.yaml
// and ORB-SLAM3 v1.0's EuRoC files. Skips when the data folder is absent.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "fleetslam/core/orbslam_settings.hpp"

namespace fleetslam::core {
namespace {

namespace fs = std::filesystem;

fs::path calib_dir() { return fs::path(FLEETSLAM_DATA_DIR) / "calib"; }

#define SKIP_WITHOUT_DATA()                                                                        \
  do {                                                                                             \
    if (!fs::is_directory(calib_dir())) {                                                          \
      GTEST_SKIP() << "real data not found at " << calib_dir().string()                            \
                   << " (set FLEETSLAM_DATA_DIR to the shared data folder to run this test)";      \
    }                                                                                              \
  } while (false)

TEST(RealOrbSlamSettings, Tum1Rgbd) {
  SKIP_WITHOUT_DATA();
  const OrbSlamSettings s = read_orbslam_settings(calib_dir() / "TUM1.yaml");
  EXPECT_EQ(s.rig.mode, SensorMode::kRgbd);
  EXPECT_DOUBLE_EQ(s.rig.cam0.fx(), 517.306408);
  EXPECT_DOUBLE_EQ(s.rig.cam0.fy(), 516.469215);
  EXPECT_DOUBLE_EQ(s.rig.cam0.cx(), 318.643040);
  EXPECT_DOUBLE_EQ(s.rig.cam0.cy(), 255.313989);
  EXPECT_DOUBLE_EQ(s.rig.cam0.distortion().k1, 0.262383);
  EXPECT_DOUBLE_EQ(s.rig.cam0.distortion().k3, 1.163314);
  EXPECT_EQ(s.rig.cam0.width(), 640);
  EXPECT_EQ(s.rig.cam0.height(), 480);
  EXPECT_DOUBLE_EQ(s.rig.depth_scale, 5000.0);
  EXPECT_DOUBLE_EQ(s.rig.bf, 40.0);
  EXPECT_DOUBLE_EQ(s.th_depth, 40.0);
  EXPECT_DOUBLE_EQ(s.rig.fps, 30.0);
  EXPECT_TRUE(s.rig.rgb_order);
  EXPECT_EQ(s.orb.num_features, 1000);
  EXPECT_EQ(s.orb.num_levels, 8);
  EXPECT_FALSE(s.rig.imu.has_value());
  EXPECT_FALSE(s.rig.cam1.has_value());
}

void expect_euroc_imu(const OrbSlamSettings& s) {
  ASSERT_TRUE(s.rig.imu.has_value());
  EXPECT_DOUBLE_EQ(s.rig.imu->gyro_noise_density, 1.7e-4);
  EXPECT_DOUBLE_EQ(s.rig.imu->accel_noise_density, 2.0e-3);
  EXPECT_DOUBLE_EQ(s.rig.imu->gyro_random_walk, 1.9393e-05);
  EXPECT_DOUBLE_EQ(s.rig.imu->accel_random_walk, 3.0e-3);
  EXPECT_DOUBLE_EQ(s.rig.imu->rate_hz, 200.0);
  ASSERT_TRUE(s.rig.T_body_cam0.has_value());
  const Eigen::Isometry3d& T = *s.rig.T_body_cam0;
  // Stored as floats ("dt: f") and orthonormalised: agree with the file to ~1e-6.
  EXPECT_NEAR(T.translation().x(), -0.0216401454975, 1e-7);
  EXPECT_NEAR(T.translation().y(), -0.064676986768, 1e-7);
  EXPECT_NEAR(T.translation().z(), 0.00981073058949, 1e-7);
  EXPECT_NEAR(T.linear()(0, 0), 0.0148655429818, 1e-6);
  EXPECT_NEAR(T.linear()(0, 1), -0.999880929698, 1e-6);
  EXPECT_NEAR(T.linear()(1, 0), 0.999557249008, 1e-6);
  EXPECT_NEAR(T.linear()(2, 2), 0.999660727178, 1e-6);
  const Eigen::Matrix3d R = T.linear();
  EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-14);
}

TEST(RealOrbSlamSettings, EurocStereoInertial) {
  SKIP_WITHOUT_DATA();
  const OrbSlamSettings s = read_orbslam_settings(calib_dir() / "Stereo-Inertial_EuRoC.yaml");
  EXPECT_EQ(s.rig.mode, SensorMode::kStereoInertial);
  EXPECT_DOUBLE_EQ(s.rig.cam0.fx(), 458.654);
  EXPECT_DOUBLE_EQ(s.rig.cam0.distortion().k1, -0.28340811);
  EXPECT_EQ(s.rig.cam0.width(), 752);
  ASSERT_TRUE(s.rig.cam1.has_value());
  EXPECT_DOUBLE_EQ(s.rig.cam1->fx(), 457.587);
  EXPECT_DOUBLE_EQ(s.rig.cam1->distortion().k2, 0.07451284);
  // Stereo.T_c1_c2: cam1 about 11 cm to the right (+x) of cam0.
  const Eigen::Vector3d t = s.rig.T_cam0_cam1.translation();
  EXPECT_NEAR(t.norm(), 0.110, 0.001);
  EXPECT_NEAR(t.x(), 0.110074137800478, 1e-7);
  EXPECT_LT(std::abs(t.y()) + std::abs(t.z()), 0.002);
  EXPECT_NEAR(s.rig.bf, t.norm() * 458.654, 1e-9);
  EXPECT_DOUBLE_EQ(s.th_depth, 60.0);
  EXPECT_DOUBLE_EQ(s.rig.fps, 20.0);
  EXPECT_EQ(s.orb.num_features, 1200);
  expect_euroc_imu(s);
}

TEST(RealOrbSlamSettings, EurocMonocularInertial) {
  SKIP_WITHOUT_DATA();
  const OrbSlamSettings s = read_orbslam_settings(calib_dir() / "Monocular-Inertial_EuRoC.yaml");
  EXPECT_EQ(s.rig.mode, SensorMode::kMonoInertial);
  EXPECT_DOUBLE_EQ(s.rig.cam0.fx(), 458.654);
  EXPECT_DOUBLE_EQ(s.rig.cam0.cy(), 248.375);
  EXPECT_FALSE(s.rig.cam1.has_value());
  EXPECT_EQ(s.new_width, 600);
  EXPECT_EQ(s.new_height, 350);
  EXPECT_EQ(s.orb.num_features, 1000);
  expect_euroc_imu(s);
}

TEST(RealOrbSlamSettings, EurocFileReadAsStereoOnly) {
  SKIP_WITHOUT_DATA();
  const OrbSlamSettings s = read_orbslam_settings(calib_dir() / "Stereo-Inertial_EuRoC.yaml", SensorMode::kStereo);
  EXPECT_EQ(s.rig.mode, SensorMode::kStereo);
  EXPECT_TRUE(s.rig.cam1.has_value());
}

}  // namespace
}  // namespace fleetslam::core
