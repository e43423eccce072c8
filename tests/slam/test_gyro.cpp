// Gyro integration against an oracle (RK4 on dR/dt = R [w]x over the same piecewise-constant rates),
// the camera-frame change of basis, and the windows it must refuse (holes, empty, backwards).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <Eigen/SVD>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/se3.hpp"
#include "fleetslam/slam/gyro.hpp"

namespace fleetslam::slam {
namespace {

constexpr core::TimeNs kPeriodNs = 5'000'000;  // 200 Hz

// Samples at k * 5 ms for k in [first, last], with rates from `rate(k)`.
template <class Rate>
std::vector<core::ImuSample> samples(int first, int last, Rate rate) {
  std::vector<core::ImuSample> out;
  for (int k = first; k <= last; ++k) {
    core::ImuSample s;
    s.t_ns = k * kPeriodNs;
    s.gyro_radps = rate(k);
    out.push_back(s);
  }
  return out;
}

Eigen::Matrix3d hat(const Eigen::Vector3d& w) {
  Eigen::Matrix3d W;
  W << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return W;
}

// The IMU's rotation over (t0, t1] when sample k's rate holds over ((k-1) T, k T]: dR/dt = R [w]x
// integrated by RK4 in 100 steps per piece (no exponential map involved), then re-orthonormalised.
Eigen::Matrix3d oracle(const std::vector<core::ImuSample>& s, core::TimeNs t0, core::TimeNs t1) {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  core::TimeNs from = t0;
  for (const core::ImuSample& x : s) {
    if (x.t_ns <= from) continue;
    const core::TimeNs to = std::min(x.t_ns, t1);
    const Eigen::Matrix3d W = hat(x.gyro_radps);
    const double h = static_cast<double>(to - from) * 1e-9 / 100.0;
    for (int i = 0; i < 100; ++i) {
      const Eigen::Matrix3d k1 = R * W, k2 = (R + 0.5 * h * k1) * W, k3 = (R + 0.5 * h * k2) * W, k4 = (R + h * k3) * W;
      R += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    }
    from = to;
    if (from >= t1) break;
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  return svd.matrixU() * svd.matrixV().transpose();
}

double angle_deg(const Eigen::Matrix3d& R) { return core::so3_log(R).norm() * 180.0 / M_PI; }

TEST(GyroIntegrator, ConstantRateGivesTheExactRotation) {
  const Eigen::Vector3d w(0.1, -0.4, 0.8);
  const auto s = samples(0, 40, [&](int) { return w; });
  const GyroIntegrator gyro(Eigen::Matrix3d::Identity(), 0.05);
  const auto R = gyro.rotation(s, 33'000'000, 166'000'000);  // window ends between samples
  ASSERT_TRUE(R.has_value());
  EXPECT_LT(angle_deg(R->transpose() * core::so3_exp(w * 0.133)), 1e-9);
}

TEST(GyroIntegrator, VaryingRatesMatchTheFineStepOracle) {
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  const auto s = samples(0, 60, [&](int) { return Eigen::Vector3d(n(rng), n(rng), n(rng)); });
  const GyroIntegrator gyro(Eigen::Matrix3d::Identity(), 0.05);
  // Starts inside a sample's interval, ends on a sample stamp.
  const core::TimeNs t0 = 12'345'678, t1 = 50 * kPeriodNs;
  const auto R = gyro.rotation(s, t0, t1);
  ASSERT_TRUE(R.has_value());
  EXPECT_GT(angle_deg(*R), 5.0);  // a real rotation, not a trivial one
  EXPECT_LT(angle_deg(R->transpose() * oracle(s, t0, t1)), 1e-3);
}

TEST(GyroIntegrator, RotationsAreExpressedInTheCameraFrame) {
  // The camera looks along the body's x axis (optical z = body x, optical x = -body y, optical y = -body z):
  // a yaw rate about body z is a rotation about the camera's -y axis.
  Eigen::Matrix3d R_body_cam;
  R_body_cam << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  const GyroIntegrator gyro(R_body_cam.transpose(), 0.05);
  const auto s = samples(0, 20, [](int) { return Eigen::Vector3d(0.0, 0.0, 0.5); });
  const auto R = gyro.rotation(s, 0, 20 * kPeriodNs);
  ASSERT_TRUE(R.has_value());
  const Eigen::Vector3d phi = core::so3_log(*R);
  EXPECT_NEAR(phi.x(), 0.0, 1e-12);
  EXPECT_NEAR(phi.y(), -0.05, 1e-12);
  EXPECT_NEAR(phi.z(), 0.0, 1e-12);
}

TEST(GyroIntegrator, SamplesOutsideTheWindowAreIgnored) {
  const auto inside = samples(5, 10, [](int) { return Eigen::Vector3d(0.0, 0.3, 0.0); });
  auto all = samples(0, 4, [](int) { return Eigen::Vector3d(9.0, 0.0, 0.0); });
  all.insert(all.end(), inside.begin(), inside.end());
  const auto after = samples(11, 15, [](int) { return Eigen::Vector3d(0.0, 0.0, 9.0); });
  all.insert(all.end(), after.begin(), after.end());
  const GyroIntegrator gyro(Eigen::Matrix3d::Identity(), 0.05);
  const auto R = gyro.rotation(all, 4 * kPeriodNs, 10 * kPeriodNs);
  ASSERT_TRUE(R.has_value());
  EXPECT_LT(angle_deg(R->transpose() * core::so3_exp(Eigen::Vector3d(0.0, 0.3 * 0.03, 0.0))), 1e-9);
}

TEST(GyroIntegrator, HolesEmptyWindowsAndBadSamplesGiveNothing) {
  const GyroIntegrator gyro(Eigen::Matrix3d::Identity(), 0.012);  // a little over two periods
  const auto rate = [](int) { return Eigen::Vector3d(0.0, 0.0, 1.0); };
  auto s = samples(0, 40, rate);
  EXPECT_TRUE(gyro.rotation(s, 0, 40 * kPeriodNs).has_value());
  // A hole of three periods in the middle.
  auto holed = s;
  holed.erase(holed.begin() + 20, holed.begin() + 22);
  EXPECT_FALSE(gyro.rotation(holed, 0, 40 * kPeriodNs).has_value());
  // Samples stop well before the end of the window, or start well after its beginning.
  EXPECT_FALSE(gyro.rotation(s, 0, 45 * kPeriodNs).has_value());
  EXPECT_FALSE(gyro.rotation(samples(10, 40, rate), 0, 40 * kPeriodNs).has_value());
  // No samples, an empty window, a window that goes backwards.
  EXPECT_FALSE(gyro.rotation({}, 0, kPeriodNs).has_value());
  EXPECT_FALSE(gyro.rotation(s, 10 * kPeriodNs, 10 * kPeriodNs).has_value());
  EXPECT_FALSE(gyro.rotation(s, 20 * kPeriodNs, 10 * kPeriodNs).has_value());
  // A NaN rate.
  auto bad = s;
  bad[5].gyro_radps.x() = std::nan("");
  EXPECT_FALSE(gyro.rotation(bad, 0, 40 * kPeriodNs).has_value());
}

TEST(GyroIntegrator, RefusesANonRotationExtrinsic) {
  EXPECT_THROW(GyroIntegrator(2.0 * Eigen::Matrix3d::Identity(), 0.05), std::exception);
  EXPECT_THROW(GyroIntegrator(Eigen::Matrix3d::Identity(), 0.0), std::exception);
}

}  // namespace
}  // namespace fleetslam::slam
