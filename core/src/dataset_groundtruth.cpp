// Ground truth of recorded sequences: one pose per frame, looked up in a trajectory file.

#include <algorithm>
#include <cmath>
#include <system_error>

#include <spdlog/logger.h>

#include "dataset_internal.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/time.hpp"

namespace fleetslam::core::dataset_detail {

Eigen::Isometry3d interpolate_pose(const Eigen::Isometry3d& T_a, const Eigen::Isometry3d& T_b, double s) {
  const Eigen::Quaterniond q_a(T_a.linear());
  const Eigen::Quaterniond q_b(T_b.linear());
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q_a.slerp(s, q_b).normalized().toRotationMatrix();
  T.translation() = (1.0 - s) * T_a.translation() + s * T_b.translation();
  return T;
}

std::optional<TimeBracket> bracket_at(const Trajectory& trajectory, TimeNs t_ns, TimeNs max_gap_ns) {
  const auto after = std::lower_bound(trajectory.begin(), trajectory.end(), t_ns,
                                      [](const StampedPose& p, TimeNs t) { return p.t_ns < t; });
  if (after != trajectory.end() && after->t_ns == t_ns) {
    return TimeBracket{static_cast<std::size_t>(after - trajectory.begin()), 0.0};
  }
  if (after == trajectory.begin() || after == trajectory.end()) return std::nullopt;
  const auto before = std::prev(after);
  // Both neighbours must be close: interpolating across a motion-capture drop-out would invent motion.
  if (t_ns - before->t_ns > max_gap_ns || after->t_ns - t_ns > max_gap_ns) return std::nullopt;
  const double s = static_cast<double>(t_ns - before->t_ns) / static_cast<double>(after->t_ns - before->t_ns);
  return TimeBracket{static_cast<std::size_t>(before - trajectory.begin()), s};
}

Eigen::Isometry3d pose_at(const Trajectory& trajectory, const TimeBracket& at) {
  if (at.s == 0.0) return trajectory[at.index].T_world_body;
  return interpolate_pose(trajectory[at.index].T_world_body, trajectory[at.index + 1].T_world_body, at.s);
}

namespace {

// EuRoC's state columns after the pose: velocity (3), gyro bias (3), accelerometer bias (3).
constexpr std::size_t kStateColumns = 9;

ImuStateGt state_of(const std::vector<double>& c) {
  ImuStateGt state;
  state.v_world_mps = Eigen::Vector3d(c[0], c[1], c[2]);
  state.gyro_bias_radps = Eigen::Vector3d(c[3], c[4], c[5]);
  state.accel_bias_mps2 = Eigen::Vector3d(c[6], c[7], c[8]);
  return state;
}

// Linear between the two states around t (the biases walk slowly; the velocity is smooth at ground-truth
// rates), exact at a stamp.
ImuStateGt state_at(const std::vector<std::vector<double>>& columns, const TimeBracket& at) {
  const ImuStateGt a = state_of(columns[at.index]);
  if (at.s == 0.0) return a;
  const ImuStateGt b = state_of(columns[at.index + 1]);
  const auto mix = [&](const Eigen::Vector3d& x, const Eigen::Vector3d& y) { return ((1.0 - at.s) * x + at.s * y).eval(); };
  return ImuStateGt{mix(a.v_world_mps, b.v_world_mps), mix(a.gyro_bias_radps, b.gyro_bias_radps),
                    mix(a.accel_bias_mps2, b.accel_bias_mps2)};
}

}  // namespace

void attach_groundtruth(RecordedSequence& sequence, const std::filesystem::path& file,
                        const std::optional<Eigen::Isometry3d>& T_body_cam,
                        const std::optional<Eigen::Isometry3d>& rig_T_body_cam0, const DatasetConfig& config,
                        bool given, const Logger& logger) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) {
    throw InputError(file.string(), std::filesystem::is_directory(file, ec) ? "is a folder; give the ground-truth file"
                                                                            : "missing ground-truth file");
  }
  // Real ground-truth files repeat stamps now and then; the TUM tools keep the last pose of a stamp.
  TrajectoryReadOptions options;
  options.duplicate_stamps = DuplicateStamps::kKeepLast;
  options.keep_columns_after_pose = true;
  const TrajectoryFile read = read_trajectory_file(file, options);
  const Trajectory& trajectory = read.trajectory;
  // EuRoC's state ground truth (body poses with velocity and biases on every line) gives the frames the
  // IMU's state as well; camera poses do not (their velocity would be the camera's).
  const bool states = T_body_cam && !read.columns_after_pose.empty() &&
                      std::all_of(read.columns_after_pose.begin(), read.columns_after_pose.end(),
                                  [](const std::vector<double>& c) { return c.size() >= kStateColumns; });
  const TimeNs max_gap_ns = seconds_to_ns(config.max_groundtruth_gap_s);
  std::size_t covered = 0;
  for (FrameEntry& entry : sequence.entries) {
    const std::optional<TimeBracket> at = bracket_at(trajectory, entry.t_ns, max_gap_ns);
    if (!at) continue;
    const Eigen::Isometry3d T_world_body = pose_at(trajectory, *at);
    entry.T_world_cam_gt = T_body_cam ? T_world_body * *T_body_cam : T_world_body;
    if (states) entry.imu_state_gt = state_at(read.columns_after_pose, *at);
    ++covered;
  }
  // The truth at the IMU samples, in the rig's body frame (the IMU): the file's poses moved through cam0
  // to it, T_world_body = T_world_file * T_file_cam0 * T_body_cam0^-1. The file's body need not be the
  // IMU (EuRoC's body frame B, in which imu0/sensor.yaml's T_BS places the IMU); without the rig's body
  // there is no truth at the samples.
  std::optional<Eigen::Isometry3d> T_file_body;  // the rig's body in the frame the file's poses are of
  if (rig_T_body_cam0) {
    T_file_body = (T_body_cam ? *T_body_cam : Eigen::Isometry3d::Identity()) * rig_T_body_cam0->inverse();
  }
  if (T_file_body && !sequence.imu.empty()) {
    sequence.imu_truth.assign(sequence.imu.size(), std::nullopt);
    for (std::size_t k = 0; k < sequence.imu.size(); ++k) {
      const TimeNs t_ns = sequence.imu[k].t_ns;
      const std::optional<TimeBracket> at = bracket_at(trajectory, t_ns, max_gap_ns);
      if (!at) continue;
      ImuTruth truth{t_ns, pose_at(trajectory, *at) * *T_file_body, std::nullopt};
      if (states) truth.state = state_at(read.columns_after_pose, *at);
      sequence.imu_truth[k] = truth;
      ++sequence.info.imu_samples_with_groundtruth;
    }
  }
  if (covered == 0 && !sequence.entries.empty()) {
    const std::string why =
        "gives none of the " + std::to_string(sequence.entries.size()) + " frames a pose: the frames span " +
        format_seconds(sequence.entries.front().t_ns, 3) + " .. " + format_seconds(sequence.entries.back().t_ns, 3) +
        " s, its " + std::to_string(trajectory.size()) + " poses " +
        (trajectory.empty() ? std::string("none")
                            : format_seconds(trajectory.front().t_ns, 3) + " .. " +
                                  format_seconds(trajectory.back().t_ns, 3) + " s") +
        " (another sequence's ground truth, or stamps on another clock?)";
    if (given) throw InputError(file.string(), why);
    logger->warn("{}: {}; the sequence has no ground truth", file.string(), why);
  }
  sequence.info.groundtruth_file = file.string();
  sequence.info.groundtruth_poses = trajectory.size();
}

}  // namespace fleetslam::core::dataset_detail
