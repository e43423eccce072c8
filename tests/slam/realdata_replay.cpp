// The agent on the real excerpts in ../shared/data (skipped when absent): TUM fr1_rpy (first 200
// frames, RGB-D) tracks every frame under 3 cm ATE RMSE; EuRoC V1_01_easy micro (stereo) tracks every
// frame, its ATE checked against the left-camera ground truth. Neither closes a loop (no revisits of
// views that are not already covisible). Each run takes tens of seconds.

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "fleetslam/core/dataset.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/core/orbslam_settings.hpp"
#include "fleetslam/core/trajectory.hpp"
#include "fleetslam/core/trajectory_metrics.hpp"
#include "fleetslam/slam/agent.hpp"

namespace fleetslam::slam {
namespace {

namespace fs = std::filesystem;

const fs::path kData = FLEETSLAM_DATA_DIR;

struct Replay {
  int frames = 0;
  int tracked = 0;
  int loops = 0;
  core::Trajectory trajectory;
};

Replay replay(core::FrameSource& source, const AgentConfig& config) {
  Agent agent(config, source.rig(), core::null_logger());
  Replay r;
  while (std::optional<core::SensorFrame> frame = source.next()) {
    const AgentUpdate u = agent.process(*frame);
    ++r.frames;
    r.tracked += u.has_pose() ? 1 : 0;
    r.loops += static_cast<int>(u.loops.size());
  }
  agent.finish();
  r.trajectory = agent.trajectory();
  return r;
}

double ate_rmse(const fs::path& groundtruth, const core::Trajectory& estimate) {
  core::TrajectoryReadOptions options;
  options.duplicate_stamps = core::DuplicateStamps::kKeepLast;
  const core::Trajectory gt = core::read_trajectory_file(groundtruth, options).trajectory;
  const core::AteResult ate =
      core::compute_ate(gt, estimate, core::associate_by_time(gt, estimate), core::AlignmentMode::kSe3);
  EXPECT_TRUE(ate.ok());
  std::printf("ATE RMSE %.4f m over %zu pairs\n", ate.stats.rmse, ate.pairs.size());
  return ate.stats.rmse;
}

TEST(RealdataReplay, TumFr1RpyRgbdTracksEveryFrameUnderThreeCentimetres) {
  const fs::path root = kData / "tum" / "rgbd_dataset_freiburg1_rpy_200";
  if (!fs::exists(root)) GTEST_SKIP() << "no TUM excerpt at " << root;
  core::DatasetConfig dataset;
  const core::OrbSlamSettings settings = core::read_orbslam_settings(kData / "calib" / "TUM1.yaml");
  dataset.rig = settings.rig;
  dataset.load_imu = false;
  auto source = core::open_dataset(root, core::DatasetFormat::kTumRgbd, dataset, core::null_logger());
  const Replay r = replay(*source, AgentConfig{});
  EXPECT_EQ(r.frames, 200);
  EXPECT_EQ(r.tracked, 200);
  EXPECT_LT(ate_rmse(root / "groundtruth.txt", r.trajectory), 0.03);
  // The camera turns on the spot; its keyframes stay covisible, so no loop is closed (none is false).
  EXPECT_EQ(r.loops, 0);
}

TEST(RealdataReplay, EurocV101MicroStereoTracksEveryFrame) {
  const fs::path root = kData / "euroc" / "V1_01_easy_micro";
  if (!fs::exists(root)) GTEST_SKIP() << "no EuRoC excerpt at " << root;
  core::DatasetConfig dataset;
  dataset.load_imu = false;
  dataset.groundtruth_file = (root / "groundtruth_leftcam_tum.txt").string();
  auto source = core::open_dataset(root, core::DatasetFormat::kEuroc, dataset, core::null_logger());
  AgentConfig config;
  config.sensor = AgentSensor::kStereo;
  const Replay r = replay(*source, config);
  EXPECT_GT(r.frames, 90);
  EXPECT_EQ(r.tracked, r.frames);
  EXPECT_EQ(r.loops, 0);
  // The ground truth covers the last 74 frames (a few metres of flight): the bound is loose on purpose.
  EXPECT_LT(ate_rmse(root / "groundtruth_leftcam_tum.txt", r.trajectory), 0.05);
}

}  // namespace
}  // namespace fleetslam::slam
