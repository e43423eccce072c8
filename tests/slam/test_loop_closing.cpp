// Loop closing on a synthetic loop: the camera turns once around the room (its start view comes back)
// and a depth glitch of 20 frames (depth 12 % too long) a third of the way round shifts the map built then,
// so the rest of the trajectory is offset from the truth until the loop is closed. The loop is detected
// between the last keyframes and the first, and closed: the ATE drops by more than half against the same
// run without loop closing.

#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/core/trajectory_metrics.hpp"
#include "fleetslam/slam/agent.hpp"
#include "fleetslam/slam/map_io.hpp"
#include "synthetic_room.hpp"

namespace fleetslam::slam {
namespace {

constexpr int kLoopFrames = 240;   // one turn in 8 s at 30 Hz
constexpr int kExtraFrames = 45;   // then 1.5 s along the start of the loop again
// A depth sensor glitch: these frames' depth is 12 % too long, which shifts the map built from them.
constexpr int kGlitchBegin = 80;
constexpr int kGlitchEnd = 100;
constexpr double kGlitchScale = 1.12;

// A circle of 0.6 m radius with the camera looking along the direction of travel turned 30 degrees
// outwards: after one turn it sees its start view again.
Eigen::Isometry3d loop_pose(double t_s) {
  const double theta = 2.0 * M_PI * t_s / (kLoopFrames / 30.0);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(-theta, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.6 * std::sin(theta) - 0.0, 0.1 * std::sin(2.0 * theta), 0.6 * std::cos(theta) - 0.6);
  return T;
}

const std::vector<core::SensorFrame>& loop_sequence() {
  static const std::vector<core::SensorFrame> frames = [] {
    const test::SyntheticRoom room = test::default_room();
    const core::SensorRig rig = test::synthetic_rgbd_rig();
    std::mt19937 rng(42);
    std::normal_distribution<double> scale_error(0.0, 0.03);
    std::vector<core::SensorFrame> out;
    for (int i = 0; i < kLoopFrames + kExtraFrames; ++i) {
      core::SensorFrame f;
      f.sequence = i;
      f.t_ns = core::kNsPerSecond + static_cast<core::TimeNs>(i) * core::kNsPerSecond / 30;
      f.T_world_cam_gt = loop_pose(i / 30.0);
      room.render(rig.cam0, *f.T_world_cam_gt, f.image, f.depth_m);
      if (i >= kGlitchBegin && i < kGlitchEnd) f.depth_m *= kGlitchScale;
      out.push_back(std::move(f));
    }
    return out;
  }();
  return frames;
}

struct LoopRun {
  core::Trajectory trajectory;
  std::vector<LoopEvent> loops;
  int tracked = 0;
  Map map;  // as saved at the end
};

LoopRun run(bool loop_closing) {
  AgentConfig config;
  config.loop_closing.enabled = loop_closing;
  Agent agent(config, test::synthetic_rgbd_rig(), core::null_logger());
  LoopRun r;
  for (const core::SensorFrame& f : loop_sequence()) {
    const AgentUpdate u = agent.process(f);
    r.tracked += u.has_pose() ? 1 : 0;
    for (const LoopEvent& e : u.loops) {
      std::printf("loop at frame %lld: keyframe %lld with %lld, %d inliers, correction %.4f m, %d keyframes moved, global BA %d\n",
                  static_cast<long long>(f.sequence), static_cast<long long>(e.current),
                  static_cast<long long>(e.loop), e.inliers, e.correction.translation().norm(), e.moved_keyframes, e.global_ba ? 1 : 0);
      r.loops.push_back(e);
    }
  }
  agent.finish();
  r.trajectory = agent.trajectory();
  const std::filesystem::path file = std::filesystem::temp_directory_path() /
                                     ("fleetslam_loop_" + std::to_string(loop_closing) + "_" + std::to_string(::getpid()) + ".fsmap");
  agent.save_map(file);
  r.map = load_map(file).map;
  std::filesystem::remove(file);
  return r;
}

// skip_glitch: frames of the glitch and the half second after it are left out; their poses carry the
// sensor's error itself, which no loop closure can remove (the drift it causes afterwards is what counts).
double ate_rmse(const core::Trajectory& estimate, bool skip_glitch) {
  core::Trajectory gt;
  for (const core::SensorFrame& f : loop_sequence()) {
    if (skip_glitch && f.sequence >= kGlitchBegin && f.sequence < kGlitchEnd + 15) continue;
    gt.push_back(core::StampedPose{f.t_ns, *f.T_world_cam_gt});
  }
  return core::compute_ate(gt, estimate, core::associate_by_time(gt, estimate), core::AlignmentMode::kSe3).stats.rmse;
}

TEST(LoopClosing, SyntheticLoopIsClosedAndHalvesTheAte) {
  const LoopRun open = run(false);
  const LoopRun closed = run(true);
  const double ate_open = ate_rmse(open.trajectory, true);
  const double ate_closed = ate_rmse(closed.trajectory, true);
  std::printf("ATE RMSE outside the glitch: without loop closing %.4f m, with %.4f m (%zu loop(s))\n", ate_open,
              ate_closed, closed.loops.size());
  std::printf("ATE RMSE over all frames: without loop closing %.4f m, with %.4f m\n", ate_rmse(open.trajectory, false),
              ate_rmse(closed.trajectory, false));
  EXPECT_TRUE(open.loops.empty());
  ASSERT_FALSE(closed.loops.empty());
  // The start view comes back: the loop reaches from one of the last keyframes to one of the first.
  std::printf("first loop: keyframe %lld to keyframe %lld\n", static_cast<long long>(closed.loops.front().current),
              static_cast<long long>(closed.loops.front().loop));
  EXPECT_LT(closed.loops.front().loop, closed.loops.front().current / 4);
  EXPECT_GE(closed.loops.front().inliers, 40);
  EXPECT_LT(ate_closed, 0.5 * ate_open);
  EXPECT_EQ(closed.tracked, static_cast<int>(loop_sequence().size()));
  // The map's root stays where it was made: the world is cam0 of the first frame.
  int roots = 0;
  for (const auto& [id, kf] : closed.map.keyframes()) {
    if (!kf.root) continue;
    ++roots;
    EXPECT_LT((kf.T_world_cam.matrix() - Eigen::Matrix4d::Identity()).norm(), 1e-9) << kf.T_world_cam.matrix();
  }
  EXPECT_EQ(roots, 1);
  // The loop's keyframes keep their loop edge (for later loops' essential graphs) and were not culled.
  for (const LoopEvent& e : closed.loops) {
    const Keyframe* current = closed.map.keyframe(e.current);
    ASSERT_NE(current, nullptr);
    EXPECT_EQ(current->loop_edges.count(e.loop), 1u);
    ASSERT_NE(closed.map.keyframe(e.loop), nullptr);
    EXPECT_EQ(closed.map.keyframe(e.loop)->loop_edges.count(e.current), 1u);
  }
}

TEST(LoopClosing, MissingVocabularyIsAnInputError) {
  AgentConfig config;
  config.place_recognition.vocabulary = "/nonexistent/vocabulary.fsvoc";
  EXPECT_THROW(Agent(config, test::synthetic_rgbd_rig(), core::null_logger()), InputError);
  config.place_recognition.enabled = false;  // no vocabulary needed then
  EXPECT_NO_THROW(Agent(config, test::synthetic_rgbd_rig(), core::null_logger()));
}

}  // namespace
}  // namespace fleetslam::slam
