// No false loop closures on a sequence without revisits: a corridor of identical 3 m bays (every surface's
// texture repeats along the corridor), walked once with the camera turned towards one wall. Each bay
// looks exactly like the one before it, to BoW and to a 3D-3D RANSAC alike, so loop detection proposes
// and verifies loops that would shift the map by whole bays. The drift bound refuses them: a 3 m
// correction after 3 m travelled is no drift an RGB-D agent accumulates. The oracle that the scene does
// deceive: with the guards off the same run closes a loop and its ATE grows by metres.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "fleetslam/core/log.hpp"
#include "fleetslam/core/trajectory_metrics.hpp"
#include "fleetslam/slam/agent.hpp"
#include "synthetic_room.hpp"

namespace fleetslam::slam {
namespace {

constexpr double kBayM = 3.0;
constexpr double kSpeedMps = 0.6;
constexpr int kFrames = 330;  // 11 s at 30 Hz: 6.6 m, two bays and more

core::SensorRig corridor_rig() {
  core::SensorRig rig;
  rig.mode = core::SensorMode::kRgbd;
  rig.cam0 = core::PinholeCamera(320, 240, 250.0, 250.0, 159.5, 119.5);
  rig.bf = 20.0;
  rig.fps = 30.0;
  rig.depth_scale = 5000.0;
  return rig;
}

// Along +z at x = -0.2, looking 75 degrees to the side (towards the +x wall 1.2 m away), swaying gently.
Eigen::Isometry3d corridor_pose(double t_s) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const double yaw = (75.0 + 5.0 * std::sin(0.7 * t_s)) * M_PI / 180.0;
  T.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(0.05 * std::sin(0.9 * t_s), Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(-0.2 + 0.05 * std::sin(0.5 * t_s), 0.05 * std::sin(1.1 * t_s), kSpeedMps * t_s);
  return T;
}

const std::vector<core::SensorFrame>& corridor_sequence() {
  static const std::vector<core::SensorFrame> frames = [] {
    const test::SyntheticRoom corridor(Eigen::Vector3d(-1.0, -1.2, -2.0), Eigen::Vector3d(1.0, 1.2, 13.0), 11, 0.004, kBayM);
    const core::SensorRig rig = corridor_rig();
    std::vector<core::SensorFrame> out;
    for (int i = 0; i < kFrames; ++i) {
      core::SensorFrame f;
      f.sequence = i;
      f.t_ns = core::kNsPerSecond + static_cast<core::TimeNs>(i) * core::kNsPerSecond / 30;
      f.T_world_cam_gt = corridor_pose(i / 30.0);
      corridor.render(rig.cam0, *f.T_world_cam_gt, f.image, f.depth_m);
      out.push_back(std::move(f));
    }
    return out;
  }();
  return frames;
}

struct CorridorRun {
  std::vector<LoopEvent> loops;
  LoopRejections refused;
  double ate_m = 0.0;
  int tracked = 0;
};

// Without the guards the run stops at its first loop (that is all the oracle needs).
CorridorRun run(bool guards) {
  AgentConfig config;
  if (!guards) {
    config.loop_closing.max_correction_floor_m = -1.0;
    config.loop_closing.max_correction_floor_deg = -1.0;
    config.loop_closing.confirmations = 0;
  }
  Agent agent(config, corridor_rig(), core::null_logger());
  CorridorRun r;
  core::Trajectory gt;
  for (const core::SensorFrame& f : corridor_sequence()) {
    const AgentUpdate u = agent.process(f);
    r.tracked += u.has_pose() ? 1 : 0;
    gt.push_back(core::StampedPose{f.t_ns, *f.T_world_cam_gt});
    for (const LoopEvent& e : u.loops) {
      std::printf("%s: loop at frame %lld, keyframe %lld with %lld, %d inliers, camera moved %.3f m after %.2f m\n",
                  guards ? "guarded" : "unguarded", static_cast<long long>(f.sequence), static_cast<long long>(e.current),
                  static_cast<long long>(e.loop), e.inliers, e.camera_shift_m, e.path_m);
      r.loops.push_back(e);
    }
    if (!guards && !r.loops.empty()) break;
  }
  agent.finish();
  r.refused = agent.map_stats().loop_rejections;
  const core::Trajectory estimate = agent.trajectory();
  r.ate_m = core::compute_ate(gt, estimate, core::associate_by_time(gt, estimate), core::AlignmentMode::kSe3).stats.rmse;
  std::printf("%s: %zu loop(s), %d refused as implausible, %d unconfirmed, ATE %.4f m, %d/%zu tracked\n",
              guards ? "guarded" : "unguarded", r.loops.size(), r.refused.implausible_correction, r.refused.unconfirmed,
              r.ate_m, r.tracked, gt.size());
  return r;
}

TEST(FalseLoops, CorridorOfIdenticalBaysClosesNoLoop) {
  const CorridorRun guarded = run(true);
  EXPECT_TRUE(guarded.loops.empty());
  EXPECT_GT(guarded.refused.implausible_correction + guarded.refused.unconfirmed, 0);  // the guards did the work
  EXPECT_EQ(guarded.tracked, kFrames);
  EXPECT_LT(guarded.ate_m, 0.02);

  // The scene deceives loop detection: without the guards a loop is closed across bays, and the
  // trajectory is wrecked by it.
  const CorridorRun unguarded = run(false);
  ASSERT_FALSE(unguarded.loops.empty());
  EXPECT_GT(unguarded.loops.front().camera_shift_m, 0.5 * kBayM);
  // Measured: 29 mm against 4.2 mm (weak loop links out of the essential graph; 10 times before).
  EXPECT_GT(unguarded.ate_m, 5.0 * guarded.ate_m);
}

}  // namespace
}  // namespace fleetslam::slam
