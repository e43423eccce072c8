#pragma once
// Internal: the wrapper MJCF that <include>s a scene and inserts the scenario's robots.
// Names of everything inserted start with "fs_<robot>" so they cannot clash with the scene's.

#include <string>

#include <Eigen/Geometry>

#include "fleetslam/sim/scenario.hpp"

namespace fleetslam::sim::detail {

// R = Rz(yaw) Ry(pitch) Rx(roll), translation (x, y, z).
Eigen::Isometry3d pose_from_config(const PoseConfig& pose);

// Pose of the camera's optical frame (OpenCV: x right, y down, z forward) in the robot body frame
// (x forward, y left, z up): the mount pose followed by the fixed body->optical axis change.
Eigen::Isometry3d T_body_optical(const CameraConfig& camera);
// The right camera of a stereo pair: baseline_m along the left optical frame's x.
Eigen::Isometry3d T_body_optical_right(const CameraConfig& camera, double baseline_m);

// Pinhole intrinsics of a camera config (fx = fy from fovy, principal point at the image centre).
double focal_length_px(const CameraConfig& camera);

std::string robot_prefix(const RobotConfig& robot);

// The wrapper model's XML. `scene_file_name` is included relative to the wrapper's own (virtual) folder,
// which the World places in the scene's folder. The offscreen buffer fits the largest camera.
std::string build_scenario_mjcf(const ScenarioConfig& scenario, const std::string& scene_file_name);

}  // namespace fleetslam::sim::detail
