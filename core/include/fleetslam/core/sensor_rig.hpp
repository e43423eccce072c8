#pragma once
// What a robot (or a dataset) carries: its cameras, their extrinsics, the IMU and its noise.
// Filled by the ORB-SLAM settings reader, the EuRoC/TUM-VI readers, the TUM reader and the simulator.

#include <optional>
#include <string>

#include <Eigen/Geometry>

#include "fleetslam/core/camera.hpp"

namespace fleetslam::core {

enum class SensorMode { kMonocular, kStereo, kRgbd, kMonoInertial, kStereoInertial };

std::string to_string(SensorMode mode);
// "monocular", "stereo", "rgbd", "mono_inertial", "stereo_inertial"; nullopt otherwise.
std::optional<SensorMode> sensor_mode_from_string(const std::string& name);

// Continuous-time IMU noise densities (EuRoC/Kalibr convention).
struct ImuNoise {
  double gyro_noise_density = 1.6968e-4;   // rad / s / sqrt(Hz)
  double gyro_random_walk = 1.9393e-5;     // rad / s^2 / sqrt(Hz)
  double accel_noise_density = 2.0e-3;     // m / s^2 / sqrt(Hz)
  double accel_random_walk = 3.0e-3;       // m / s^3 / sqrt(Hz)
  double rate_hz = 200.0;
};

struct SensorRig {
  SensorMode mode = SensorMode::kMonocular;
  PinholeCamera cam0;                                          // colour / left camera, as recorded
  std::optional<PinholeCamera> cam1;                           // right camera of a stereo pair, as recorded
  Eigen::Isometry3d T_cam0_cam1 = Eigen::Isometry3d::Identity();  // pose of cam1 in the cam0 frame
  std::optional<Eigen::Isometry3d> T_body_cam0;               // pose of cam0 in the IMU/body frame
  std::optional<ImuNoise> imu;
  double depth_scale = 5000.0;  // RGB-D: raw depth units per metre
  double bf = 0.0;              // baseline times fx (stereo: real; RGB-D: virtual), pixel*metres
  double fps = 30.0;
  // ORB-SLAM's Camera.RGB flag, kept so settings files round-trip. It does not describe fleetslam's
  // frames: SensorFrame images are always BGR (OpenCV's order), whatever a settings file says.
  bool rgb_order = false;
};

}  // namespace fleetslam::core
