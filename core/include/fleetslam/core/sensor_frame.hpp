#pragma once
// The message every sensor source produces: the simulator, dataset readers, and later real robots.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>

#include "fleetslam/core/time.hpp"

namespace fleetslam::core {

struct ImuSample {
  TimeNs t_ns = 0;
  Eigen::Vector3d gyro_radps = Eigen::Vector3d::Zero();  // angular velocity in the IMU frame
  Eigen::Vector3d accel_mps2 = Eigen::Vector3d::Zero();  // specific force in the IMU frame
};

// What the simulator knows of an IMU's state at a frame's t_ns besides the pose (EuRoC's
// state_groundtruth_estimate0 columns after the pose): the velocity of the body (IMU) frame's origin in
// the world, and the IMU's biases in its own frame (measurement = truth + bias + noise).
struct ImuStateGt {
  Eigen::Vector3d v_world_mps = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_bias_radps = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias_mps2 = Eigen::Vector3d::Zero();
};

// The truth at one IMU sample, from a source that knows it (the simulator, or a recorded sequence's
// ground truth in the body frame): the pose of the body (IMU) frame in the world and, where known, the
// IMU's state, at the sample's t_ns. EuRoC's ground truth runs at the IMU's rate; these let a writer do
// the same.
struct ImuTruth {
  TimeNs t_ns = 0;
  Eigen::Isometry3d T_world_body = Eigen::Isometry3d::Identity();
  std::optional<ImuStateGt> state;  // nullopt where the source knows only poses (TUM-VI's motion capture)
};

// One camera tick of one robot. Images are owned by the frame (cv::Mat is reference-counted; sources
// hand out freshly decoded or rendered buffers and never write them afterwards).
struct SensorFrame {
  int robot_id = 0;
  std::int64_t sequence = 0;  // index of this frame in its stream, from 0
  TimeNs t_ns = 0;

  cv::Mat image;    // colour (CV_8UC3, BGR) or gray (CV_8UC1); the left image of a stereo pair
  cv::Mat right;    // right image of a stereo pair (same type as image), empty otherwise
  cv::Mat depth_m;  // metric depth (CV_32FC1, metres, 0 = no measurement) registered to image, or empty

  std::vector<ImuSample> imu;  // IMU samples with t in (previous frame t_ns, t_ns], oldest first

  std::optional<Eigen::Isometry3d> T_world_cam_gt;  // ground-truth pose of the (left) camera
  std::optional<ImuStateGt> imu_state_gt;           // with T_world_cam_gt, from a source that knows it
  // The truth at those samples of `imu` where the source knows it, oldest first, each at its sample's
  // t_ns: every sample for the simulator, those within the ground truth for a recorded sequence (a
  // motion-capture drop-out leaves out the samples in it, not the frame's others); empty where none.
  std::vector<ImuTruth> imu_truth;

  std::string image_path;  // where the image came from, for messages (empty for rendered frames)

  bool has_depth() const { return !depth_m.empty(); }
  bool is_stereo() const { return !right.empty(); }
};

}  // namespace fleetslam::core
