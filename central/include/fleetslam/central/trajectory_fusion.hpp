#pragma once
// Trajectory fusion (PAPER.md §4): one robot's trajectory, estimated in its own frame (the agent's
// world: its first camera pose), brought into the shared world frame.
//   - Without an inter-robot constraint the initial-pose prior T_world_robot places it rigidly.
//   - With one (map registration found where the robot's keyframes `anchors` overlap another robot's map,
//     and says they belong at T_world_robot_refined * T_robot_kf), the correction is either rigid (every
//     pose moved by the refined transform: the paper's choice) or, with `pose_graph`, spread over the
//     trajectory by a small pose graph (Ceres): keyframe poses as nodes, the agent's relative poses
//     between consecutive keyframes as odometry edges, the prior on the first keyframe and the refined
//     transform on the anchors, each weighted by its standard deviations. A robot whose start is far
//     from the overlap then keeps its start near the prior and bends toward the overlap, instead of
//     swinging rigidly about it.
// Frame poses follow the keyframe they are nearest to in time before them (their reference), so a
// correction of the keyframes moves the frames with them.

#include <cstddef>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/trajectory.hpp"

namespace fleetslam::central {

struct TrajectoryFusionConfig {
  bool pose_graph = true;
  double prior_translation_sigma_m = 0.10;     // how far the initial-pose prior may be off
  double prior_rotation_sigma_rad = 0.09;
  double odometry_translation_sigma_m = 0.01;  // per keyframe-to-keyframe edge
  double odometry_rotation_sigma_rad = 0.005;
  double anchor_translation_sigma_m = 0.005;   // the registration's placement of the overlap keyframes
  double anchor_rotation_sigma_rad = 0.003;
  int max_iterations = 50;

  template <class V>
  void visit(V& v) {
    v("pose_graph", pose_graph);
    v("prior_translation_sigma_m", prior_translation_sigma_m, core::Limits<double>{1e-6, 1e6});
    v("prior_rotation_sigma_rad", prior_rotation_sigma_rad, core::Limits<double>{1e-6, 10.0});
    v("odometry_translation_sigma_m", odometry_translation_sigma_m, core::Limits<double>{1e-6, 1e6});
    v("odometry_rotation_sigma_rad", odometry_rotation_sigma_rad, core::Limits<double>{1e-6, 10.0});
    v("anchor_translation_sigma_m", anchor_translation_sigma_m, core::Limits<double>{1e-6, 1e6});
    v("anchor_rotation_sigma_rad", anchor_rotation_sigma_rad, core::Limits<double>{1e-6, 10.0});
    v("max_iterations", max_iterations, core::Limits<int>{1, 10000});
  }
};

struct InterRobotConstraint {
  Eigen::Isometry3d T_world_robot_refined = Eigen::Isometry3d::Identity();
  std::vector<std::size_t> anchors;  // indices into the keyframe trajectory of the keyframes in the overlap
};

struct FusedTrajectory {
  core::Trajectory keyframes_world;
  core::Trajectory frames_world;
  bool pose_graph_solved = false;
  int iterations = 0;
  double initial_cost = 0.0;
  double final_cost = 0.0;
};

class TrajectoryFusion {
 public:
  explicit TrajectoryFusion(const TrajectoryFusionConfig& config);

  // keyframes_robot and frames_robot in the robot's frame, time-ordered. Anchors out of range are an
  // InputError. Empty keyframes: frames are placed rigidly by the prior (or the refined transform).
  FusedTrajectory fuse(const core::Trajectory& keyframes_robot, const core::Trajectory& frames_robot,
                       const Eigen::Isometry3d& T_world_robot_prior,
                       const std::optional<InterRobotConstraint>& constraint) const;

  const TrajectoryFusionConfig& config() const { return config_; }

 private:
  TrajectoryFusionConfig config_;
};

// Frames re-expressed against corrected keyframes: each frame keeps its pose relative to the last
// keyframe at or before it (the first keyframe for earlier frames). Same keyframe times in both inputs.
core::Trajectory follow_keyframes(const core::Trajectory& frames_robot, const core::Trajectory& keyframes_robot,
                                  const core::Trajectory& keyframes_world);

}  // namespace fleetslam::central
