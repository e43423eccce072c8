#pragma once
// IMU measurement model: true angular velocity and specific force (in the IMU frame) plus discrete
// white noise and a bias random walk, from continuous-time densities (EuRoC/Kalibr convention):
//   white:  sigma_d = density * sqrt(rate_hz)        bias walk per step: sigma = random_walk * sqrt(dt)
// One seeded generator per model; the true biases are kept for ground truth.
// Each call draws, in this order: the gyro bias step (x, y, z), the accel bias step (not on the first
// call), the gyro white noise, the accel white noise; so a seed fixes the whole stream.

#include <cstdint>
#include <random>

#include <Eigen/Core>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/sensor_frame.hpp"
#include "fleetslam/core/sensor_rig.hpp"

namespace fleetslam::sim {

struct ImuModelConfig {
  bool enabled = true;          // the robot carries an IMU (read by the world; the model ignores it)
  bool noise_enabled = true;    // false: the exact kinematics plus the initial biases, held (no draws)
  core::ImuNoise noise;         // densities and rate (EuRoC-like defaults)
  std::vector<double> initial_gyro_bias_radps = {0.0, 0.0, 0.0};
  std::vector<double> initial_accel_bias_mps2 = {0.0, 0.0, 0.0};

  template <class V>
  void visit(V& v) {
    v("enabled", enabled);
    v("noise_enabled", noise_enabled);
    v("rate_hz", noise.rate_hz, core::Limits<double>{1.0, 10000.0});
    v("gyro_noise_density", noise.gyro_noise_density, core::Limits<double>{0.0, 1.0});
    v("gyro_random_walk", noise.gyro_random_walk, core::Limits<double>{0.0, 1.0});
    v("accel_noise_density", noise.accel_noise_density, core::Limits<double>{0.0, 10.0});
    v("accel_random_walk", noise.accel_random_walk, core::Limits<double>{0.0, 10.0});
    v("initial_gyro_bias_radps", initial_gyro_bias_radps);
    v("initial_accel_bias_mps2", initial_accel_bias_mps2);
  }
};

class ImuModel {
 public:
  // Throws std::invalid_argument when a bias vector does not have 3 finite entries or rate_hz <= 0.
  ImuModel(const ImuModelConfig& config, std::uint64_t seed);

  // One measurement at t_ns of the true kinematics (gyro in rad/s, specific force in m/s^2, IMU frame).
  // Advances the bias random walk by the time since the previous call (the first call does not).
  // measurement = truth + bias + white noise, with the bias after this call's step.
  // Throws std::invalid_argument when t_ns is earlier than the previous call's.
  core::ImuSample measure(core::TimeNs t_ns, const Eigen::Vector3d& gyro_true_radps,
                          const Eigen::Vector3d& accel_true_mps2);

  const Eigen::Vector3d& gyro_bias_radps() const { return gyro_bias_; }
  const Eigen::Vector3d& accel_bias_mps2() const { return accel_bias_; }

 private:
  ImuModelConfig config_;
  std::mt19937_64 rng_;
  Eigen::Vector3d gyro_bias_;
  Eigen::Vector3d accel_bias_;
  core::TimeNs last_t_ns_ = 0;
  bool has_last_ = false;
};

}  // namespace fleetslam::sim
