#include "fleetslam/sim/imu_model.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace fleetslam::sim {
namespace {

Eigen::Vector3d bias_from_config(const std::vector<double>& values, const char* name) {
  if (values.size() != 3) {
    throw std::invalid_argument(std::string("ImuModel: ") + name + " must have 3 entries, got " +
                                std::to_string(values.size()));
  }
  const Eigen::Vector3d bias(values[0], values[1], values[2]);
  if (!bias.allFinite()) throw std::invalid_argument(std::string("ImuModel: ") + name + " must be finite");
  return bias;
}

// Three independent N(0, sigma^2) draws, x then y then z (the order is part of the determinism contract).
Eigen::Vector3d gaussian3(std::mt19937_64& rng, std::normal_distribution<double>& unit, double sigma) {
  const double x = unit(rng);
  const double y = unit(rng);
  const double z = unit(rng);
  return sigma * Eigen::Vector3d(x, y, z);
}

}  // namespace

ImuModel::ImuModel(const ImuModelConfig& config, std::uint64_t seed)
    : config_(config),
      rng_(seed),
      gyro_bias_(bias_from_config(config.initial_gyro_bias_radps, "initial_gyro_bias_radps")),
      accel_bias_(bias_from_config(config.initial_accel_bias_mps2, "initial_accel_bias_mps2")) {
  if (!(config.noise.rate_hz > 0.0)) {
    throw std::invalid_argument("ImuModel: rate_hz must be positive, got " + std::to_string(config.noise.rate_hz));
  }
}

core::ImuSample ImuModel::measure(core::TimeNs t_ns, const Eigen::Vector3d& gyro_true_radps,
                                  const Eigen::Vector3d& accel_true_mps2) {
  if (has_last_ && t_ns < last_t_ns_) {
    throw std::invalid_argument("ImuModel::measure: time went backwards (" + std::to_string(t_ns) + " ns after " +
                                std::to_string(last_t_ns_) + " ns)");
  }
  core::ImuSample sample;
  sample.t_ns = t_ns;
  sample.gyro_radps = gyro_true_radps;
  sample.accel_mps2 = accel_true_mps2;
  const bool first = !has_last_;
  const double dt_s = first ? 0.0 : core::ns_to_seconds(t_ns - last_t_ns_);
  has_last_ = true;
  last_t_ns_ = t_ns;
  if (!config_.noise_enabled) {  // the initial biases, held: a known constant bias with no draws
    sample.gyro_radps += gyro_bias_;
    sample.accel_mps2 += accel_bias_;
    return sample;
  }

  // Draw order: gyro walk, accel walk (not on the first call), gyro white, accel white.
  std::normal_distribution<double> unit(0.0, 1.0);
  const core::ImuNoise& n = config_.noise;
  if (!first) {
    // The bias is a Wiener process: its increment over dt has variance random_walk^2 * dt.
    const double sqrt_dt = std::sqrt(dt_s);
    gyro_bias_ += gaussian3(rng_, unit, n.gyro_random_walk * sqrt_dt);
    accel_bias_ += gaussian3(rng_, unit, n.accel_random_walk * sqrt_dt);
  }
  // A continuous white density sampled at rate f has the discrete std density * sqrt(f) (Kalibr IMU model).
  const double sqrt_rate = std::sqrt(n.rate_hz);
  sample.gyro_radps += gyro_bias_ + gaussian3(rng_, unit, n.gyro_noise_density * sqrt_rate);
  sample.accel_mps2 += accel_bias_ + gaussian3(rng_, unit, n.accel_noise_density * sqrt_rate);
  return sample;
}

}  // namespace fleetslam::sim
