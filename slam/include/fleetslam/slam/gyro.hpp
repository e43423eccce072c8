#pragma once
// Camera rotation between two frames from the gyroscope (the rotation half of IMU preintegration, with
// neither accelerometer nor bias: the tracker estimates the bias itself and uses the rotation to predict
// where the camera looks, which a constant-velocity model gets wrong when a robot starts or stops turning
// and cannot give at all through a stretch of frames it cannot track).
//
// Samples hold the rate over the interval that ends at their stamp (zero-order hold, as the IMU's
// integrated output); the rate after the last sample holds to the end of the window.

#include <optional>
#include <vector>

#include <Eigen/Core>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/sensor_frame.hpp"
#include "fleetslam/core/time.hpp"

namespace fleetslam::slam {

struct GyroConfig {
  bool enabled = true;  // use the gyroscope when the rig has one (rig.imu and rig.T_body_cam0)
  // Samples must cover the window without a hole longer than this (a dropped IMU stretch: no rotation).
  double max_gap_s = 0.05;
  // Bias estimate: exponential average of gyro minus visual rate over tracked frame pairs.
  double bias_time_constant_s = 5.0;
  double max_bias_residual_radps = 0.2;  // a pair further off than this is a tracking glitch: skipped
  // While lost, the gyro-predicted pose is tried against the last local map for this long.
  double recovery_s = 5.0;
  // While lost, the constant-velocity translation is extrapolated for this long at most (then held): the
  // velocity of the last frames before a loss is often already off.
  double max_translation_extrapolation_s = 0.2;
  // Search radius of the first match from a gyro-predicted pose, as a multiple of the local map's.
  double recovery_radius_factor = 2.0;

  template <class V>
  void visit(V& v) {
    v("enabled", enabled);
    v("max_gap_s", max_gap_s, core::Limits<double>{1e-4, 10.0});
    v("bias_time_constant_s", bias_time_constant_s, core::Limits<double>{0.01, 1e6});
    v("max_bias_residual_radps", max_bias_residual_radps, core::Limits<double>{0.0, 100.0});
    v("recovery_s", recovery_s, core::Limits<double>{0.0, 1e6});
    v("max_translation_extrapolation_s", max_translation_extrapolation_s, core::Limits<double>{0.0, 1e6});
    v("recovery_radius_factor", recovery_radius_factor, core::Limits<double>{1.0, 100.0});
  }
};

// Integrates gyroscope samples into the camera's rotation over a window.
class GyroIntegrator {
 public:
  // R_cam_imu: orientation of the IMU in the camera frame the rotations are wanted in.
  GyroIntegrator(const Eigen::Matrix3d& R_cam_imu, double max_gap_s);

  // R_prev_cur: the camera's orientation at t_cur_ns in its frame at t_prev_ns, from the samples with
  // stamps in (t_prev_ns, t_cur_ns] (others are ignored; samples must be in time order); nullopt when
  // they leave a hole longer than the maximum gap at either end or between them.
  std::optional<Eigen::Matrix3d> rotation(const std::vector<core::ImuSample>& samples, core::TimeNs t_prev_ns,
                                          core::TimeNs t_cur_ns) const;

 private:
  Eigen::Matrix3d R_cam_imu_;
  core::TimeNs max_gap_ns_;
};

}  // namespace fleetslam::slam
