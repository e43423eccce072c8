// IMU measurement model: exact kinematics without noise, white-noise statistics against
// sigma_d = density * sqrt(rate), bias random-walk variance growing as random_walk^2 * t, initial
// biases, and repeatability from the seed. Every generator is seeded, so the numbers are fixed.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <vector>

#include "fleetslam/sim/imu_model.hpp"

namespace fleetslam::sim {
namespace {

constexpr core::TimeNs kStepNs = 5'000'000;  // 200 Hz, the default rate

ImuModelConfig white_only_config() {
  ImuModelConfig config;
  config.noise.gyro_random_walk = 0.0;
  config.noise.accel_random_walk = 0.0;
  return config;
}

// Mean and population standard deviation of a sample.
struct Moments {
  double mean = 0.0;
  double std = 0.0;
};

Moments moments(const std::vector<double>& values) {
  double sum = 0.0;
  double sum_sq = 0.0;
  for (double v : values) sum += v;
  const double mean = sum / static_cast<double>(values.size());
  for (double v : values) sum_sq += (v - mean) * (v - mean);
  return {mean, std::sqrt(sum_sq / static_cast<double>(values.size()))};
}

const Eigen::Vector3d kGyroTrue(0.1, -0.2, 0.3);
const Eigen::Vector3d kAccelTrue(0.5, -0.25, 9.81);

TEST(ImuModel, WithoutNoiseMeasuresTheExactKinematics) {
  ImuModelConfig config;
  config.noise_enabled = false;
  ImuModel imu(config, 7);
  for (int k = 0; k < 100; ++k) {
    const Eigen::Vector3d gyro = kGyroTrue * k;
    const Eigen::Vector3d accel = kAccelTrue + Eigen::Vector3d::Constant(0.01 * k);
    const core::ImuSample sample = imu.measure(k * kStepNs, gyro, accel);
    EXPECT_EQ(sample.t_ns, k * kStepNs);
    EXPECT_EQ(sample.gyro_radps, gyro);
    EXPECT_EQ(sample.accel_mps2, accel);
  }
  EXPECT_EQ(imu.gyro_bias_radps(), Eigen::Vector3d::Zero());
  EXPECT_EQ(imu.accel_bias_mps2(), Eigen::Vector3d::Zero());
}

// Without noise, configured initial biases are a known constant bias: added to every sample, never
// drawn or walked, and reported as the truth.
TEST(ImuModel, WithoutNoiseTheInitialBiasesAreHeld) {
  ImuModelConfig config;
  config.noise_enabled = false;
  config.initial_gyro_bias_radps = {0.01, 0.02, 0.03};
  config.initial_accel_bias_mps2 = {-0.1, 0.0, 0.2};
  const Eigen::Vector3d gyro_bias(0.01, 0.02, 0.03);
  const Eigen::Vector3d accel_bias(-0.1, 0.0, 0.2);
  ImuModel imu(config, 7);
  for (int k = 0; k < 100; ++k) {
    const core::ImuSample sample = imu.measure(k * kStepNs, kGyroTrue, kAccelTrue);
    EXPECT_EQ(sample.gyro_radps, kGyroTrue + gyro_bias);
    EXPECT_EQ(sample.accel_mps2, kAccelTrue + accel_bias);
  }
  EXPECT_EQ(imu.gyro_bias_radps(), gyro_bias);
  EXPECT_EQ(imu.accel_bias_mps2(), accel_bias);
}

TEST(ImuModel, WhiteNoiseHasTheDiscreteStandardDeviation) {
  const ImuModelConfig config = white_only_config();
  ImuModel imu(config, 42);
  constexpr int kSamples = 200'000;
  std::vector<std::vector<double>> errors(6);
  for (int k = 0; k < kSamples; ++k) {
    const core::ImuSample s = imu.measure(k * kStepNs, kGyroTrue, kAccelTrue);
    for (int axis = 0; axis < 3; ++axis) {
      errors[static_cast<std::size_t>(axis)].push_back(s.gyro_radps[axis] - kGyroTrue[axis]);
      errors[static_cast<std::size_t>(axis + 3)].push_back(s.accel_mps2[axis] - kAccelTrue[axis]);
    }
  }
  const double gyro_sigma_d = config.noise.gyro_noise_density * std::sqrt(config.noise.rate_hz);
  const double accel_sigma_d = config.noise.accel_noise_density * std::sqrt(config.noise.rate_hz);
  for (std::size_t i = 0; i < errors.size(); ++i) {
    const double sigma_d = i < 3 ? gyro_sigma_d : accel_sigma_d;
    const Moments m = moments(errors[i]);
    std::printf("white noise channel %zu: std / sigma_d = %.4f, mean / sigma_d = %+.4f\n", i, m.std / sigma_d,
                m.mean / sigma_d);
    // The std estimate from 2e5 samples has a relative spread of 1/sqrt(2N) = 0.16 %.
    EXPECT_NEAR(m.std / sigma_d, 1.0, 0.01) << "channel " << i << " std " << m.std << " vs " << sigma_d;
    EXPECT_LT(std::abs(m.mean), 5.0 * sigma_d / std::sqrt(double{kSamples})) << "channel " << i;
  }
  EXPECT_EQ(imu.gyro_bias_radps(), Eigen::Vector3d::Zero());
}

TEST(ImuModel, ConstantInitialBiasesShiftTheMean) {
  ImuModelConfig config = white_only_config();
  config.initial_gyro_bias_radps = {0.01, -0.02, 0.005};
  config.initial_accel_bias_mps2 = {0.1, 0.2, -0.3};
  ImuModel imu(config, 3);
  constexpr int kSamples = 50'000;
  Eigen::Vector3d gyro_sum = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_sum = Eigen::Vector3d::Zero();
  for (int k = 0; k < kSamples; ++k) {
    const core::ImuSample s = imu.measure(k * kStepNs, kGyroTrue, kAccelTrue);
    gyro_sum += s.gyro_radps;
    accel_sum += s.accel_mps2;
  }
  const Eigen::Vector3d gyro_bias(0.01, -0.02, 0.005);
  const Eigen::Vector3d accel_bias(0.1, 0.2, -0.3);
  EXPECT_LT((gyro_sum / kSamples - kGyroTrue - gyro_bias).cwiseAbs().maxCoeff(), 1e-4);
  EXPECT_LT((accel_sum / kSamples - kAccelTrue - accel_bias).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_EQ(imu.gyro_bias_radps(), gyro_bias);
  EXPECT_EQ(imu.accel_bias_mps2(), accel_bias);
}

// Variance of the bias over an ensemble of independently seeded IMUs, after `steps` steps, normalised
// by the Wiener-process prediction random_walk^2 * t (pooled over the three axes).
struct WalkVariance {
  double gyro_ratio = 0.0;
  double accel_ratio = 0.0;
};

std::vector<WalkVariance> bias_walk_variance_ratios(const std::vector<int>& checkpoints, int models) {
  const ImuModelConfig config;  // default densities and random walks
  std::vector<double> gyro_sq(checkpoints.size(), 0.0), accel_sq(checkpoints.size(), 0.0);
  for (int m = 0; m < models; ++m) {
    ImuModel imu(config, 1000 + static_cast<std::uint64_t>(m));
    std::size_t next = 0;
    for (int k = 0; k <= checkpoints.back(); ++k) {
      imu.measure(k * kStepNs, kGyroTrue, kAccelTrue);
      if (k != checkpoints[next]) continue;
      gyro_sq[next] += imu.gyro_bias_radps().squaredNorm();
      accel_sq[next] += imu.accel_bias_mps2().squaredNorm();
      ++next;
    }
  }
  std::vector<WalkVariance> ratios;
  for (std::size_t i = 0; i < checkpoints.size(); ++i) {
    const double t_s = core::ns_to_seconds(checkpoints[i] * kStepNs);
    const double samples = 3.0 * models;
    const double gyro_expected = config.noise.gyro_random_walk * config.noise.gyro_random_walk * t_s;
    const double accel_expected = config.noise.accel_random_walk * config.noise.accel_random_walk * t_s;
    ratios.push_back({gyro_sq[i] / samples / gyro_expected, accel_sq[i] / samples / accel_expected});
  }
  return ratios;
}

TEST(ImuModel, BiasRandomWalkVarianceGrowsLinearlyInTime) {
  // 2000 IMUs x 3 axes: the variance estimate has a relative spread of sqrt(2 / 6000) = 1.8 %.
  const std::vector<int> checkpoints = {50, 200, 800};
  const std::vector<WalkVariance> ratios = bias_walk_variance_ratios(checkpoints, 2000);
  for (std::size_t i = 0; i < ratios.size(); ++i) {
    std::printf("bias walk after %d steps: variance / (rw^2 t) gyro %.4f accel %.4f\n", checkpoints[i],
                ratios[i].gyro_ratio, ratios[i].accel_ratio);
    EXPECT_NEAR(ratios[i].gyro_ratio, 1.0, 0.07) << "after " << checkpoints[i] << " steps";
    EXPECT_NEAR(ratios[i].accel_ratio, 1.0, 0.07) << "after " << checkpoints[i] << " steps";
  }
}

TEST(ImuModel, UnevenStepsAccumulateTheSameWalk) {
  // The walk depends on elapsed time, not on the number of calls: 1 ms and 10 ms steps both reach 1 s.
  const ImuModelConfig config;
  for (core::TimeNs step_ns : {core::TimeNs{1'000'000}, core::TimeNs{10'000'000}}) {
    double sum_sq = 0.0;
    constexpr int kModels = 1000;
    for (int m = 0; m < kModels; ++m) {
      ImuModel imu(config, 5000 + static_cast<std::uint64_t>(m));
      for (core::TimeNs t = 0; t <= core::kNsPerSecond; t += step_ns) imu.measure(t, kGyroTrue, kAccelTrue);
      sum_sq += imu.gyro_bias_radps().squaredNorm();
    }
    const double expected = config.noise.gyro_random_walk * config.noise.gyro_random_walk * 1.0;
    EXPECT_NEAR(sum_sq / (3.0 * kModels) / expected, 1.0, 0.1) << "step " << step_ns << " ns";
  }
}

std::vector<core::ImuSample> stream(std::uint64_t seed, int count) {
  ImuModel imu(ImuModelConfig{}, seed);
  std::vector<core::ImuSample> samples;
  for (int k = 0; k < count; ++k) samples.push_back(imu.measure(k * kStepNs, kGyroTrue, kAccelTrue));
  return samples;
}

TEST(ImuModel, SameSeedGivesTheSameStreamAndAnotherSeedAnother) {
  const std::vector<core::ImuSample> a = stream(11, 500);
  const std::vector<core::ImuSample> b = stream(11, 500);
  const std::vector<core::ImuSample> c = stream(12, 500);
  int differing = 0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].gyro_radps, b[k].gyro_radps);
    EXPECT_EQ(a[k].accel_mps2, b[k].accel_mps2);
    if (a[k].gyro_radps != c[k].gyro_radps && a[k].accel_mps2 != c[k].accel_mps2) ++differing;
  }
  EXPECT_EQ(differing, static_cast<int>(a.size()));
}

TEST(ImuModel, RejectsBadBiasesAndTimeGoingBack) {
  ImuModelConfig config;
  config.initial_gyro_bias_radps = {0.0, 0.0};
  EXPECT_THROW(ImuModel(config, 1), std::invalid_argument);
  config = ImuModelConfig{};
  config.initial_accel_bias_mps2 = {0.0, 0.0, 0.0, 0.0};
  EXPECT_THROW(ImuModel(config, 1), std::invalid_argument);

  ImuModel imu(ImuModelConfig{}, 1);
  imu.measure(10 * kStepNs, kGyroTrue, kAccelTrue);
  EXPECT_THROW(imu.measure(9 * kStepNs, kGyroTrue, kAccelTrue), std::invalid_argument);
  EXPECT_NO_THROW(imu.measure(10 * kStepNs, kGyroTrue, kAccelTrue));  // a repeated stamp adds no walk
}

}  // namespace
}  // namespace fleetslam::sim
