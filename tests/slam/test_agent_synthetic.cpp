// The agent on a synthetic textured box room with exact depth (RGB-D) or an exact rectified pair
// (stereo): it tracks every frame to well under a centimetre, repeats bit for bit in deterministic
// mode, tracks in threaded mode too, and reports bad input instead of failing on it.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <vector>

#include "fleetslam/core/log.hpp"
#include "fleetslam/core/se3.hpp"
#include "fleetslam/core/trajectory_metrics.hpp"
#include "fleetslam/slam/agent.hpp"
#include "synthetic_room.hpp"

namespace fleetslam::slam {
namespace {

constexpr int kFrames = 60;

// Rendering dominates the test time: each sequence is rendered once.
const std::vector<core::SensorFrame>& sequence(core::SensorMode mode) {
  static const test::SyntheticRoom room = test::default_room();
  const auto render = [](const core::SensorRig& rig) {
    std::vector<core::SensorFrame> frames;
    for (int i = 0; i < kFrames; ++i) frames.push_back(test::synthetic_frame(room, rig, i));
    return frames;
  };
  if (mode == core::SensorMode::kStereo) {
    static const std::vector<core::SensorFrame> stereo = render(test::synthetic_stereo_rig());
    return stereo;
  }
  static const std::vector<core::SensorFrame> rgbd = render(test::synthetic_rgbd_rig());
  return rgbd;
}

struct AgentRun {
  std::vector<AgentUpdate> updates;
  core::Trajectory trajectory;
  core::Trajectory keyframes;
  MapStats stats;
};

AgentRun run_agent(const AgentConfig& config, const core::SensorRig& rig, const std::vector<core::SensorFrame>& frames) {
  Agent agent(config, rig, core::null_logger());
  AgentRun run;
  for (const core::SensorFrame& frame : frames) run.updates.push_back(agent.process(frame));
  agent.finish();
  run.trajectory = agent.trajectory();
  run.keyframes = agent.keyframe_trajectory();
  run.stats = agent.map_stats();
  return run;
}

core::Trajectory ground_truth(const std::vector<core::SensorFrame>& frames) {
  core::Trajectory gt;
  for (const core::SensorFrame& f : frames) gt.push_back(core::StampedPose{f.t_ns, *f.T_world_cam_gt});
  return gt;
}

core::AteResult ate(const std::vector<core::SensorFrame>& frames, const core::Trajectory& estimate) {
  const core::Trajectory gt = ground_truth(frames);
  core::AteResult result =
      core::compute_ate(gt, estimate, core::associate_by_time(gt, estimate), core::AlignmentMode::kSe3);
  std::printf("ATE RMSE %.6f m over %zu poses\n", result.stats.rmse, result.pairs.size());
  return result;
}

int tracked(const AgentRun& run) {
  int n = 0;
  for (const AgentUpdate& u : run.updates) {
    n += (u.status == FrameStatus::kTracked || u.status == FrameStatus::kInitialized) ? 1 : 0;
  }
  return n;
}

TEST(AgentSynthetic, RgbdTracksEveryFrameWellUnderOneCentimetre) {
  const auto& frames = sequence(core::SensorMode::kRgbd);
  const AgentRun run = run_agent(AgentConfig{}, test::synthetic_rgbd_rig(), frames);
  EXPECT_EQ(tracked(run), kFrames);
  ASSERT_EQ(run.trajectory.size(), static_cast<std::size_t>(kFrames));
  const core::AteResult result = ate(frames, run.trajectory);
  ASSERT_TRUE(result.ok());
  EXPECT_LT(result.stats.rmse, 0.005) << "ATE RMSE " << result.stats.rmse << " m";
  EXPECT_GE(run.stats.keyframes, 2u);
  EXPECT_EQ(run.stats.components, 1);
  // The first update starts the map with a keyframe and its points.
  EXPECT_EQ(run.updates.front().status, FrameStatus::kInitialized);
  ASSERT_EQ(run.updates.front().new_keyframes.size(), 1u);
  EXPECT_GT(run.updates.front().new_keyframes.front().points_world.size(), 300u);
  // Tracked frames carry their keyframe decision and timings.
  const AgentUpdate& later = run.updates[10];
  EXPECT_TRUE(later.keyframe_decision.has_value());
  EXPECT_GT(later.inliers, 100);
  EXPECT_GT(later.timings.extract_ms, 0.0);
  EXPECT_GE(later.timings.total_ms, later.timings.tracking_ms);
}

TEST(AgentSynthetic, StereoTracksEveryFrameWellUnderOneCentimetre) {
  const auto& frames = sequence(core::SensorMode::kStereo);
  const AgentRun run = run_agent(AgentConfig{}, test::synthetic_stereo_rig(), frames);
  EXPECT_EQ(tracked(run), kFrames);
  const core::AteResult result = ate(frames, run.trajectory);
  ASSERT_TRUE(result.ok());
  EXPECT_LT(result.stats.rmse, 0.005) << "ATE RMSE " << result.stats.rmse << " m";
}

TEST(AgentSynthetic, DeterministicModeRepeatsBitForBit) {
  const auto& all = sequence(core::SensorMode::kRgbd);
  const std::vector<core::SensorFrame> frames(all.begin(), all.begin() + 30);
  const AgentRun a = run_agent(AgentConfig{}, test::synthetic_rgbd_rig(), frames);
  const AgentRun b = run_agent(AgentConfig{}, test::synthetic_rgbd_rig(), frames);
  ASSERT_EQ(a.trajectory.size(), b.trajectory.size());
  for (std::size_t i = 0; i < a.trajectory.size(); ++i) {
    EXPECT_EQ(a.trajectory[i].t_ns, b.trajectory[i].t_ns);
    EXPECT_TRUE(a.trajectory[i].T_world_body.matrix() == b.trajectory[i].T_world_body.matrix()) << "frame " << i;
  }
  ASSERT_EQ(a.keyframes.size(), b.keyframes.size());
  for (std::size_t i = 0; i < a.keyframes.size(); ++i) {
    EXPECT_TRUE(a.keyframes[i].T_world_body.matrix() == b.keyframes[i].T_world_body.matrix()) << "keyframe " << i;
  }
  EXPECT_EQ(a.stats.points, b.stats.points);
}

TEST(AgentSynthetic, TwoAgentsInOneProcessShareNothing) {
  const auto& all = sequence(core::SensorMode::kRgbd);
  const std::vector<core::SensorFrame> frames(all.begin(), all.begin() + 30);
  const AgentRun alone = run_agent(AgentConfig{}, test::synthetic_rgbd_rig(), frames);
  // Interleaved with a second agent (another camera: the stereo rig) frame by frame.
  Agent a(AgentConfig{}, test::synthetic_rgbd_rig(), core::null_logger());
  Agent b(AgentConfig{}, test::synthetic_stereo_rig(), core::null_logger());
  const auto& stereo = sequence(core::SensorMode::kStereo);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    a.process(frames[i]);
    b.process(stereo[i]);
  }
  const core::Trajectory together = a.trajectory();
  ASSERT_EQ(together.size(), alone.trajectory.size());
  for (std::size_t i = 0; i < together.size(); ++i) {
    EXPECT_TRUE(together[i].T_world_body.matrix() == alone.trajectory[i].T_world_body.matrix()) << i;
  }
  EXPECT_EQ(b.trajectory().size(), frames.size());
}

TEST(AgentSynthetic, ThreadedModeTracks) {
  const auto& frames = sequence(core::SensorMode::kRgbd);
  AgentConfig config;
  config.threaded = true;
  const AgentRun run = run_agent(config, test::synthetic_rgbd_rig(), frames);
  EXPECT_EQ(tracked(run), kFrames);
  const core::AteResult result = ate(frames, run.trajectory);
  ASSERT_TRUE(result.ok());
  EXPECT_LT(result.stats.rmse, 0.01) << "ATE RMSE " << result.stats.rmse << " m";
  EXPECT_GE(run.stats.keyframes, 2u);
}

// Keyframes counted from the logged decisions are the keyframes the stream carries: a keyframe the policy
// wanted but the busy worker refused is logged as not inserted.
std::size_t decided_keyframes(const AgentRun& run) {
  std::size_t n = 0;
  for (const AgentUpdate& u : run.updates) n += u.keyframe_decision && u.keyframe_decision->insert ? 1 : 0;
  return n;
}
std::size_t streamed_keyframes(const AgentRun& run) {
  std::size_t n = 0;
  for (const AgentUpdate& u : run.updates) n += u.status == FrameStatus::kInitialized ? 0 : u.new_keyframes.size();
  return n;
}

TEST(AgentSynthetic, LoggedDecisionsAreTheKeyframesInserted) {
  const auto& frames = sequence(core::SensorMode::kRgbd);
  AgentConfig config;
  config.threaded = true;
  config.max_mapping_queue = 1;
  config.keyframes.policy = KeyframePolicyKind::kFixedInterval;  // a keyframe wanted every few frames
  config.keyframes.interval_frames = 1;
  const AgentRun busy = run_agent(config, test::synthetic_rgbd_rig(), frames);
  EXPECT_EQ(decided_keyframes(busy), streamed_keyframes(busy));
  config.threaded = false;
  const AgentRun inline_run = run_agent(config, test::synthetic_rgbd_rig(), frames);
  EXPECT_EQ(decided_keyframes(inline_run), streamed_keyframes(inline_run));
  EXPECT_GT(decided_keyframes(inline_run), 10u);
}

// What the tracker feeds the policies about the reference keyframe, on the frame after a map starts:
// each point of the first keyframe is seen by that keyframe alone, with depth. ORB-SLAM3's weighted count
// (an observation with depth counts 2, at least 2 needed in a map of 1 or 2 keyframes) takes every one
// of them; exponential's R_A counts keyframes, none, so R_A is 1.
TEST(AgentSynthetic, TheReferenceCountsThePoliciesUseRightAfterAMapStarts) {
  const std::vector<core::SensorFrame> frames(sequence(core::SensorMode::kRgbd).begin(),
                                              sequence(core::SensorMode::kRgbd).begin() + 2);
  AgentConfig config;
  config.keyframes.policy = KeyframePolicyKind::kOrbslam3;
  const AgentRun orbslam3 = run_agent(config, test::synthetic_rgbd_rig(), frames);
  ASSERT_EQ(orbslam3.updates[0].new_keyframes.size(), 1u);
  const std::size_t initial_points = orbslam3.updates[0].new_keyframes[0].point_ids.size();
  ASSERT_GT(initial_points, 100u);
  ASSERT_TRUE(orbslam3.updates[1].keyframe_decision.has_value());
  const auto factor = [](const KeyframeDecision& d, const std::string& name) {
    for (const auto& [n, v] : d.factors) {
      if (n == name) return v;
    }
    ADD_FAILURE() << "no factor " << name;
    return -1.0;
  };
  EXPECT_EQ(factor(*orbslam3.updates[1].keyframe_decision, "reference"), static_cast<double>(initial_points));
  config.keyframes.policy = KeyframePolicyKind::kExponential;
  const AgentRun exponential = run_agent(config, test::synthetic_rgbd_rig(), frames);
  ASSERT_TRUE(exponential.updates[1].keyframe_decision.has_value());
  EXPECT_EQ(factor(*exponential.updates[1].keyframe_decision, "R_A"), 1.0);
}

// A keyframe's own frame is the keyframe: the trajectory at a keyframe's time is the keyframe's pose,
// moved by the local BA and loop corrections inline mapping applied right after it was inserted.
TEST(AgentSynthetic, AKeyframesFrameFollowsItsKeyframe) {
  const auto& frames = sequence(core::SensorMode::kRgbd);
  const AgentRun run = run_agent(AgentConfig{}, test::synthetic_rgbd_rig(), frames);
  ASSERT_GE(run.keyframes.size(), 2u);
  for (const core::StampedPose& kf : run.keyframes) {
    const auto frame = std::find_if(run.trajectory.begin(), run.trajectory.end(),
                                    [&](const core::StampedPose& p) { return p.t_ns == kf.t_ns; });
    ASSERT_NE(frame, run.trajectory.end());
    EXPECT_TRUE(frame->T_world_body.isApprox(kf.T_world_body, 1e-12)) << "keyframe at " << kf.t_ns << " ns";
  }
}

// Without fusion the points triangulated at a keyframe still reach its covisibility weights: updating
// them again from the map's observations changes nothing for the newest keyframe.
// The threaded worker takes the same step (it had its own copy of the steps, without the update).
TEST(AgentSynthetic, WithoutFusionCovisibilityFollowsTriangulation) {
  const auto& frames = sequence(core::SensorMode::kRgbd);
  for (const bool threaded : {false, true}) {
    AgentConfig config;
    config.mapping.fuse = false;
    config.threaded = threaded;
    Agent agent(config, test::synthetic_rgbd_rig(), core::null_logger());
    for (const core::SensorFrame& frame : frames) agent.process(frame);
    agent.finish();
    Map map = agent.map_copy();
    ASSERT_GE(map.keyframe_count(), 2u);
    const KeyframeId newest = map.keyframes().rbegin()->first;
    const std::map<KeyframeId, int> before = map.keyframe(newest)->connections;
    map.update_connections(newest, config.mapping.covisibility_min_weight);
    EXPECT_EQ(map.keyframe(newest)->connections, before) << (threaded ? "threaded" : "inline");
  }
}

core::SensorFrame with_image(core::SensorFrame f, cv::Mat image) {
  f.image = std::move(image);
  return f;
}

TEST(AgentSynthetic, BadInputIsReportedNotFatal) {
  const auto& frames = sequence(core::SensorMode::kRgbd);
  Agent agent(AgentConfig{}, test::synthetic_rgbd_rig(), core::null_logger());
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(agent.process(frames[static_cast<std::size_t>(i)]).has_pose());

  // A stamp that goes backwards, a repeated stamp, an empty image, an image of the wrong size: rejected.
  const AgentUpdate backwards = agent.process(frames[5]);
  EXPECT_EQ(backwards.status, FrameStatus::kRejected);
  EXPECT_NE(backwards.reason.find("does not advance"), std::string::npos) << backwards.reason;
  EXPECT_EQ(agent.process(frames[9]).status, FrameStatus::kRejected);
  EXPECT_EQ(agent.process(with_image(frames[10], cv::Mat())).status, FrameStatus::kRejected);
  const AgentUpdate small = agent.process(with_image(frames[10], cv::Mat(240, 320, CV_8UC1, cv::Scalar(9))));
  EXPECT_EQ(small.status, FrameStatus::kRejected);
  EXPECT_FALSE(small.reason.empty());

  // All-zero depth: not rejected; tracking may still hold on map points (no depth needed to track).
  core::SensorFrame no_depth = frames[10];
  no_depth.depth_m = cv::Mat::zeros(no_depth.image.size(), CV_32FC1);
  const AgentUpdate zero_depth = agent.process(no_depth);
  EXPECT_NE(zero_depth.status, FrameStatus::kRejected);
  EXPECT_EQ(zero_depth.features_with_depth, 0);

  // No texture: nothing to track, reported as lost with a reason.
  const AgentUpdate blank = agent.process(with_image(frames[11], cv::Mat(480, 640, CV_8UC1, cv::Scalar(128))));
  EXPECT_EQ(blank.status, FrameStatus::kLost);
  EXPECT_FALSE(blank.has_pose());
  EXPECT_FALSE(blank.reason.empty());

  // Dropped frames (a gap), then good frames again: tracking recovers against the reference keyframe.
  const AgentUpdate after_gap = agent.process(frames[16]);
  EXPECT_EQ(after_gap.status, FrameStatus::kTracked);
  EXPECT_NE(after_gap.reason.find("recovered"), std::string::npos) << after_gap.reason;
  EXPECT_NE(after_gap.reason.find("gap"), std::string::npos) << after_gap.reason;
  for (std::size_t i = 17; i < 20; ++i) EXPECT_EQ(agent.process(frames[i]).status, FrameStatus::kTracked) << i;

  // Lost for longer than the recovery frames: relocalisation finds the map again (same component).
  for (std::size_t i = 20; i < 27; ++i) {
    EXPECT_EQ(agent.process(with_image(frames[i], cv::Mat(480, 640, CV_8UC1, cv::Scalar(128)))).status,
              FrameStatus::kLost);
  }
  const AgentUpdate relocalized = agent.process(frames[27]);
  EXPECT_EQ(relocalized.status, FrameStatus::kTracked);
  EXPECT_TRUE(relocalized.relocalized) << relocalized.reason;
  for (std::size_t i = 28; i < 35; ++i) EXPECT_EQ(agent.process(frames[i]).status, FrameStatus::kTracked) << i;
  EXPECT_EQ(agent.map_stats().components, 1);
}

TEST(AgentSynthetic, WithoutRelocalizationALongLossStartsANewComponent) {
  const std::vector<core::SensorFrame>& frames = sequence(core::SensorMode::kRgbd);
  AgentConfig config;
  config.tracking.relocalization.enabled = false;
  Agent agent(config, test::synthetic_rgbd_rig(), core::null_logger());
  for (std::size_t i = 0; i < 20; ++i) agent.process(frames[i]);
  for (std::size_t i = 20; i < 27; ++i) {
    EXPECT_EQ(agent.process(with_image(frames[i], cv::Mat(480, 640, CV_8UC1, cv::Scalar(128)))).status,
              FrameStatus::kLost);
  }
  EXPECT_EQ(agent.process(frames[27]).status, FrameStatus::kInitialized);
  for (std::size_t i = 28; i < 35; ++i) EXPECT_EQ(agent.process(frames[i]).status, FrameStatus::kTracked) << i;
  EXPECT_EQ(agent.map_stats().components, 2);
}

// Relocalisation must fail for new_map_after_s (1 s) on consecutive textured frames before a new map
// starts: a third of a second of them, two seconds blank, then one more is no reason yet (the blank time
// counted, and that frame started a new component).
TEST(AgentSynthetic, BlankFramesDoNotCountTowardsANewComponent) {
  const std::vector<core::SensorFrame>& frames = sequence(core::SensorMode::kRgbd);
  Agent agent(AgentConfig{}, test::synthetic_rgbd_rig(), core::null_logger());
  for (std::size_t i = 0; i < 20; ++i) ASSERT_TRUE(agent.process(frames[i]).has_pose()) << i;
  cv::Mat noise(480, 640, CV_8UC1);
  cv::RNG rng(7);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);  // textured, and no place in the map
  const cv::Mat blank(480, 640, CV_8UC1, cv::Scalar(128));
  core::TimeNs t_ns = frames[19].t_ns;
  const auto next = [&](const cv::Mat& image) {
    core::SensorFrame f = with_image(frames[20], image);
    t_ns += 33'333'333;
    f.t_ns = t_ns;
    return agent.process(f);
  };
  for (int k = 0; k < 10; ++k) EXPECT_FALSE(next(noise).has_pose()) << k;
  for (int k = 0; k < 60; ++k) EXPECT_FALSE(next(blank).has_pose()) << k;
  const AgentUpdate after = next(noise);
  EXPECT_NE(after.status, FrameStatus::kInitialized) << after.reason;
  EXPECT_EQ(agent.map_stats().components, 1);
}

// Half a second of blank frames while the camera keeps turning: the gyro-predicted pose finds the last
// local map again in the same component, where without a gyro a new component starts (test above).
TEST(AgentSynthetic, WithAGyroABlankStretchIsBridgedInTheSameComponent) {
  for (const double bias : {0.0, 0.03}) {
    SCOPED_TRACE(bias);
    const std::vector<core::SensorFrame> frames = test::with_gyro(sequence(core::SensorMode::kRgbd), Eigen::Vector3d(bias, -bias, bias));
    AgentConfig config;
    config.tracking.relocalization.enabled = false;
    Agent agent(config, test::synthetic_gyro_rig(), core::null_logger());
    for (std::size_t i = 0; i < 20; ++i) ASSERT_TRUE(agent.process(frames[i]).has_pose()) << i;
    for (std::size_t i = 20; i < 35; ++i) {
      EXPECT_EQ(agent.process(with_image(frames[i], cv::Mat(480, 640, CV_8UC1, cv::Scalar(128)))).status,
                FrameStatus::kLost);
    }
    const AgentUpdate back = agent.process(frames[35]);
    ASSERT_EQ(back.status, FrameStatus::kTracked) << back.reason;
    EXPECT_NE(back.reason.find("recovered"), std::string::npos) << back.reason;
    for (std::size_t i = 36; i < 45; ++i) EXPECT_EQ(agent.process(frames[i]).status, FrameStatus::kTracked) << i;
    EXPECT_EQ(agent.map_stats().components, 1);
    agent.finish();
    const std::vector<core::SensorFrame> seen(frames.begin(), frames.begin() + 45);
    EXPECT_LT(ate(seen, agent.trajectory()).stats.rmse, 0.005);
  }
}

TEST(AgentSynthetic, DroppedFramesKeepTracking) {
  const auto& all = sequence(core::SensorMode::kRgbd);
  std::vector<core::SensorFrame> frames;
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (i < 20 || i > 23) frames.push_back(all[i]);  // four frames missing
  }
  const AgentRun run = run_agent(AgentConfig{}, test::synthetic_rgbd_rig(), frames);
  EXPECT_EQ(tracked(run), static_cast<int>(frames.size()));
  EXPECT_NE(run.updates[20].reason.find("gap"), std::string::npos) << run.updates[20].reason;
  EXPECT_LT(ate(frames, run.trajectory).stats.rmse, 0.005);
}

}  // namespace
}  // namespace fleetslam::slam
