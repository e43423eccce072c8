// sim::World against analytic ground truth: metric depth on planes, stereo disparity, IMU at rest and
// integrated over a second of motion, tick scheduling, byte-identical repeats, surface sampling, errors.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/se3.hpp"
#include "fleetslam/sim/world.hpp"

namespace fleetslam::sim {
namespace {

namespace fs = std::filesystem;

// A temp folder with a scene: floor, a wall whose face is at x = wall_x, a red marker sphere.
fs::path write_scene(const std::string& name, const std::string& body) {
  const fs::path dir = fs::temp_directory_path() / ("fleetslam_test_world_" + name);
  fs::create_directories(dir);
  std::ofstream(dir / "scene.xml") << "<mujoco model=\"" << name << "\">\n"
                                   << "  <asset><material name=\"glow\" rgba=\"1 0 0 1\" emission=\"1\"/></asset>\n"
                                   << "  <worldbody>\n"
                                   << "    <light pos=\"0 0 5\" dir=\"0 0 -1\" castshadow=\"false\"/>\n"
                                   << body << "  </worldbody>\n</mujoco>\n";
  return dir;
}

const char* kWallScene =
    "    <geom name=\"floor\" type=\"plane\" size=\"10 10 0.1\" rgba=\"0.5 0.5 0.5 1\"/>\n"
    "    <geom name=\"wall\" type=\"box\" pos=\"2.25 0 1.5\" size=\"0.1 4 3\" rgba=\"0.8 0.8 0.8 1\"/>\n"
    // An emissive square facing the cameras: its projected centroid is the projection of its centre.
    "    <geom name=\"marker\" type=\"box\" pos=\"1.5 0.1 1.25\" size=\"0.001 0.03 0.03\" material=\"glow\"/>\n";

// A stationary free rig at `pose` (camera mount at its origin, looking along +x).
RobotConfig still_rig(const std::string& name, const PoseConfig& pose) {
  RobotConfig robot;
  robot.name = name;
  robot.type = RobotType::kFreeRig;
  robot.initial_pose = pose;
  robot.seed = 7;
  robot.camera.mount = PoseConfig{};
  robot.camera.image_noise.enabled = false;
  robot.camera.depth_noise.enabled = false;
  robot.imu.noise_enabled = false;
  for (double t : {0.0, 100.0}) {
    WaypointConfig w;
    w.t_s = t;
    w.x = pose.x;
    w.y = pose.y;
    w.z = pose.z;
    w.roll_deg = pose.roll_deg;
    w.pitch_deg = pose.pitch_deg;
    w.yaw_deg = pose.yaw_deg;
    robot.waypoints.push_back(w);
  }
  return robot;
}

// A diff-drive robot named "rover" with a small camera, driving through `waypoints` (x, y).
RobotConfig small_rover(std::int64_t seed, const std::vector<std::pair<double, double>>& waypoints) {
  RobotConfig rover;
  rover.name = "rover";
  rover.seed = seed;
  rover.camera.width = 32;
  rover.camera.height = 24;
  for (const auto& [x, y] : waypoints) {
    WaypointConfig w;
    w.x = x;
    w.y = y;
    rover.waypoints.push_back(w);
  }
  return rover;
}

ScenarioConfig scenario_in(const fs::path& dir, std::vector<RobotConfig> robots, double duration_s = 1.0) {
  ScenarioConfig scenario;
  scenario.scene = "scene.xml";
  scenario.base_dir = dir;
  scenario.duration_s = duration_s;
  scenario.robots = std::move(robots);
  return scenario;
}

TEST(World, DepthOfAFrontoParallelWallIsExact) {
  const fs::path dir = write_scene("wall", kWallScene);
  // Camera at x = 0.15, wall face at x = 2.15: every wall pixel is 2 m deep along the optical axis.
  World world(scenario_in(dir, {still_rig("cam", PoseConfig{0.15, 0.0, 1.25, 0, 0, 0})}), nullptr);
  const auto frames = world.step();
  ASSERT_EQ(frames.size(), 1u);
  const cv::Mat& depth = frames[0].depth_m;
  ASSERT_EQ(depth.type(), CV_32FC1);
  double worst = 0.0;
  int wall_pixels = 0;
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) {
      const double z = depth.at<float>(v, u);
      if (std::abs(z - 2.0) < 0.05) {
        worst = std::max(worst, std::abs(z - 2.0));
        ++wall_pixels;
      }
    }
  }
  EXPECT_GT(wall_pixels, depth.rows * depth.cols * 8 / 10);  // the marker and floor cover little
  EXPECT_LT(worst, 1e-3);
}

// Sky is no surface: depth 0 where a skybox shows. MuJoCo draws the skybox as a shell 0.7 zfar around the
// camera, which the depth buffer held as a wall hundreds of metres away.
TEST(World, ASkyboxHasNoDepth) {
  const fs::path dir = fs::temp_directory_path() / "fleetslam_test_world_skybox";
  fs::create_directories(dir);
  std::ofstream(dir / "scene.xml")
      << "<mujoco model=\"sky\">\n  <asset><texture type=\"skybox\" builtin=\"gradient\" rgb1=\"0.3 0.5 0.7\" "
         "rgb2=\"0 0 0\" width=\"32\" height=\"32\"/>\n    <material name=\"glow\" rgba=\"1 0 0 1\" emission=\"1\"/></asset>\n"
         "  <worldbody>\n"
      << "    <light pos=\"0 0 5\" dir=\"0 0 -1\" castshadow=\"false\"/>\n" << kWallScene << "  </worldbody>\n</mujoco>\n";
  // Pitched up 60 degrees in front of the 3 m wall: its top edge crosses the image, sky above it.
  World world(scenario_in(dir, {still_rig("cam", PoseConfig{1.0, 0.0, 1.25, 0, -60, 0})}), nullptr);
  const auto frames = world.step();
  ASSERT_EQ(frames.size(), 1u);
  const cv::Mat& depth = frames[0].depth_m;
  int sky = 0, near = 0, far = 0;
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) {
      const float z = depth.at<float>(v, u);
      sky += z == 0.0f ? 1 : 0;
      near += z > 0.0f && z < 20.0f ? 1 : 0;
      far += z >= 20.0f ? 1 : 0;
    }
  }
  EXPECT_EQ(far, 0);
  EXPECT_GT(sky, depth.rows * depth.cols / 10);
  EXPECT_GT(near, depth.rows * depth.cols / 10);
  // The colour still shows the sky: the top row is the skybox's, not the background's black.
  const cv::Vec3b top = frames[0].image.at<cv::Vec3b>(0, depth.cols / 2);
  EXPECT_GT(top[0] + top[1] + top[2], 30) << top;
}

TEST(World, NearbyWallsAreNotClippedInLargeScenes) {
  // A large scene (MuJoCo's default near plane would be over 0.3 m) and a camera 12 cm from a wall.
  const fs::path dir = write_scene("near", std::string(kWallScene) +
                                               "    <geom type=\"box\" pos=\"30 30 1\" size=\"1 1 1\"/>\n");
  World world(scenario_in(dir, {still_rig("cam", PoseConfig{2.03, 0.0, 1.25, 0, 0, 0})}), nullptr);
  const auto frames = world.step();
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_NEAR(frames[0].depth_m.at<float>(240, 320), 0.12, 1e-3);
}

TEST(World, DepthOfTheFloorMatchesRayCasting) {
  const fs::path dir = write_scene("floor", "    <geom type=\"plane\" size=\"30 30 0.1\" rgba=\"0.5 0.5 0.5 1\"/>\n");
  // Looking 35 degrees down from 1.2 m: the lower image sees the floor, the top sees nothing.
  World world(scenario_in(dir, {still_rig("cam", PoseConfig{0, 0, 1.2, 0, 35, 20})}), nullptr);
  const auto frames = world.step();
  ASSERT_EQ(frames.size(), 1u);
  const core::PinholeCamera camera = world.sensor_rig(0).cam0;
  const Eigen::Isometry3d T_world_cam = *frames[0].T_world_cam_gt;
  double worst = 0.0;
  int floor_pixels = 0;
  for (int v = 0; v < camera.height(); v += 3) {
    for (int u = 0; u < camera.width(); u += 3) {
      const Eigen::Vector3d ray_world = T_world_cam.linear() * *camera.unproject(Eigen::Vector2d(u, v));
      if (ray_world.z() > -1e-3) continue;
      const double depth_true = -T_world_cam.translation().z() / ray_world.z();
      if (depth_true > 20.0) continue;  // beyond the plane's extent or the far plane
      worst = std::max(worst, std::abs(static_cast<double>(frames[0].depth_m.at<float>(v, u)) - depth_true));
      ++floor_pixels;
    }
  }
  EXPECT_GT(floor_pixels, 5000);
  EXPECT_LT(worst, 1e-3);
}

// Centroid of the red marker's pixels.
Eigen::Vector2d red_centroid(const cv::Mat& bgr) {
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  int n = 0;
  for (int v = 0; v < bgr.rows; ++v) {
    for (int u = 0; u < bgr.cols; ++u) {
      const cv::Vec3b p = bgr.at<cv::Vec3b>(v, u);
      if (p[2] > 200 && p[1] < 120 && p[0] < 120) {
        sum += Eigen::Vector2d(u, v);
        ++n;
      }
    }
  }
  EXPECT_GT(n, 20);
  return sum / std::max(n, 1);
}

TEST(World, StereoDisparityEqualsFocalTimesBaselineOverDepth) {
  const fs::path dir = write_scene("stereo", kWallScene);
  RobotConfig robot = still_rig("pair", PoseConfig{0.0, 0.0, 1.25, 0, 0, 0});
  robot.stereo.enabled = true;
  robot.stereo.baseline_m = 0.12;
  World world(scenario_in(dir, {robot}), nullptr);
  const auto frames = world.step();
  ASSERT_EQ(frames.size(), 1u);
  ASSERT_FALSE(frames[0].right.empty());
  const core::SensorRig rig = world.sensor_rig(0);
  ASSERT_TRUE(rig.cam1.has_value());
  EXPECT_NEAR(rig.T_cam0_cam1.translation().x(), 0.12, 1e-12);
  // The marker's centre, 1.5 m ahead: its projections in both images, and the disparity f * b / z.
  const Eigen::Vector3d p_cam = frames[0].T_world_cam_gt->inverse() * Eigen::Vector3d(1.499, 0.1, 1.25);
  const Eigen::Vector2d left = red_centroid(frames[0].image);
  const Eigen::Vector2d right = red_centroid(frames[0].right);
  EXPECT_NEAR((left - *rig.cam0.project(p_cam)).norm(), 0.0, 0.3);
  EXPECT_NEAR(left.y(), right.y(), 0.2);  // rectified: same row
  EXPECT_NEAR(left.x() - right.x(), rig.cam0.fx() * 0.12 / p_cam.z(), 0.3);
}

// A stereo head shares one exposure: with exposure changes on (fast, strong) and no pixel noise, the two
// images of each frame keep the same brightness; independent gains made them differ by tens of percent.
TEST(World, AStereoPairSharesItsExposure) {
  const fs::path dir = write_scene("exposure", kWallScene);
  RobotConfig robot = still_rig("pair", PoseConfig{0.0, 0.0, 1.25, 0, 0, 0});
  robot.stereo.enabled = true;
  robot.stereo.baseline_m = 0.02;
  robot.camera.width = 160;
  robot.camera.height = 120;
  robot.camera.image_noise.enabled = true;
  robot.camera.image_noise.sigma_intensity = 0.0;
  robot.camera.image_noise.exposure_changes = true;
  robot.camera.image_noise.exposure_sigma = 0.5;
  robot.camera.image_noise.exposure_correlation_s = 0.05;
  World world(scenario_in(dir, {robot}, 0.5), nullptr);
  double spread = 0.0;  // how far the left image's brightness moved: the gains did change
  double first_mean = -1.0;
  for (auto frames = world.step(); !frames.empty(); frames = world.step()) {
    const double left = cv::mean(frames[0].image)[0];
    const double right = cv::mean(frames[0].right)[0];
    if (first_mean < 0.0) first_mean = left;
    spread = std::max(spread, std::abs(left / first_mean - 1.0));
    EXPECT_NEAR(left / right, 1.0, 0.03) << "t " << frames[0].t_ns;
  }
  EXPECT_GT(spread, 0.2);
}

TEST(World, ImuAtRestReadsGravityAndNoRotation) {
  const fs::path dir = write_scene("rest", kWallScene);
  RobotConfig robot;
  robot.name = "rover";
  robot.type = RobotType::kDiffDrive;
  robot.seed = 3;
  robot.imu.noise_enabled = false;
  robot.camera.width = 64;
  robot.camera.height = 48;
  World world(scenario_in(dir, {robot}, 0.5), nullptr);
  int samples = 0;
  core::TimeNs last_frame_ns = 0;
  for (auto frames = world.step(); !frames.empty(); frames = world.step()) {
    last_frame_ns = frames[0].t_ns;
    for (const auto& s : frames[0].imu) {
      EXPECT_NEAR((s.accel_mps2 - Eigen::Vector3d(0, 0, 9.81)).norm(), 0.0, 1e-3);
      EXPECT_NEAR(s.gyro_radps.norm(), 0.0, 1e-6);
      ++samples;
    }
  }
  // 200 Hz from t = 0 up to the last frame (later samples wait for a frame that never comes).
  EXPECT_EQ(samples, last_frame_ns / 5'000'000 + 1);
}

// A rig following a smooth, rotating trajectory.
RobotConfig moving_rig() {
  RobotConfig robot = still_rig("rig", PoseConfig{0, 0, 1, 0, 0, 0});
  robot.camera.width = 80;
  robot.camera.height = 60;
  robot.waypoints.clear();
  const double knots[][7] = {{0.0, 0.0, 0.0, 1.0, 0, 0, 0},     {0.8, 0.4, 0.1, 1.1, 5, -4, 20},
                             {1.6, 0.9, -0.2, 1.2, -6, 8, 45}, {2.4, 1.2, 0.1, 1.0, 3, 0, 80},
                             {3.2, 1.3, 0.4, 1.1, 0, 5, 100}};
  for (const auto& k : knots) {
    WaypointConfig w;
    w.t_s = k[0];
    w.x = k[1];
    w.y = k[2];
    w.z = k[3];
    w.roll_deg = k[4];
    w.pitch_deg = k[5];
    w.yaw_deg = k[6];
    robot.waypoints.push_back(w);
  }
  return robot;
}

TEST(World, IntegratingNoiseFreeImuOverOneSecondReproducesTheMotion) {
  const fs::path dir = write_scene("imu", kWallScene);
  World world(scenario_in(dir, {moving_rig()}, 2.0), nullptr);
  // Run to 0.5 s, take the ground-truth state, then integrate the IMU for one second.
  std::vector<core::ImuSample> samples;
  Eigen::Isometry3d T_start = Eigen::Isometry3d::Identity();
  Eigen::Vector3d v_start = Eigen::Vector3d::Zero();
  core::TimeNs t_start = -1;
  Eigen::Isometry3d T_end_true = Eigen::Isometry3d::Identity();
  for (auto frames = world.step(); !frames.empty(); frames = world.step()) {
    if (t_start < 0 && world.time_ns() >= 500'000'000) {
      t_start = world.time_ns();
      T_start = world.truth(0).T_world_body;
      v_start = world.truth(0).v_world_mps;
      continue;
    }
    if (t_start < 0) continue;
    for (const auto& s : frames[0].imu) samples.push_back(s);
    if (world.time_ns() >= t_start + 1'000'000'000) {
      T_end_true = world.truth(0).T_world_body;
      break;
    }
  }
  ASSERT_GT(samples.size(), 190u);
  ASSERT_EQ(samples.back().t_ns, world.time_ns());
  // Trapezoidal strapdown integration between consecutive samples (the first starts at t_start).
  Eigen::Matrix3d R = T_start.linear();
  Eigen::Vector3d p = T_start.translation();
  Eigen::Vector3d v = v_start;
  const Eigen::Vector3d g(0, 0, -9.81);
  // samples[k] is at t_start + 5 ms * (k + 1): the sample at t_start went with the frame at t_start.
  ASSERT_EQ(samples.front().t_ns, t_start + 5'000'000);
  // The first interval uses the first sample on both ends (first-order there only).
  core::TimeNs t = t_start;
  Eigen::Vector3d a_prev = R * samples.front().accel_mps2 + g;
  Eigen::Vector3d w_prev = samples.front().gyro_radps;
  for (const auto& s : samples) {
    const double dt = core::ns_to_seconds(s.t_ns - t);
    const Eigen::Vector3d w_mid = 0.5 * (w_prev + s.gyro_radps);
    const Eigen::Matrix3d R_next = R * core::so3_exp(w_mid * dt);
    const Eigen::Vector3d a_next = R_next * s.accel_mps2 + g;
    p += v * dt + dt * dt / 6.0 * (2.0 * a_prev + a_next);
    v += 0.5 * (a_prev + a_next) * dt;
    R = R_next;
    a_prev = a_next;
    w_prev = s.gyro_radps;
    t = s.t_ns;
  }
  EXPECT_LT((p - T_end_true.translation()).norm(), 5e-3);
  EXPECT_LT(core::rotation_angle_rad(R.transpose() * T_end_true.linear()), 1e-3);
}

// Each frame of a robot with an IMU carries the IMU's state: velocity as the poses' central differences
// say (a kinematic rig and a diff-drive robot turning on its way), biases as the IMU model holds them (noise
// on: they walk). A robot without an IMU carries none.
TEST(World, FramesCarryTheImuStateAtTheirInstant) {
  const fs::path dir = write_scene("imu_state", kWallScene);
  RobotConfig rig = moving_rig();
  rig.imu.noise_enabled = true;
  rig.imu.initial_gyro_bias_radps = {0.01, -0.02, 0.005};
  const RobotConfig rover = small_rover(2, {{0.5, 0.5}, {0.5, -0.5}});
  RobotConfig blind = still_rig("blind", PoseConfig{0, 1, 1, 0, 0, 0});
  blind.camera.width = 32;
  blind.camera.height = 24;
  blind.imu.enabled = false;
  World world(scenario_in(dir, {rig, rover, blind}, 2.0), nullptr);
  std::vector<std::vector<core::SensorFrame>> by_robot(3);
  bool biases_walked = false;
  for (auto frames = world.step(); !frames.empty(); frames = world.step()) {
    for (core::SensorFrame& frame : frames) {
      const auto r = static_cast<std::size_t>(frame.robot_id);
      if (r == 2) {
        EXPECT_FALSE(frame.imu_state_gt.has_value());
        continue;
      }
      ASSERT_TRUE(frame.imu_state_gt.has_value());
      const RobotTruth truth = world.truth(r);
      EXPECT_EQ(frame.imu_state_gt->v_world_mps, truth.v_world_mps);
      EXPECT_EQ(frame.imu_state_gt->gyro_bias_radps, truth.gyro_bias_radps);
      EXPECT_EQ(frame.imu_state_gt->accel_bias_mps2, truth.accel_bias_mps2);
      if (r == 0) biases_walked = biases_walked || (truth.gyro_bias_radps - Eigen::Vector3d(0.01, -0.02, 0.005)).norm() > 1e-6;
      by_robot[r].push_back(std::move(frame));
    }
  }
  EXPECT_TRUE(biases_walked);
  for (std::size_t r = 0; r < 2; ++r) {
    SCOPED_TRACE(r);
    const std::vector<core::SensorFrame>& frames = by_robot[r];
    ASSERT_GT(frames.size(), 20u);
    const Eigen::Isometry3d T_cam_body = world.T_body_cam(r).inverse();
    double worst = 0.0;
    double fastest = 0.0;
    for (std::size_t i = 1; i + 1 < frames.size(); ++i) {
      const Eigen::Vector3d p_before = (*frames[i - 1].T_world_cam_gt * T_cam_body).translation();
      const Eigen::Vector3d p_after = (*frames[i + 1].T_world_cam_gt * T_cam_body).translation();
      const double dt_s = core::ns_to_seconds(frames[i + 1].t_ns - frames[i - 1].t_ns);
      const Eigen::Vector3d v_numeric = (p_after - p_before) / dt_s;
      worst = std::max(worst, (v_numeric - frames[i].imu_state_gt->v_world_mps).norm());
      fastest = std::max(fastest, v_numeric.norm());
    }
    EXPECT_GT(fastest, 0.1);  // it moved
    EXPECT_LT(worst, 0.02 * fastest + 1e-3);
  }
}

// Every IMU sample comes with the truth at its instant: the body pose, velocity and biases. At a frame's
// instant it is the frame's own ground truth; between frames the poses agree with what the noise-free gyro
// and the velocities say (a kinematic rig and a diff-drive robot).
TEST(World, FramesCarryTheTruthAtEveryImuSample) {
  const fs::path dir = write_scene("imu_truth", kWallScene);
  const RobotConfig rig = moving_rig();
  RobotConfig rover = small_rover(2, {{0.5, 0.5}, {0.5, -0.5}});
  rover.imu.noise_enabled = false;
  World world(scenario_in(dir, {rig, rover}, 1.5), nullptr);
  std::vector<std::vector<core::ImuSample>> samples(2);
  std::vector<std::vector<core::ImuTruth>> truths(2);
  std::size_t frames_seen = 0;
  std::size_t shared_instants = 0;
  for (auto frames = world.step(); !frames.empty(); frames = world.step()) {
    for (const core::SensorFrame& frame : frames) {
      const auto r = static_cast<std::size_t>(frame.robot_id);
      SCOPED_TRACE(testing::Message() << "robot " << r << ", frame " << frame.sequence);
      ASSERT_EQ(frame.imu_truth.size(), frame.imu.size());
      ASSERT_FALSE(frame.imu.empty());
      for (std::size_t k = 0; k < frame.imu.size(); ++k) EXPECT_EQ(frame.imu_truth[k].t_ns, frame.imu[k].t_ns);
      // Where a camera tick is an IMU tick (every 100 ms: 30 Hz and 200 Hz), the truth is the frame's.
      const core::ImuTruth& last = frame.imu_truth.back();
      ASSERT_TRUE(frame.T_world_cam_gt && frame.imu_state_gt);
      if (last.t_ns == frame.t_ns) {
        EXPECT_TRUE((last.T_world_body * world.T_body_cam(r)).isApprox(*frame.T_world_cam_gt, 1e-15));
        ASSERT_TRUE(last.state.has_value());
        EXPECT_EQ(last.state->v_world_mps, frame.imu_state_gt->v_world_mps);
        EXPECT_EQ(last.state->gyro_bias_radps, frame.imu_state_gt->gyro_bias_radps);
        EXPECT_EQ(last.state->accel_bias_mps2, frame.imu_state_gt->accel_bias_mps2);
        ++shared_instants;
      }
      samples[r].insert(samples[r].end(), frame.imu.begin(), frame.imu.end());
      truths[r].insert(truths[r].end(), frame.imu_truth.begin(), frame.imu_truth.end());
      ++frames_seen;
    }
  }
  EXPECT_GT(frames_seen, 40u);
  EXPECT_GE(shared_instants, 20u);
  for (std::size_t r = 0; r < 2; ++r) {
    SCOPED_TRACE(r);
    const std::vector<core::ImuTruth>& truth = truths[r];
    ASSERT_GT(truth.size(), 200u);
    double worst_rotation_rad = 0.0;
    double worst_velocity_mps = 0.0;
    double largest_turn_rad = 0.0;
    double fastest_mps = 0.0;
    for (std::size_t k = 1; k + 1 < truth.size(); ++k) {
      const double dt_s = core::ns_to_seconds(truth[k + 1].t_ns - truth[k].t_ns);
      // Rotation over one sample interval against the gyro (midpoint rate), both in the body frame.
      const Eigen::Vector3d omega = 0.5 * (samples[r][k].gyro_radps + samples[r][k + 1].gyro_radps);
      const Eigen::Matrix3d dR = truth[k].T_world_body.linear().transpose() * truth[k + 1].T_world_body.linear();
      worst_rotation_rad =
          std::max(worst_rotation_rad, core::rotation_angle_rad(core::so3_exp(omega * dt_s).transpose() * dR));
      largest_turn_rad = std::max(largest_turn_rad, core::rotation_angle_rad(dR));
      // Velocity against the central difference of the positions.
      const Eigen::Vector3d v_numeric =
          (truth[k + 1].T_world_body.translation() - truth[k - 1].T_world_body.translation()) /
          core::ns_to_seconds(truth[k + 1].t_ns - truth[k - 1].t_ns);
      ASSERT_TRUE(truth[k].state.has_value());
      worst_velocity_mps = std::max(worst_velocity_mps, (v_numeric - truth[k].state->v_world_mps).norm());
      fastest_mps = std::max(fastest_mps, v_numeric.norm());
    }
    EXPECT_GT(largest_turn_rad, 1e-3);  // it turned between samples
    EXPECT_GT(fastest_mps, 0.1);        // and moved
    EXPECT_LT(worst_rotation_rad, 0.01 * largest_turn_rad + 1e-7);
    EXPECT_LT(worst_velocity_mps, 0.005 * fastest_mps + 1e-4);
  }
}

TEST(World, CameraTicksDoNotDriftAndImuAttachesToTheRightFrames) {
  const fs::path dir = write_scene("ticks", kWallScene);
  RobotConfig robot = still_rig("cam", PoseConfig{0, 0, 1.25, 0, 0, 0});
  robot.camera.width = 32;
  robot.camera.height = 24;
  robot.camera.rate_hz = 30.0;
  World world(scenario_in(dir, {robot}, 20.0), nullptr);
  std::int64_t k = 0;
  core::TimeNs previous = -1;
  for (auto frames = world.step(); !frames.empty(); frames = world.step(), ++k) {
    const core::SensorFrame& f = frames[0];
    EXPECT_EQ(f.sequence, k);
    EXPECT_LE(std::abs(static_cast<double>(f.t_ns) - k * 1e9 / 30.0), 0.5e6);  // nearest 1 ms step
    for (const auto& s : f.imu) {
      EXPECT_GT(s.t_ns, previous);
      EXPECT_LE(s.t_ns, f.t_ns);
    }
    previous = f.t_ns;
  }
  EXPECT_EQ(k, 600);
}

std::vector<core::SensorFrame> run_all(const ScenarioConfig& scenario) {
  World world(scenario, nullptr);
  std::vector<core::SensorFrame> all;
  for (auto frames = world.step(); !frames.empty(); frames = world.step()) {
    for (auto& f : frames) all.push_back(std::move(f));
  }
  return all;
}

bool same_bytes(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  return a.empty() || std::equal(a.datastart, a.dataend, b.datastart);
}

TEST(World, RepeatRunsAreByteIdenticalWithNoiseOn) {
  const fs::path dir = write_scene("repeat", kWallScene);
  RobotConfig rig = moving_rig();
  rig.camera.image_noise.enabled = true;
  rig.camera.depth_noise.enabled = true;
  rig.imu.noise_enabled = true;
  RobotConfig rover;
  rover.name = "rover";
  rover.initial_pose = PoseConfig{-1.0, 1.0, 0, 0, 0, -30};
  rover.camera.width = 64;
  rover.camera.height = 48;
  rover.stereo.enabled = true;
  WaypointConfig goal;
  goal.x = 0.5;
  goal.y = 0.0;
  rover.waypoints = {goal};
  const ScenarioConfig scenario = scenario_in(dir, {rig, rover}, 1.0);
  const auto a = run_all(scenario);
  const auto b = run_all(scenario);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GT(a.size(), 50u);
  for (std::size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].t_ns, b[i].t_ns);
    ASSERT_EQ(a[i].robot_id, b[i].robot_id);
    ASSERT_TRUE(same_bytes(a[i].image, b[i].image)) << i;
    ASSERT_TRUE(same_bytes(a[i].depth_m, b[i].depth_m)) << i;
    ASSERT_TRUE(same_bytes(a[i].right, b[i].right)) << i;
    ASSERT_EQ(a[i].imu.size(), b[i].imu.size());
    for (std::size_t k = 0; k < a[i].imu.size(); ++k) {
      ASSERT_EQ(a[i].imu[k].accel_mps2, b[i].imu[k].accel_mps2);
      ASSERT_EQ(a[i].imu[k].gyro_radps, b[i].imu[k].gyro_radps);
    }
    ASSERT_TRUE(a[i].T_world_cam_gt->isApprox(*b[i].T_world_cam_gt, 0.0));
  }
}

// Two worlds side by side (each with its own GL context) render what each renders alone, stepped in turns
// and with the second one built last (its context current) and destroyed first (no context current: the
// first world's frames after that were the last image rendered, again and again).
TEST(World, TwoWorldsStepInTurnsAsEachAlone) {
  const fs::path wall = write_scene("turns_wall", kWallScene);
  const fs::path near = write_scene("turns_near", std::string(kWallScene) +
                                                      "    <geom type=\"box\" pos=\"1.2 0 1.25\" size=\"0.2 0.6 0.6\"/>\n");
  const ScenarioConfig a_config = scenario_in(wall, {moving_rig()}, 0.3);  // moving: no two frames alike
  const ScenarioConfig b_config = scenario_in(near, {still_rig("cam", PoseConfig{0.15, 0.3, 1.25, 0, 0, 10})}, 0.2);
  const auto a_alone = run_all(a_config);
  const auto b_alone = run_all(b_config);
  ASSERT_GE(a_alone.size(), 5u);
  std::vector<core::SensorFrame> a_frames;
  {
    World a(a_config, nullptr);
    {
      World b(b_config, nullptr);
      std::size_t k = 0;
      for (auto fa = a.step(); !fa.empty(); fa = a.step(), ++k) {
        for (auto& f : fa) a_frames.push_back(std::move(f));
        const auto fb = b.step();
        ASSERT_EQ(fb.size(), 1u);
        ASSERT_LT(k, b_alone.size());
        EXPECT_TRUE(same_bytes(fb[0].image, b_alone[k].image)) << "b, frame " << k;
        EXPECT_TRUE(same_bytes(fb[0].depth_m, b_alone[k].depth_m)) << "b, frame " << k;
        if (k == 1) break;  // b goes away while a renders on
      }
    }
    for (auto fa = a.step(); !fa.empty(); fa = a.step()) {
      for (auto& f : fa) a_frames.push_back(std::move(f));
    }
  }
  ASSERT_EQ(a_frames.size(), a_alone.size());
  for (std::size_t i = 0; i < a_frames.size(); ++i) {
    EXPECT_TRUE(same_bytes(a_frames[i].image, a_alone[i].image)) << "a, frame " << i;
    EXPECT_TRUE(same_bytes(a_frames[i].depth_m, a_alone[i].depth_m)) << "a, frame " << i;
  }
}

TEST(World, DiffDriveRobotFollowsItsPathAndStopsAtWalls) {
  const fs::path dir = write_scene("drive", kWallScene);
  const RobotConfig rover = small_rover(1, {{1.0, 0.0}, {4.0, 0.0}});  // 4 m: behind the wall (face at x = 2.15), where it must stop
  World world(scenario_in(dir, {rover}, 12.0), nullptr);
  int contacts = 0;
  for (auto frames = world.step(); !frames.empty(); frames = world.step()) {
    contacts += world.truth(0).contacts_with_scene > 0 ? 1 : 0;
  }
  const double x = world.truth(0).T_world_body.translation().x();
  EXPECT_NEAR(x, 2.15 - rover.radius_m, 0.02);
  EXPECT_GT(contacts, 0);
}

TEST(World, BodyCylinderHoldsWhatAnotherCameraSeesOfTheRobot) {
  const fs::path dir = write_scene("body", "    <geom type=\"plane\" size=\"30 30 0.1\" rgba=\"0.5 0.5 0.5 1\"/>\n");
  RobotConfig rover;
  rover.name = "rover";
  rover.seed = 3;
  rover.initial_pose = PoseConfig{1.2, 0.1, 0, 0, 0, 30};
  rover.camera.width = 32;
  rover.camera.height = 24;
  RobotConfig rig = still_rig("cam", PoseConfig{0, 0, 0.5, 0, 12, 0});  // looking down at the rover
  rig.camera.width = 320;
  rig.camera.height = 240;
  World world(scenario_in(dir, {rig, rover}), nullptr);
  const BodyCylinder rover_body = world.body_cylinder(1);
  EXPECT_DOUBLE_EQ(rover_body.radius_m, rover.radius_m);  // the base is the widest part
  EXPECT_GT(rover_body.z_min_m, 0.0);                      // it does not reach into the floor
  EXPECT_GT(rover_body.z_max_m, 0.3);                      // the mast with the camera
  const BodyCylinder rig_body = world.body_cylinder(0);
  EXPECT_NEAR(rig_body.radius_m, std::hypot(0.04, 0.08), 1e-9);
  EXPECT_NEAR(rig_body.z_max_m - rig_body.z_min_m, 0.06, 1e-9);

  const auto frames = world.step();
  ASSERT_EQ(frames.size(), 2u);
  const core::PinholeCamera camera = world.sensor_rig(0).cam0;
  const Eigen::Isometry3d T_body_cam = world.truth(1).T_world_body.inverse() * *frames[0].T_world_cam_gt;
  int seen = 0;
  double widest = 0.0;
  for (int v = 0; v < camera.height(); ++v) {
    for (int u = 0; u < camera.width(); ++u) {
      const float depth = frames[0].depth_m.at<float>(v, u);
      if (!(depth > 0.0f) || depth > 10.0f) continue;
      const Eigen::Vector3d p_world = *frames[0].T_world_cam_gt * (*camera.unproject(Eigen::Vector2d(u, v)) * depth);
      if (p_world.z() < 5e-3) continue;  // the floor
      const Eigen::Vector3d p = T_body_cam * (*camera.unproject(Eigen::Vector2d(u, v)) * depth);
      ++seen;
      widest = std::max(widest, p.head<2>().norm());
      ASSERT_LE(p.head<2>().norm(), rover_body.radius_m + 2e-3) << "pixel " << u << ", " << v;
      ASSERT_GE(p.z(), rover_body.z_min_m - 2e-3);
      ASSERT_LE(p.z(), rover_body.z_max_m + 2e-3);
    }
  }
  EXPECT_GT(seen, 1000);
  EXPECT_GT(widest, rover_body.radius_m - 0.01);  // the cylinder is tight
}

TEST(World, SurfacePointsLieOnTheSceneAndExcludeRobots) {
  const fs::path dir = write_scene(
      "surface", "    <geom type=\"box\" pos=\"1 2 0.5\" size=\"0.5 0.25 0.5\" rgba=\"1 1 1 1\"/>\n");
  RobotConfig rover;
  rover.name = "rover";
  rover.initial_pose = PoseConfig{-2, 0, 0, 0, 0, 0};
  rover.camera.enabled = false;
  World world(scenario_in(dir, {rover}), nullptr);
  const auto points = world.surface_points(0.05);
  // Area 2 * (1*0.5 + 1*1 + 0.5*1) = 4 m^2 -> about 1600 points at 5 cm.
  EXPECT_NEAR(static_cast<double>(points.size()), 1600.0, 200.0);
  for (const auto& p : points) {
    const Eigen::Vector3d q = (p.cast<double>() - Eigen::Vector3d(1, 2, 0.5)).cwiseAbs();
    const Eigen::Vector3d half(0.5, 0.25, 0.5);
    ASSERT_TRUE((q.array() <= half.array() + 1e-5).all());
    ASSERT_LT((half - q).minCoeff(), 1e-5);  // on a face
  }
}

// An infinite plane (size 0) is sampled over the rest of the scene's extent, wherever that lies: it was
// a square centred on the plane's origin, so a room far from the origin had no floor samples under it.
TEST(World, AnInfinitePlaneIsSampledUnderTheScene) {
  const fs::path dir = write_scene("infinite_plane",
                                   "    <geom type=\"plane\" size=\"0 0 0.1\" rgba=\"1 1 1 1\"/>\n"
                                   "    <geom type=\"box\" pos=\"20 10 0.5\" size=\"2 2 0.5\" rgba=\"1 1 1 1\"/>\n");
  RobotConfig rover;
  rover.name = "rover";
  rover.initial_pose = PoseConfig{17, 10, 0, 0, 0, 0};
  rover.camera.enabled = false;
  World world(scenario_in(dir, {rover}), nullptr);
  const auto points = world.surface_points(0.05);
  std::size_t floor = 0;
  bool under_the_box = false;
  for (const auto& p : points) {
    if (std::abs(p.z()) > 1e-4f) continue;
    ++floor;
    ASSERT_GT(p.x(), 15.0) << p.transpose();
    ASSERT_GT(p.y(), 6.0) << p.transpose();
    under_the_box = under_the_box || (p.head<2>() - Eigen::Vector2f(20.0f, 10.0f)).norm() < 0.1f;
  }
  EXPECT_GT(floor, 5000u);
  EXPECT_TRUE(under_the_box);
}

// Sensors are sampled at physics steps: an IMU faster than the physics would get two ticks in one step
// (and then none at all), so it is refused, as a camera that fast is.
TEST(World, AnImuFasterThanThePhysicsIsRefused) {
  const fs::path dir = write_scene("imu_rate", kWallScene);
  RobotConfig rig = still_rig("cam", PoseConfig{});
  rig.imu.enabled = true;
  rig.imu.noise.rate_hz = 200.0;
  ScenarioConfig scenario = scenario_in(dir, {rig});
  scenario.physics_step_s = 0.01;
  try {
    World world(scenario, nullptr);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("IMU rate"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("cam"), std::string::npos) << e.what();
  }
  scenario.physics_step_s = 0.005;  // 200 Hz: one sample per step
  EXPECT_NO_THROW(World(scenario, nullptr));
  scenario.physics_step_s = 0.003;  // 200 Hz in steps of 3 ms: gaps of 6, 3, 6, 6, 3 ms
  try {
    World world(scenario, nullptr);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("not a whole number of physics steps"), std::string::npos) << e.what();
  }
  // The step the ticks fall on is physics_step_s rounded to nanoseconds: 3333334 ns here, longer than
  // the IMU's period (3333333.4 ns), though 299.99999 Hz x 0.0033333335 s is below 1.
  scenario.physics_step_s = 0.0033333335;
  scenario.robots[0].imu.noise.rate_hz = 299.99999;
  EXPECT_THROW(World(scenario, nullptr), InputError);
}

// MuJoCo integrates the velocity actuators explicitly: a long physics step, or a light robot, makes the
// drive loop diverge (MuJoCo then resets the robot to its start). Such a world is refused, naming the step.
TEST(World, APhysicsStepTooLongForTheDriveIsRefused) {
  const fs::path dir = write_scene("drive_step", kWallScene);
  RobotConfig rover;
  rover.name = "rover";
  rover.initial_pose = PoseConfig{0.0, 0.0, 0.0, 0, 0, 0};
  rover.camera.enabled = false;
  rover.imu.enabled = false;
  const auto error_of = [&](const ScenarioConfig& scenario) -> std::string {
    try {
      World world(scenario, nullptr);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  ScenarioConfig scenario = scenario_in(dir, {rover});
  EXPECT_EQ(error_of(scenario), "") << "the default step and robot";
  scenario.physics_step_s = 0.05;
  std::string error = error_of(scenario);
  EXPECT_NE(error.find("physics_step_s 0.05"), std::string::npos) << error;
  EXPECT_NE(error.find("rover"), std::string::npos) << error;
  scenario.physics_step_s = 0.001;
  scenario.robots[0].radius_m = 0.02;  // a 4 cm robot at the default step
  error = error_of(scenario);
  EXPECT_NE(error.find("yaw inertia"), std::string::npos) << error;
}

// A free rig's IMU reads the model's gravity, as a diff-drive robot's (MuJoCo's sensors) does: a scene
// with other gravity made the two kinds disagree.
TEST(World, AFreeRigAtRestReadsTheScenesGravity) {
  const fs::path dir = fs::temp_directory_path() / "fleetslam_test_world_gravity";
  fs::create_directories(dir);
  std::ofstream(dir / "scene.xml") << "<mujoco model=\"g\">\n  <option gravity=\"0 0 -5\"/>\n  <asset><material name=\"glow\" "
                                      "rgba=\"1 0 0 1\" emission=\"1\"/></asset>\n  <worldbody>\n"
                                   << kWallScene << "  </worldbody>\n</mujoco>\n";
  RobotConfig rig = still_rig("rig", PoseConfig{0.15, 0.0, 1.25, 0, 0, 0});
  rig.imu.enabled = true;
  World world(scenario_in(dir, {rig}, 0.2), nullptr);
  int samples = 0;
  for (auto frames = world.step(); !frames.empty(); frames = world.step()) {
    for (const core::ImuSample& s : frames[0].imu) {
      EXPECT_NEAR((s.accel_mps2 - Eigen::Vector3d(0, 0, 5.0)).norm(), 0.0, 1e-9);
      ++samples;
    }
  }
  EXPECT_GT(samples, 10);
}

// A ScenarioConfig built in code leaves robot seeds at -1: the world derives them as validation does, so
// two robots do not draw the same noise.
TEST(World, RobotsWithoutSeedsDrawDifferentNoise) {
  const fs::path dir = write_scene("seeds", kWallScene);
  RobotConfig a = still_rig("a", PoseConfig{0.15, 0.0, 1.25, 0, 0, 0});
  RobotConfig b = still_rig("b", PoseConfig{0.15, 0.5, 1.25, 0, 0, 0});
  for (RobotConfig* r : {&a, &b}) {
    r->seed = -1;
    r->imu.enabled = true;
    r->imu.noise_enabled = true;
  }
  World world(scenario_in(dir, {a, b}, 0.2), nullptr);
  EXPECT_EQ(world.robot_config(0).seed, 1001);  // scenario seed 1: 1 * 1000 + index + 1
  EXPECT_EQ(world.robot_config(1).seed, 1002);
  const auto frames = world.step();
  ASSERT_EQ(frames.size(), 2u);
  ASSERT_FALSE(frames[0].imu.empty());
  ASSERT_EQ(frames[0].imu.size(), frames[1].imu.size());
  EXPECT_NE(frames[0].imu[0].gyro_radps, frames[1].imu[0].gyro_radps);
}

// At the end of the run truth() is the state at end_ns, as at any frame: a world that ends at 0.5 s and one
// that goes on, seen at its frame at 0.5 s, agree. mj_step had left the kinematics of the step before
// (0.4 mm behind for a robot at 0.4 m/s).
TEST(World, TruthAtTheEndIsTheStateAtTheEnd) {
  const fs::path dir = write_scene("truth_end", kWallScene);
  RobotConfig rover;
  rover.name = "rover";
  rover.initial_pose = PoseConfig{0.0, 0.0, 0.0, 0, 0, 0};
  rover.camera.width = 64;
  rover.camera.height = 48;
  rover.imu.enabled = false;
  WaypointConfig ahead;
  ahead.x = 1.5;
  rover.waypoints = {ahead};
  World ending(scenario_in(dir, {rover}, 0.5), nullptr);
  while (!ending.step().empty()) {
  }
  ASSERT_EQ(ending.time_ns(), 500'000'000);
  World going_on(scenario_in(dir, {rover}, 1.0), nullptr);
  while (going_on.time_ns() < 500'000'000) ASSERT_FALSE(going_on.step().empty());
  ASSERT_EQ(going_on.time_ns(), 500'000'000);
  const RobotTruth a = ending.truth(0);
  const RobotTruth b = going_on.truth(0);
  EXPECT_GT(b.T_world_body.translation().x(), 0.05) << "the robot must move for this test";
  EXPECT_LT((a.T_world_body.translation() - b.T_world_body.translation()).norm(), 1e-12);
}

TEST(World, SetPathRefusesABadRobotIndex) {
  const fs::path dir = write_scene("set_path", kWallScene);
  World world(scenario_in(dir, {still_rig("cam", PoseConfig{})}), nullptr);
  EXPECT_THROW(world.set_path(99, {}), std::invalid_argument);
  EXPECT_THROW(world.set_path(0, {}), std::invalid_argument);  // a free rig
}

TEST(World, MissingOrMalformedSceneNamesTheFile) {
  const fs::path dir = write_scene("bad", kWallScene);
  std::ofstream(dir / "broken.xml") << "<mujoco><worldbody><geom type=\"box\" size=\"1\"";
  ScenarioConfig scenario = scenario_in(dir, {still_rig("cam", PoseConfig{})});
  scenario.scene = "missing.xml";
  try {
    World world(scenario, nullptr);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.xml"), std::string::npos) << e.what();
  }
  scenario.scene = "broken.xml";
  try {
    World world(scenario, nullptr);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("broken.xml"), std::string::npos) << e.what();
  }
}

TEST(Scenario, LoadsAndRejectsBadFiles) {
  const fs::path dir = write_scene("scenario", kWallScene);
  auto write = [&](const std::string& text) {
    std::ofstream(dir / "s.yaml") << text;
    return dir / "s.yaml";
  };
  const auto good = load_scenario(write(
      "scene: scene.xml\nseed: 4\nrobots:\n  - {name: a, initial_pose: {x: 0}}\n  - {name: b, initial_pose: {x: 1}}\n"));
  ASSERT_EQ(good.robots.size(), 2u);
  EXPECT_EQ(good.robots[0].seed, 4001);
  EXPECT_EQ(good.robots[1].seed, 4002);
  auto error_of = [&](const std::string& text) -> std::string {
    try {
      load_scenario(write(text));
    } catch (const InputError& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_NE(error_of("scene: scene.xml\nrobots:\n  - {name: a}\n  - {name: b, initial_pose: {x: 0.1}}\n")
                .find("robots[1].initial_pose: robot 'b' starts overlapping robot 'a'"),
            std::string::npos);
  EXPECT_NE(error_of("scene: scene.xml\nrobots:\n  - {name: a, type: tank}\n").find("robots[0].type: unknown value 'tank'"),
            std::string::npos);
  EXPECT_NE(error_of("scene: nowhere.xml\nrobots:\n  - {name: a}\n").find("s.yaml:scene: scene file"),
            std::string::npos);
  EXPECT_NE(error_of("scene: scene.xml\nrobots:\n  - {name: a}\n  - {name: a, initial_pose: {x: 3}}\n")
                .find("duplicate robot name 'a'"),
            std::string::npos);
  EXPECT_NE(error_of("scene: scene.xml\nrobots: []\n").find("at least one robot"), std::string::npos);
  // The sections of the layers above (fleetslam run) are left to them; other unknown keys are errors.
  EXPECT_EQ(load_scenario(write("scene: scene.xml\nrobots:\n  - {name: a}\nmission: {kind: explore}\ncriteria: {x: 1}\n"
                                "agent: {}\ncentral: {}\nplanner: {}\n"))
                .robots.size(),
            1u);
  EXPECT_NE(error_of("scene: scene.xml\nrobots:\n  - {name: a}\nmisson: {kind: explore}\n").find("misson: unknown key"),
            std::string::npos);
  EXPECT_NE(error_of("scene: scene.xml\nrobots:\n  - {name: r, type: free_rig, waypoints: [{t_s: 1}]}\n")
                .find("at least 2 timed waypoints"),
            std::string::npos);
  // What the World's parts refused later, as internal errors or naming the scene, names file:key here.
  const std::string a = "scene: scene.xml\nrobots:\n  - {name: a, ";
  EXPECT_NE(error_of("scene: scene.xml\nrobots:\n  - {name: r, type: free_rig, waypoints: [{t_s: 0}, {t_s: 1e-10}]}\n")
                .find("robots[0].waypoints[1].t_s: waypoint times must increase"),
            std::string::npos);
  EXPECT_NE(error_of(a + "camera: {depth_noise: {max_depth_m: 0.2}}}\n").find("robots[0].camera.depth_noise.max_depth_m"),
            std::string::npos);
  EXPECT_NE(error_of(a + "imu: {initial_gyro_bias_radps: [0.1]}}\n").find("robots[0].imu.initial_gyro_bias_radps"),
            std::string::npos);
  EXPECT_NE(error_of(a + "imu: {initial_accel_bias_mps2: [0, 0, 0, 1]}}\n").find("robots[0].imu.initial_accel_bias_mps2"),
            std::string::npos);
  EXPECT_NE(error_of("scene: scene.xml\nphysics_step_s: 0.05\nrobots:\n  - {name: a, camera: {rate_hz: 30}}\n")
                .find("robots[0].camera.rate_hz"),
            std::string::npos);
  EXPECT_NE(error_of("scene: scene.xml\nphysics_step_s: 0.01\nrobots:\n  - {name: a, imu: {rate_hz: 200}}\n")
                .find("robots[0].imu.rate_hz"),
            std::string::npos);
  // An IMU period that is not a whole number of steps (200 Hz at 3 ms, 300 Hz at 1 ms) would be uneven.
  EXPECT_NE(error_of("scene: scene.xml\nphysics_step_s: 0.003\nrobots:\n  - {name: a, imu: {rate_hz: 200}}\n")
                .find("robots[0].imu.rate_hz: 200.000000 Hz is not a whole number of physics steps"),
            std::string::npos);
  EXPECT_NE(error_of(a + "imu: {rate_hz: 300}}\n").find("take 250.000000 or 333.333333 Hz"), std::string::npos)
      << error_of(a + "imu: {rate_hz: 300}}\n");
  EXPECT_NE(error_of("scene: scene.xml\nduration_s: 0\nrobots:\n  - {name: a}\n").find("duration_s"), std::string::npos);
  EXPECT_NE(error_of("scene: scene.xml\nrobots:\n  - {name: r, type: free_rig, waypoints: [{t_s: 0}, {t_s: 1, yaw_deg: 1e300}]}\n")
                .find("robots[0].waypoints[1].yaw_deg"),
            std::string::npos);
  EXPECT_NE(error_of(a + "camera: {enabled: false}, imu: {enabled: true}}\n").find("robots[0].imu.enabled"),
            std::string::npos);
  // A zero noise figure would be exported in a calibration no reader takes (at the end of a generate).
  EXPECT_NE(error_of(a + "imu: {gyro_random_walk: 0}}\n").find("robots[0].imu.gyro_random_walk: must be positive"),
            std::string::npos);
  EXPECT_NE(error_of(a + "imu: {accel_noise_density: 0, noise_enabled: false}}\n").find("robots[0].imu.accel_noise_density"),
            std::string::npos);
  EXPECT_NE(error_of("scene: scene.xml\nrobots:\n  - {name: R&D}\n").find("robots[0].name: robot name 'R&D'"),
            std::string::npos);
  EXPECT_NE(error_of("scene: scene.xml\nseed: 1000000000000001\nrobots:\n  - {name: a}\n").find("seed"), std::string::npos);
  // Robot b's derived seed (1 * 1000 + 1 + 1) is the seed robot a was given: identical noise, refused.
  EXPECT_NE(error_of("scene: scene.xml\nrobots:\n  - {name: a, seed: 1002}\n  - {name: b, initial_pose: {x: 1}}\n")
                .find("robots[1].seed: robot 'b' has seed 1002, as robot 'a' has"),
            std::string::npos);
  // A free rig starts at its first waypoint, not at its (unused) initial pose.
  const std::string rig = "  - {name: r, type: free_rig, waypoints: [{t_s: 0, x: X}, {t_s: 1, x: 4}]}\n";
  const auto with_rig_at = [&](const std::string& x) {
    std::string text = "scene: scene.xml\nrobots:\n  - {name: a}\n" + rig;
    text.replace(text.find('X'), 1, x);
    return text;
  };
  EXPECT_EQ(error_of(with_rig_at("3")), "no error");
  EXPECT_NE(error_of(with_rig_at("0.1")).find("robot 'r' starts overlapping robot 'a'"), std::string::npos);
  // Settings a robot type does not use are refused, not ignored; a free rig without an initial pose starts
  // at its first waypoint, and one given must be that pose.
  const auto error_with = [&](const std::string& robot) { return error_of("scene: scene.xml\nrobots:\n  - " + robot + "\n"); };
  EXPECT_NE(error_with("{name: a, initial_pose: {pitch_deg: 10}}").find("robots[0].initial_pose.pitch_deg: a diff_drive"),
            std::string::npos);
  EXPECT_NE(error_with("{name: a, waypoints: [{x: 1, y: 1}, {x: 2, y: 1, t_s: 4}]}").find("robots[0].waypoints[1].t_s"),
            std::string::npos);
  EXPECT_NE(error_with("{name: a, waypoints: [{x: 1, y: 1, yaw_deg: 90}]}").find("robots[0].waypoints[0].yaw_deg"),
            std::string::npos);
  EXPECT_NE(error_with("{name: a, controller: {max_speed_mps: 0}}").find("robots[0].controller.max_speed_mps: must be positive"),
            std::string::npos);
  EXPECT_NE(error_with("{name: a, controller: {max_yaw_rate_radps: 0}}").find("controller.max_yaw_rate_radps"),
            std::string::npos);
  const std::string knots = "waypoints: [{t_s: 0, x: 1, y: 2, z: 1, yaw_deg: 30}, {t_s: 1, x: 2}]";
  EXPECT_NE(error_with("{name: r, type: free_rig, controller: {max_speed_mps: 1}, " + knots + "}")
                .find("robots[0].controller.max_speed_mps: a free_rig"),
            std::string::npos);
  EXPECT_NE(error_with("{name: r, type: free_rig, initial_pose: {x: 1, y: 2, z: 1}, " + knots + "}")
                .find("robots[0].initial_pose.yaw_deg: a free_rig starts at its first waypoint"),
            std::string::npos);
  EXPECT_EQ(error_with("{name: r, type: free_rig, initial_pose: {x: 1, y: 2, z: 1, yaw_deg: 30}, " + knots + "}"), "no error");
  const ScenarioConfig rig_only = load_scenario(write("scene: scene.xml\nrobots:\n  - {name: r, type: free_rig, " + knots + "}\n"));
  EXPECT_EQ(rig_only.robots[0].initial_pose.yaw_deg, 30.0);
  EXPECT_EQ(rig_only.robots[0].initial_pose.z, 1.0);
  // Knots may count turns: a first knot at 400 degrees starts the rig at 40, and the scenario written with
  // that initial pose (generate's and run's effective scenario) loads again.
  const std::string turned = "waypoints: [{t_s: 0, x: 1, y: 2, z: 1, yaw_deg: 400}, {t_s: 1, x: 2, yaw_deg: 760}]";
  const ScenarioConfig spinning = load_scenario(write("scene: scene.xml\nrobots:\n  - {name: r, type: free_rig, " + turned + "}\n"));
  EXPECT_NEAR(spinning.robots[0].initial_pose.yaw_deg, 40.0, 1e-12);
  ScenarioConfig again = spinning;
  again.scene = (spinning.base_dir / spinning.scene).string();
  EXPECT_NO_THROW(load_scenario(write(core::config_to_yaml(again))));
  EXPECT_EQ(error_with("{name: r, type: free_rig, initial_pose: {x: 1, y: 2, z: 1, yaw_deg: 40}, " + turned + "}"), "no error");
  EXPECT_NE(error_with("{name: r, type: free_rig, waypoints: [{t_s: 0, x: 20000}, {t_s: 1}]}").find("waypoints[0].x"),
            std::string::npos);
}

}  // namespace
}  // namespace fleetslam::sim
