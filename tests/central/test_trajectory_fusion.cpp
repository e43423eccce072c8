// Trajectory fusion against known truth: rigid placement by the prior, rigid correction by a refined
// transform, and the pose graph keeping the start near the prior while the overlap follows the anchors.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "fleetslam/central/trajectory_fusion.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/se3.hpp"

namespace fleetslam::central {
namespace {

// A robot driving a 4 m arc: keyframes every 0.4 s, frames at 10 Hz, in the robot's own frame.
core::Trajectory arc(double period_s) {
  core::Trajectory out;
  for (double t = 0.0; t <= 8.0 + 1e-9; t += period_s) {
    const double a = 0.2 * t;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()).toRotationMatrix();
    T.translation() = Eigen::Vector3d(2.5 * std::sin(a), 0.05 * std::sin(t), 2.5 * (1.0 - std::cos(a)));
    out.push_back(core::StampedPose{static_cast<core::TimeNs>(std::llround(t * 1e9)), T});
  }
  return out;
}

Eigen::Isometry3d pose(double x, double y, double z, double yaw_rad) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

double translation_error(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm();
}

// Translation (m) and rotation (rad) apart, the larger: RPE's rotation needs the fused orientations too.
double pose_error(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return std::max(translation_error(a, b), Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle());
}

TEST(TrajectoryFusion, WithoutConstraintThePriorPlacesTheTrajectoryRigidly) {
  const core::Trajectory keyframes = arc(0.4), frames = arc(0.1);
  const Eigen::Isometry3d prior = pose(1.0, 0.0, -2.0, 0.7);
  const FusedTrajectory fused = TrajectoryFusion(TrajectoryFusionConfig{}).fuse(keyframes, frames, prior, std::nullopt);
  ASSERT_EQ(fused.frames_world.size(), frames.size());
  ASSERT_EQ(fused.keyframes_world.size(), keyframes.size());
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(fused.frames_world[i].t_ns, frames[i].t_ns);
    EXPECT_LT(pose_error(fused.frames_world[i].T_world_body, prior * frames[i].T_world_body), 1e-12);
  }
  EXPECT_FALSE(fused.pose_graph_solved);
}

TEST(TrajectoryFusion, RigidCorrectionMovesEveryPoseByTheRefinedTransform) {
  const core::Trajectory keyframes = arc(0.4), frames = arc(0.1);
  TrajectoryFusionConfig config;
  config.pose_graph = false;
  const Eigen::Isometry3d prior = pose(0.1, 0.0, 0.0, 0.087);
  InterRobotConstraint constraint;
  constraint.T_world_robot_refined = Eigen::Isometry3d::Identity();
  constraint.anchors = {15, 16, 17};
  const FusedTrajectory fused = TrajectoryFusion(config).fuse(keyframes, frames, prior, constraint);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_LT(pose_error(fused.frames_world[i].T_world_body, frames[i].T_world_body), 1e-12);
  }
}

TEST(TrajectoryFusion, PoseGraphAgreesWithAConsistentPriorAndAnchors) {
  // Prior and refined transform agree: the graph has nothing to trade and returns the rigid solution.
  const core::Trajectory keyframes = arc(0.4), frames = arc(0.1);
  const Eigen::Isometry3d T_world_robot = pose(0.3, 0.1, -0.2, 0.2);
  InterRobotConstraint constraint;
  constraint.T_world_robot_refined = T_world_robot;
  constraint.anchors = {18, 19, 20};
  const FusedTrajectory fused = TrajectoryFusion(TrajectoryFusionConfig{}).fuse(keyframes, frames, T_world_robot, constraint);
  ASSERT_TRUE(fused.pose_graph_solved);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_LT(pose_error(fused.frames_world[i].T_world_body, T_world_robot * frames[i].T_world_body), 1e-6);
  }
}

TEST(TrajectoryFusion, PoseGraphSpreadsTheCorrectionBetweenPriorAndOverlap) {
  // The agent's trajectory drifted: its end is 12 cm off. The prior (exact at the start) and the
  // registration (exact at the end, where the robot met another robot's map) together pull it back.
  const core::Trajectory truth = arc(0.4);
  core::Trajectory drifted = truth;
  for (std::size_t i = 0; i < drifted.size(); ++i) {
    const double s = static_cast<double>(i) / static_cast<double>(drifted.size() - 1);
    drifted[i].T_world_body.translation() += Eigen::Vector3d(0.12 * s, 0.0, -0.05 * s);
  }
  const std::size_t last = drifted.size() - 1;
  // The registration aligned the end of the drifted map to the truth.
  InterRobotConstraint constraint;
  constraint.T_world_robot_refined = truth[last].T_world_body * drifted[last].T_world_body.inverse();
  constraint.anchors = {last - 1, last};
  TrajectoryFusionConfig config;
  config.prior_translation_sigma_m = 0.005;  // the start is known well here
  config.odometry_translation_sigma_m = 0.02;
  const FusedTrajectory fused = TrajectoryFusion(config).fuse(drifted, drifted, Eigen::Isometry3d::Identity(), constraint);
  ASSERT_TRUE(fused.pose_graph_solved);
  EXPECT_LT(fused.final_cost, fused.initial_cost);
  const double start_error = translation_error(fused.keyframes_world.front().T_world_body, truth.front().T_world_body);
  const double end_error = translation_error(fused.keyframes_world.back().T_world_body, truth.back().T_world_body);
  const double rigid_start_error =
      translation_error(constraint.T_world_robot_refined * drifted.front().T_world_body, truth.front().T_world_body);
  std::printf("start %.4f m (rigid %.4f m), end %.4f m\n", start_error, rigid_start_error, end_error);
  EXPECT_LT(end_error, 0.02);
  EXPECT_LT(start_error, 0.02);
  EXPECT_LT(start_error, 0.5 * rigid_start_error) << "a rigid correction would move the start away";
}

TEST(TrajectoryFusion, FramesFollowTheirKeyframe) {
  core::Trajectory keyframes_robot = {{0, pose(0, 0, 0, 0)}, {10, pose(1, 0, 0, 0)}};
  core::Trajectory keyframes_world = {{0, pose(0, 0, 0, 0)}, {10, pose(1, 0, 0.5, 0.3)}};
  core::Trajectory frames = {{5, pose(0.5, 0, 0, 0)}, {12, pose(1.2, 0, 0, 0)}};
  const core::Trajectory out = follow_keyframes(frames, keyframes_robot, keyframes_world);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_LT(pose_error(out[0].T_world_body, pose(0.5, 0, 0, 0)), 1e-12);
  EXPECT_LT(pose_error(out[1].T_world_body, pose(1, 0, 0.5, 0.3) * pose(0.2, 0, 0, 0)), 1e-12);
}

TEST(TrajectoryFusion, AnchorOutOfRangeIsAnInputError) {
  InterRobotConstraint constraint;
  constraint.anchors = {99};
  EXPECT_THROW(TrajectoryFusion(TrajectoryFusionConfig{}).fuse(arc(0.4), arc(0.1), Eigen::Isometry3d::Identity(), constraint),
               InputError);
}

}  // namespace
}  // namespace fleetslam::central
