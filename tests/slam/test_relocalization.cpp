// Relocalisation after a blackout: the synthetic room sequence with 2 s of black frames (30 Hz) in the
// middle; tracking is lost during them and found again by relocalisation within 1 s of the images
// returning, in the same map component. Deterministic mode repeats bit for bit with place recognition on.

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "fleetslam/core/log.hpp"
#include "fleetslam/slam/agent.hpp"
#include "synthetic_room.hpp"

namespace fleetslam::slam {
namespace {

constexpr int kBefore = 60;    // 2 s tracked
constexpr int kBlackout = 60;  // 2 s black
constexpr int kAfter = 45;     // 1.5 s

const std::vector<core::SensorFrame>& blackout_sequence() {
  static const std::vector<core::SensorFrame> frames = [] {
    const test::SyntheticRoom room = test::default_room();
    const core::SensorRig rig = test::synthetic_rgbd_rig();
    std::vector<core::SensorFrame> out;
    for (int i = 0; i < kBefore + kBlackout + kAfter; ++i) {
      core::SensorFrame f = test::synthetic_frame(room, rig, i);
      if (i >= kBefore && i < kBefore + kBlackout) {
        f.image.setTo(0);
        f.depth_m.setTo(0.0f);
      }
      out.push_back(std::move(f));
    }
    return out;
  }();
  return frames;
}

TEST(Relocalization, RecoversWithinOneSecondAfterATwoSecondBlackout) {
  Agent agent(AgentConfig{}, test::synthetic_rgbd_rig(), core::null_logger());
  const std::vector<core::SensorFrame>& frames = blackout_sequence();
  std::optional<core::TimeNs> recovered_ns;
  bool relocalized = false;
  int component_before = -1;
  int component_after = -1;
  int lost_after_recovery = 0;
  double recovered_error_m = -1.0;
  const Eigen::Isometry3d T_gt_world = *frames.front().T_world_cam_gt;  // the agent's world: the first camera
  for (const core::SensorFrame& f : frames) {
    const AgentUpdate u = agent.process(f);
    if (recovered_ns && !u.has_pose()) ++lost_after_recovery;
    if (f.sequence == kBefore - 1) {
      ASSERT_TRUE(u.has_pose());
      component_before = u.component;
    }
    if (f.sequence >= kBefore && f.sequence < kBefore + kBlackout) {
      EXPECT_FALSE(u.has_pose());
    }
    if (f.sequence >= kBefore + kBlackout && u.has_pose() && !recovered_ns) {
      recovered_ns = f.t_ns;
      relocalized = u.relocalized;
      component_after = u.component;
      recovered_error_m =
          (u.T_world_cam->translation() - (T_gt_world.inverse() * *f.T_world_cam_gt).translation()).norm();
      std::printf("frame %lld: %s\n", static_cast<long long>(f.sequence), u.reason.c_str());
    }
  }
  ASSERT_TRUE(recovered_ns.has_value());
  const double recovery_s = core::ns_to_seconds(*recovered_ns - frames[kBefore + kBlackout].t_ns);
  std::printf("recovered %.3f s after the images returned\n", recovery_s);
  EXPECT_LE(recovery_s, 1.0);
  EXPECT_TRUE(relocalized);
  EXPECT_EQ(component_after, component_before);
  // Relocalised where the camera is, and every frame after the recovery is tracked.
  std::printf("relocalised %.4f m from the truth, %d frames lost after\n", recovered_error_m, lost_after_recovery);
  EXPECT_LT(recovered_error_m, 0.02);
  EXPECT_EQ(lost_after_recovery, 0);
  agent.finish();
  const core::Trajectory trajectory = agent.trajectory();
  EXPECT_GE(static_cast<int>(trajectory.size()), kBefore + kAfter - 30);
}

// The relocalised pose rests on few inliers: no keyframe on it nor on the next frames while the map holds
// more keyframes than the hold (ORB-SLAM3's rule; here a hold of 3 frames, the default being fps).
TEST(Relocalization, NoKeyframeOnTheFirstFramesAfterIt) {
  AgentConfig config;
  config.keyframes.relocalization_hold_frames = 3;
  Agent agent(config, test::synthetic_rgbd_rig(), core::null_logger());
  std::optional<std::int64_t> relocalized_at;
  std::size_t keyframes_before = 0;
  for (const core::SensorFrame& f : blackout_sequence()) {
    const AgentUpdate u = agent.process(f);
    if (f.sequence == kBefore - 1) keyframes_before = agent.map_stats().keyframes;
    if (u.relocalized) relocalized_at = f.sequence;
    if (!relocalized_at || f.sequence >= *relocalized_at + 3) continue;
    EXPECT_TRUE(u.new_keyframes.empty()) << "frame " << f.sequence;
    ASSERT_TRUE(u.keyframe_decision.has_value()) << "frame " << f.sequence;
    EXPECT_FALSE(u.keyframe_decision->insert);
    EXPECT_NE(u.keyframe_decision->reason.find("after a relocalisation"), std::string::npos)
        << u.keyframe_decision->reason;
  }
  ASSERT_TRUE(relocalized_at.has_value());
  EXPECT_GT(keyframes_before, 3u);  // the gate applies to a map larger than the hold
}

// A "kidnap": after 2 s tracked and 0.2 s black, the camera shows the place it started from (0.5 m and
// 25 degrees away). Relocalisation finds it (check off: the pose is right), but with a tight reach
// (0.1 m + 0.5 m/s, 5 deg + 10 deg/s) it is refused as out of reach and the agent stays lost; a camera
// that comes back where it was is accepted with the same bounds.
TEST(Relocalization, APoseOutOfReachIsRefused) {
  const test::SyntheticRoom room = test::default_room();
  const core::SensorRig rig = test::synthetic_rgbd_rig();
  const auto run = [&](bool check_jump, bool kidnapped) {
    AgentConfig config;
    config.tracking.relocalization.check_jump = check_jump;
    config.tracking.relocalization.max_jump_floor_m = 0.1;
    config.tracking.relocalization.max_jump_m_per_s = 0.5;
    config.tracking.relocalization.max_jump_floor_deg = 5.0;
    config.tracking.relocalization.max_jump_deg_per_s = 10.0;
    Agent agent(config, rig, core::null_logger());
    const std::vector<core::SensorFrame>& frames = blackout_sequence();
    for (int i = 0; i < kBefore; ++i) agent.process(frames[static_cast<std::size_t>(i)]);
    for (int i = kBefore; i < kBefore + 6; ++i) EXPECT_FALSE(agent.process(frames[static_cast<std::size_t>(i)]).has_pose());
    std::optional<AgentUpdate> found;
    std::string last_reason;
    for (int k = 0; k < 10 && !found; ++k) {
      const int seen = kidnapped ? k : kBefore + 6 + k;  // the view: the start, or where it went on
      core::SensorFrame f = test::synthetic_frame(room, rig, seen);
      const core::SensorFrame& slot = test::synthetic_frame(room, rig, kBefore + 6 + k);
      f.t_ns = slot.t_ns;
      f.sequence = slot.sequence;
      const AgentUpdate u = agent.process(f);
      last_reason = u.reason;
      if (u.has_pose()) {
        found = u;
        // The agent's world is the first camera's, which is the synthetic world's (frame 0 at the origin).
        EXPECT_LT((u.T_world_cam->translation() - f.T_world_cam_gt->translation()).norm(), 0.05) << "found at the right pose";
      }
    }
    return std::make_pair(found, last_reason);
  };
  const auto free_run = run(false, true);
  ASSERT_TRUE(free_run.first.has_value()) << "relocalisation must find the start: " << free_run.second;
  EXPECT_TRUE(free_run.first->relocalized);
  const auto refused = run(true, true);
  EXPECT_FALSE(refused.first.has_value());
  EXPECT_NE(refused.second.find("out of reach"), std::string::npos) << refused.second;
  const auto back = run(true, false);
  ASSERT_TRUE(back.first.has_value()) << back.second;
}

// The same kidnap with a gyroscope that keeps measuring the camera's true rotation, and bounds too loose
// to refuse it otherwise (1 m, 90 degrees): the start's pose is turned 25 degrees from what the gyro
// says and is refused; without the gyro it is taken; a camera that comes back where it was is found.
TEST(Relocalization, WithAGyroAPoseTurnedAwayFromItsRotationIsRefused) {
  const test::SyntheticRoom room = test::default_room();
  const std::vector<core::SensorFrame> frames = test::with_gyro(blackout_sequence());
  const auto run = [&](bool gyro, bool kidnapped) {
    AgentConfig config;
    RelocalizationConfig& reloc = config.tracking.relocalization;
    reloc.max_jump_floor_m = 1.0;
    reloc.max_jump_floor_deg = 90.0;
    const core::SensorRig rig = gyro ? test::synthetic_gyro_rig() : test::synthetic_rgbd_rig();
    Agent agent(config, rig, core::null_logger());
    const auto fed = [&](core::SensorFrame f) {
      if (!gyro) f.imu.clear();
      return agent.process(f);
    };
    for (int i = 0; i < kBefore; ++i) fed(frames[static_cast<std::size_t>(i)]);
    for (int i = kBefore; i < kBefore + 6; ++i) EXPECT_FALSE(fed(frames[static_cast<std::size_t>(i)]).has_pose());
    std::optional<AgentUpdate> found;
    std::string reasons;
    for (int k = 0; k < 10 && !found; ++k) {
      const core::SensorFrame& slot = frames[static_cast<std::size_t>(kBefore + 6 + k)];
      core::SensorFrame f = test::synthetic_frame(room, rig, kidnapped ? k : kBefore + 6 + k);
      f.t_ns = slot.t_ns;
      f.sequence = slot.sequence;
      f.imu = slot.imu;  // what the gyro measured: the camera went on turning as before
      const AgentUpdate u = fed(f);
      reasons += u.reason + "\n";
      if (u.has_pose()) found = u;
    }
    return std::make_pair(found, reasons);
  };
  const auto without_gyro = run(false, true);
  ASSERT_TRUE(without_gyro.first.has_value()) << without_gyro.second;
  EXPECT_TRUE(without_gyro.first->relocalized);
  const auto refused = run(true, true);
  EXPECT_FALSE(refused.first.has_value()) << refused.second;
  EXPECT_NE(refused.second.find("from the gyro's rotation"), std::string::npos) << refused.second;
  const auto back = run(true, false);
  ASSERT_TRUE(back.first.has_value()) << back.second;
  EXPECT_LT((back.first->T_world_cam->translation() - frames[static_cast<std::size_t>(back.first->sequence)].T_world_cam_gt->translation()).norm(), 0.05);
}

TEST(Relocalization, DeterministicModeRepeatsBitForBit) {
  const auto run = [] {
    Agent agent(AgentConfig{}, test::synthetic_rgbd_rig(), core::null_logger());
    for (const core::SensorFrame& f : blackout_sequence()) agent.process(f);
    return agent.trajectory();
  };
  const core::Trajectory a = run();
  const core::Trajectory b = run();
  ASSERT_GE(static_cast<int>(a.size()), kBefore + kAfter - 30) << "the runs must track to compare anything";
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].t_ns, b[i].t_ns);
    EXPECT_TRUE(a[i].T_world_body.matrix() == b[i].T_world_body.matrix()) << "pose " << i << " differs";
  }
}

}  // namespace
}  // namespace fleetslam::slam
