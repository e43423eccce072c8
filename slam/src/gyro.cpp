#include "fleetslam/slam/gyro.hpp"

#include <cmath>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/se3.hpp"

namespace fleetslam::slam {

GyroIntegrator::GyroIntegrator(const Eigen::Matrix3d& R_cam_imu, double max_gap_s)
    : R_cam_imu_(R_cam_imu), max_gap_ns_(core::seconds_to_ns(max_gap_s)) {
  FLEETSLAM_CHECK(R_cam_imu.allFinite() && std::abs(R_cam_imu.determinant() - 1.0) < 1e-6,
                  "GyroIntegrator: R_cam_imu is not a rotation");
  FLEETSLAM_CHECK(max_gap_ns_ > 0, "GyroIntegrator: the maximum gap must be positive");
}

std::optional<Eigen::Matrix3d> GyroIntegrator::rotation(const std::vector<core::ImuSample>& samples,
                                                        core::TimeNs t_prev_ns, core::TimeNs t_cur_ns) const {
  if (t_cur_ns <= t_prev_ns) return std::nullopt;
  Eigen::Matrix3d R_imu = Eigen::Matrix3d::Identity();  // IMU at t_cur in the IMU frame at t_prev
  core::TimeNs covered_ns = t_prev_ns;
  const core::ImuSample* last = nullptr;
  for (const core::ImuSample& s : samples) {
    if (s.t_ns <= covered_ns) continue;  // before the window (or out of order: ignored)
    if (s.t_ns > t_cur_ns) break;
    if (s.t_ns - covered_ns > max_gap_ns_ || !s.gyro_radps.allFinite()) return std::nullopt;
    R_imu = R_imu * core::so3_exp(s.gyro_radps * core::ns_to_seconds(s.t_ns - covered_ns));
    covered_ns = s.t_ns;
    last = &s;
  }
  if (last == nullptr || t_cur_ns - covered_ns > max_gap_ns_) return std::nullopt;
  if (covered_ns < t_cur_ns) R_imu = R_imu * core::so3_exp(last->gyro_radps * core::ns_to_seconds(t_cur_ns - covered_ns));
  return R_cam_imu_ * R_imu * R_cam_imu_.transpose();
}

}  // namespace fleetslam::slam
