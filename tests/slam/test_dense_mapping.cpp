// Dense mapping: back-projection against known depth, the flying-pixel and depth-limit filters, voxel
// de-duplication, hand-over of culled keyframes' points, stereo depth against the synthetic room's
// exact walls, and the agent's dense map and update stream in both modes.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <vector>

#include "fleetslam/core/log.hpp"
#include "fleetslam/slam/agent.hpp"
#include "fleetslam/slam/dense_mapping.hpp"
#include "fleetslam/slam/frame_builder.hpp"
#include "synthetic_room.hpp"

namespace fleetslam::slam {
namespace {

const Eigen::Vector3d kRoomMin(-2.0, -1.2, -1.8);
const Eigen::Vector3d kRoomMax(2.0, 1.2, 2.5);

// Distance from a point inside the synthetic room to its nearest wall (the true surface).
double distance_to_walls(const Eigen::Vector3d& p) {
  const Eigen::Vector3d below = p - kRoomMin;
  const Eigen::Vector3d above = kRoomMax - p;
  return std::abs(std::min(below.minCoeff(), above.minCoeff()));
}

struct SurfaceError {
  double mean = 0.0;
  double p95 = 0.0;
};

SurfaceError surface_error(const core::PointCloud& cloud, const Eigen::Isometry3d& T_room_cloud) {
  std::vector<double> d;
  for (const Eigen::Vector3f& p : cloud.points) d.push_back(distance_to_walls(T_room_cloud * p.cast<double>()));
  SurfaceError e;
  if (d.empty()) return e;
  for (double x : d) e.mean += x;
  e.mean /= static_cast<double>(d.size());
  std::sort(d.begin(), d.end());
  e.p95 = d[static_cast<std::size_t>(0.95 * static_cast<double>(d.size() - 1))];
  return e;
}

core::SensorFrame flat_frame(const core::SensorRig& rig, float depth) {
  core::SensorFrame f;
  f.image = cv::Mat(rig.cam0.height(), rig.cam0.width(), CV_8UC3, cv::Scalar(10, 20, 30));
  f.depth_m = cv::Mat(rig.cam0.height(), rig.cam0.width(), CV_32FC1, cv::Scalar(depth));
  return f;
}

DenseMappingConfig config_with_stride(int stride) {
  DenseMappingConfig c;
  c.pixel_stride = stride;
  return c;
}

TEST(DenseMapping, BackProjectsAFlatDepthImageExactlyWithColours) {
  const core::SensorRig rig = test::synthetic_rgbd_rig();
  const FrameBuilder builder(FrameBuilderConfig{}, rig);
  const DenseMapper mapper(config_with_stride(8), builder);
  const core::PointCloud cloud = mapper.keyframe_cloud(flat_frame(rig, 2.0f));
  ASSERT_EQ(cloud.size(), static_cast<std::size_t>((640 / 8) * (480 / 8)));
  ASSERT_TRUE(cloud.has_colors());
  std::size_t i = 0;
  for (int v = 0; v < 480; v += 8) {
    for (int u = 0; u < 640; u += 8, ++i) {
      const Eigen::Vector3f& p = cloud.points[i];
      EXPECT_FLOAT_EQ(p.z(), 2.0f);
      EXPECT_NEAR(p.x(), (u - 319.5) / 500.0 * 2.0, 1e-5);
      EXPECT_NEAR(p.y(), (v - 239.5) / 500.0 * 2.0, 1e-5);
    }
  }
  // BGR (10, 20, 30) in the image is RGB (30, 20, 10) in the cloud.
  EXPECT_EQ(cloud.colors.front(), (core::PointCloud::Rgb{30, 20, 10}));
}

// Normals from the depth image: a plane tilted 30 degrees about the camera's y axis gives every point
// the plane's normal, turned towards the camera, including the last row and column (one-sided there).
TEST(DenseMapping, NormalsOfATiltedPlaneFaceTheCamera) {
  const core::SensorRig rig = test::synthetic_rgbd_rig();
  const FrameBuilder builder(FrameBuilderConfig{}, rig);
  const DenseMapper mapper(config_with_stride(8), builder);
  const double tilt = 30.0 * 3.14159265358979323846 / 180.0;
  const Eigen::Vector3d n(std::sin(tilt), 0.0, -std::cos(tilt));  // n . p = -2 for the plane's points
  core::SensorFrame frame = flat_frame(rig, 0.0f);
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      const Eigen::Vector3d ray((u - 319.5) / 500.0, (v - 239.5) / 500.0, 1.0);
      frame.depth_m.at<float>(v, u) = static_cast<float>(-2.0 / n.dot(ray));
    }
  }
  const core::PointCloud cloud = mapper.keyframe_cloud(frame);
  ASSERT_EQ(cloud.size(), static_cast<std::size_t>((640 / 8) * (480 / 8)));
  ASSERT_TRUE(cloud.has_normals());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    EXPECT_NEAR(n.dot(cloud.points[i].cast<double>()), -2.0, 1e-4) << i;
    EXPECT_GT(cloud.normals[i].cast<double>().dot(n), std::cos(0.5 * 3.14159265358979323846 / 180.0)) << i;
  }
  // A lone sample (no neighbour on the surface) has no normal.
  core::SensorFrame lone = flat_frame(rig, 0.0f);
  lone.depth_m.at<float>(80, 80) = 1.5f;
  const core::PointCloud one = mapper.keyframe_cloud(lone);
  ASSERT_EQ(one.size(), 1u);
  ASSERT_TRUE(one.has_normals());
  EXPECT_EQ(one.normals[0], Eigen::Vector3f::Zero());
}

TEST(DenseMapping, DistortedCameraUsesUndistortedRays) {
  core::SensorRig rig = test::synthetic_rgbd_rig();
  rig.cam0 = core::PinholeCamera(640, 480, 500.0, 500.0, 319.5, 239.5, core::Distortion{0.1, -0.05, 0.001, 0.0, 0.0});
  const FrameBuilder builder(FrameBuilderConfig{}, rig);
  const DenseMapper mapper(config_with_stride(16), builder);
  const core::PointCloud cloud = mapper.keyframe_cloud(flat_frame(rig, 1.5f));
  ASSERT_FALSE(cloud.empty());
  // Every point re-projects through the distorted camera onto the pixel grid it was sampled from.
  for (const Eigen::Vector3f& p : cloud.points) {
    const std::optional<Eigen::Vector2d> uv = rig.cam0.project(p.cast<double>());
    ASSERT_TRUE(uv.has_value());
    EXPECT_NEAR(uv->x(), 16.0 * std::round(uv->x() / 16.0), 1e-4);
    EXPECT_NEAR(uv->y(), 16.0 * std::round(uv->y() / 16.0), 1e-4);
  }
}

TEST(DenseMapping, SkipsMissingOutOfRangeAndFlyingPixels) {
  const core::SensorRig rig = test::synthetic_rgbd_rig();
  const FrameBuilder builder(FrameBuilderConfig{}, rig);
  DenseMappingConfig config = config_with_stride(4);
  config.min_depth_m = 0.5;
  config.max_depth_m = 3.0;
  const DenseMapper mapper(config, builder);
  core::SensorFrame f = flat_frame(rig, 1.0f);
  f.depth_m.colRange(0, 160).setTo(0.0f);                                   // no reading
  f.depth_m.colRange(160, 240).setTo(std::numeric_limits<float>::quiet_NaN());  // invalid
  f.depth_m.colRange(240, 320).setTo(5.0f);                                 // beyond max
  f.depth_m.colRange(320, 400).setTo(0.2f);                                 // before min
  f.depth_m.colRange(480, 640).setTo(2.0f);                                 // a step at u = 480
  const core::PointCloud cloud = mapper.keyframe_cloud(f);
  for (const Eigen::Vector3f& p : cloud.points) {
    const double u = static_cast<double>(p.x() / p.z()) * 500.0 + 319.5;
    EXPECT_GE(u, 399.0);
    EXPECT_GE(p.z(), 0.5f);
    EXPECT_LE(p.z(), 3.0f);
    EXPECT_FALSE(std::abs(u - 476.0) < 0.5) << "the sample beside the depth step is a flying pixel";
  }
  // Columns 400..472 at 1 m and 480..636 at 2 m, every 4th row: 19 + 40 columns.
  EXPECT_EQ(cloud.size(), static_cast<std::size_t>((19 + 40) * 120));
}

// Depth 0 means no measurement, also when min_depth_m is 0: such pixels became points at the camera centre.
TEST(DenseMapping, ZeroDepthIsNoPointEvenWithMinDepthZero) {
  const core::SensorRig rig = test::synthetic_rgbd_rig();
  const FrameBuilder builder(FrameBuilderConfig{}, rig);
  DenseMappingConfig config = config_with_stride(4);
  config.min_depth_m = 0.0;
  const DenseMapper mapper(config, builder);
  core::SensorFrame f = flat_frame(rig, 0.0f);
  f.depth_m(cv::Rect(300, 200, 40, 40)).setTo(1.0f);  // 10 x 10 samples at 1 m
  const core::PointCloud cloud = mapper.keyframe_cloud(f);
  EXPECT_EQ(cloud.size(), 100u);
  for (const Eigen::Vector3f& p : cloud.points) EXPECT_FLOAT_EQ(p.z(), 1.0f);
}

TEST(DenseMapping, UnusableDepthGivesAnEmptyCloud) {
  const core::SensorRig rig = test::synthetic_rgbd_rig();
  const FrameBuilder builder(FrameBuilderConfig{}, rig);
  const DenseMapper mapper(DenseMappingConfig{}, builder);
  core::SensorFrame f = flat_frame(rig, 1.0f);
  core::SensorFrame no_depth = f;
  no_depth.depth_m = cv::Mat();
  EXPECT_TRUE(mapper.keyframe_cloud(no_depth).empty());
  core::SensorFrame small = f;
  small.depth_m = cv::Mat(240, 320, CV_32FC1, cv::Scalar(1.0f));
  EXPECT_TRUE(mapper.keyframe_cloud(small).empty());
  core::SensorFrame raw_units = f;
  raw_units.depth_m = cv::Mat(480, 640, CV_16UC1, cv::Scalar(5000));
  EXPECT_TRUE(mapper.keyframe_cloud(raw_units).empty());
  core::SensorFrame no_image = f;
  no_image.image = cv::Mat();
  EXPECT_FALSE(mapper.keyframe_cloud(no_image).empty()) << "depth without colour still maps (gray points)";
}

TEST(DenseMapping, RejectsBadConfig) {
  const FrameBuilder builder(FrameBuilderConfig{}, test::synthetic_rgbd_rig());
  DenseMappingConfig inverted;
  inverted.min_depth_m = 3.0;
  inverted.max_depth_m = 1.0;
  EXPECT_THROW(DenseMapper(inverted, builder), InputError);
  DenseMappingConfig even_block;
  even_block.stereo_block_size = 4;
  EXPECT_THROW(DenseMapper(even_block, builder), InputError);
  // Built in code, past the YAML limits: errors, not a division by zero or a huge allocation.
  DenseMappingConfig negative_block;
  negative_block.stereo_block_size = -3;
  EXPECT_THROW(DenseMapper(negative_block, builder), InputError);
  for (const int stride : {0, -1}) {
    DenseMappingConfig bad_stride;
    bad_stride.pixel_stride = stride;
    EXPECT_THROW(DenseMapper(bad_stride, builder), InputError) << stride;
  }
}

TEST(DenseMapping, RevisitedVoxelsAddNothing) {
  const core::SensorRig rig = test::synthetic_rgbd_rig();
  const FrameBuilder builder(FrameBuilderConfig{}, rig);
  DenseMapper mapper(config_with_stride(8), builder);
  const core::PointCloud cloud = mapper.keyframe_cloud(flat_frame(rig, 2.0f));
  const Eigen::Isometry3d here = Eigen::Isometry3d::Identity();
  const std::size_t first = mapper.add_keyframe(0, here, cloud);
  EXPECT_EQ(first, cloud.size()) << "samples 8 px apart at 2 m are 3.2 cm apart: one per 2 cm voxel";
  EXPECT_EQ(mapper.add_keyframe(1, here, cloud), 0u) << "the same view again adds no point";
  Eigen::Isometry3d far = Eigen::Isometry3d::Identity();
  far.translation() = Eigen::Vector3d(0.0, 0.0, 10.0);
  EXPECT_EQ(mapper.add_keyframe(2, far, cloud), cloud.size());
  EXPECT_EQ(mapper.add_keyframe(2, far, cloud), 0u) << "an id is added once";
  const DenseStats stats = mapper.stats();
  EXPECT_EQ(stats.keyframes, 3u);
  EXPECT_EQ(stats.points, 2 * cloud.size());
  EXPECT_EQ(stats.back_projected, 3 * cloud.size());
}

TEST(DenseMapping, CloudFollowsKeyframePosesAndCulledPointsMoveToTheHeir) {
  const core::SensorRig rig = test::synthetic_rgbd_rig();
  const FrameBuilder builder(FrameBuilderConfig{}, rig);
  DenseMapper mapper(config_with_stride(16), builder);
  const core::PointCloud cloud = mapper.keyframe_cloud(flat_frame(rig, 2.0f));
  std::map<KeyframeId, Eigen::Isometry3d> poses;
  poses[0] = Eigen::Isometry3d::Identity();
  poses[1] = Eigen::Isometry3d(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()));
  poses[1].translation() = Eigen::Vector3d(1.0, 0.0, -0.5);
  mapper.add_keyframe(0, poses[0], cloud);
  mapper.add_keyframe(1, poses[1], cloud);
  const auto lookup = [&poses](KeyframeId id) -> std::optional<Eigen::Isometry3d> {
    const auto it = poses.find(id);
    if (it == poses.end()) return std::nullopt;
    return it->second;
  };
  const core::PointCloud before = mapper.cloud_world(lookup);
  ASSERT_EQ(before.size(), mapper.stats().points);

  // A correction of keyframe 1 moves its points with it.
  const Eigen::Isometry3d correction(Eigen::Translation3d(0.05, -0.02, 0.01));
  poses[1] = correction * poses[1];
  const core::PointCloud moved = mapper.cloud_world(lookup);
  const std::size_t n0 = mapper.keyframe_cloud_of(0)->size();
  for (std::size_t i = 0; i < moved.size(); ++i) {
    const Eigen::Vector3d expected = i < n0 ? before.points[i].cast<double>() : correction * before.points[i].cast<double>();
    EXPECT_LT((moved.points[i].cast<double>() - expected).norm(), 1e-5);
  }

  // Culling keyframe 1 hands its points to keyframe 0: the world cloud stays where it was.
  mapper.remove_keyframe(1, std::make_pair(KeyframeId{0}, poses[0].inverse() * poses[1]));
  poses.erase(1);
  const core::PointCloud after = mapper.cloud_world(lookup);
  ASSERT_EQ(after.size(), moved.size());
  for (std::size_t i = 0; i < after.size(); ++i) {
    EXPECT_LT((after.points[i] - moved.points[i]).norm(), 1e-5f);
  }
  EXPECT_EQ(mapper.stats().keyframes, 1u);
  mapper.remove_keyframe(0, std::nullopt);
  EXPECT_EQ(mapper.stats().points, 0u);
  mapper.remove_keyframe(42, std::nullopt);  // unknown: ignored
}

// An heir without a cloud of its own (a keyframe of a loaded map, or one the dense stage has not reached)
// still takes a culled keyframe's points, and its own come on top; points dropped for want of an heir free
// their voxels, so that a later view of the surface maps it again.
TEST(DenseMapping, NoSurfaceIsLostWhenTheHeirHasNoCloudOrThereIsNoHeir) {
  const core::SensorRig rig = test::synthetic_rgbd_rig();
  const FrameBuilder builder(FrameBuilderConfig{}, rig);
  DenseMapper mapper(config_with_stride(16), builder);
  const core::PointCloud cloud = mapper.keyframe_cloud(flat_frame(rig, 2.0f));
  const Eigen::Isometry3d here = Eigen::Isometry3d::Identity();
  ASSERT_EQ(mapper.add_keyframe(1, here, cloud), cloud.size());
  mapper.remove_keyframe(1, std::make_pair(KeyframeId{2}, here));  // 2 has no cloud yet
  ASSERT_NE(mapper.keyframe_cloud_of(2), nullptr);
  EXPECT_EQ(mapper.stats().points, cloud.size());
  EXPECT_EQ(mapper.add_keyframe(3, here, cloud), 0u) << "the inherited points still hold their voxels";
  Eigen::Isometry3d far = here;
  far.translation().z() = 10.0;
  EXPECT_EQ(mapper.add_keyframe(2, far, cloud), cloud.size()) << "the heir's own points come on top";
  EXPECT_EQ(mapper.stats().points, 2 * cloud.size());

  mapper.remove_keyframe(2, std::nullopt);  // no heir: its points (own and inherited) go, and their voxels
  EXPECT_EQ(mapper.stats().points, 0u);
  EXPECT_EQ(mapper.add_keyframe(4, here, cloud), cloud.size()) << "the surface maps again";
  EXPECT_EQ(mapper.add_keyframe(5, far, cloud), cloud.size());
}

TEST(DenseMapping, StereoDepthLiesOnTheTrueWalls) {
  const test::SyntheticRoom room = test::default_room();
  const core::SensorRig rig = test::synthetic_stereo_rig(0.12);
  const FrameBuilder builder(FrameBuilderConfig{}, rig);
  const DenseMapper mapper(config_with_stride(4), builder);
  const core::SensorFrame frame = test::synthetic_frame(room, rig, 10);
  const core::PointCloud cloud = mapper.keyframe_cloud(frame);
  ASSERT_GT(cloud.size(), 5000u);
  const SurfaceError e = surface_error(cloud, *frame.T_world_cam_gt);
  std::printf("stereo dense: %zu points, mean %.4f m, p95 %.4f m from the walls\n", cloud.size(), e.mean, e.p95);
  EXPECT_LT(e.mean, 0.03);
  core::SensorFrame no_right = frame;
  no_right.right = cv::Mat();
  EXPECT_TRUE(mapper.keyframe_cloud(no_right).empty());
}

// The agent on the synthetic room: the dense map matches the true walls, and a receiver that keeps
// the latest dense_cam of every keyframe from the update stream holds the same cloud as the agent.
// save_first: the map is saved before finish(), which must not take the pending changes with it.
void check_agent_dense_map(bool threaded, bool save_first = false) {
  const test::SyntheticRoom room = test::default_room();
  const core::SensorRig rig = test::synthetic_rgbd_rig();
  AgentConfig config;
  config.threaded = threaded;
  if (save_first) {  // a keyframe at the last frame (44): its mapping and cloud are pending at the end
    config.keyframes.policy = KeyframePolicyKind::kFixedInterval;
    config.keyframes.interval_frames = 4;
  }
  Agent agent(config, rig, core::null_logger());
  std::map<KeyframeId, std::pair<Eigen::Isometry3d, core::PointCloud>> received;
  const auto receive = [&received](const KeyframeSnapshot& kf) {
    auto& entry = received[kf.id];
    entry.first = kf.T_world_cam;
    if (kf.dense_cam) entry.second = *kf.dense_cam;
  };
  Eigen::Isometry3d T_room_world = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 45; ++i) {
    const core::SensorFrame frame = test::synthetic_frame(room, rig, i);
    if (i == 0) T_room_world = *frame.T_world_cam_gt;
    const AgentUpdate u = agent.process(frame);
    for (const KeyframeSnapshot& kf : u.new_keyframes) receive(kf);
    for (const KeyframeSnapshot& kf : u.changed_keyframes) receive(kf);
    for (KeyframeId id : u.removed_keyframes) received.erase(id);
  }
  if (save_first) {
    const std::filesystem::path file = std::filesystem::temp_directory_path() / "fleetslam_dense_save_first.fsmap";
    agent.save_map(file);
    std::filesystem::remove(file);
  }
  // What the workers did after the last frame (threaded mode) comes with finish(): nothing inline.
  const AgentUpdate last = agent.finish();
  EXPECT_EQ(last.status, FrameStatus::kMapChanges);
  EXPECT_EQ(last.sequence, 44);
  if (!threaded) {
    EXPECT_TRUE(last.new_keyframes.empty() && last.changed_keyframes.empty() && last.removed_keyframes.empty());
  }
  if (save_first) {  // the premise: changes were pending when the map was saved, and finish() has them
    ASSERT_FALSE(last.new_keyframes.empty() && last.changed_keyframes.empty());
  }
  for (const KeyframeSnapshot& kf : last.new_keyframes) receive(kf);
  for (const KeyframeSnapshot& kf : last.changed_keyframes) receive(kf);
  for (KeyframeId id : last.removed_keyframes) received.erase(id);

  const core::PointCloud cloud = agent.dense_cloud();
  const DenseStats stats = agent.dense_stats();
  ASSERT_GT(cloud.size(), 10000u);
  EXPECT_EQ(cloud.size(), stats.points);
  EXPECT_LT(stats.points, stats.back_projected) << "overlapping keyframes add only new voxels";
  const SurfaceError e = surface_error(cloud, T_room_world);
  std::printf("agent dense (%s): %zu points of %zu back-projected, mean %.4f m, p95 %.4f m from the walls\n",
              threaded ? "threaded" : "inline", stats.points, stats.back_projected, e.mean, e.p95);
  EXPECT_LT(e.mean, 0.01);
  EXPECT_LT(e.p95, 0.03);

  std::size_t streamed = 0;
  for (const auto& [id, entry] : received) streamed += entry.second.size();
  EXPECT_EQ(streamed, cloud.size());
}

TEST(DenseMapping, AgentInlineDenseMapMatchesTheWallsAndTheUpdateStream) { check_agent_dense_map(false); }

TEST(DenseMapping, AgentThreadedDenseMapMatchesTheWallsAndTheUpdateStream) { check_agent_dense_map(true); }

// Saving the map waits for the workers but leaves their changes to finish() (it used to call finish() and
// drop them: the last keyframes' clouds never reached a receiver).
TEST(DenseMapping, SavingTheMapKeepsThePendingChangesForFinish) { check_agent_dense_map(true, true); }

TEST(DenseMapping, DisabledDenseMappingSendsNoClouds) {
  const test::SyntheticRoom room = test::default_room();
  const core::SensorRig rig = test::synthetic_rgbd_rig();
  AgentConfig config;
  config.dense.enabled = false;
  Agent agent(config, rig, core::null_logger());
  for (int i = 0; i < 5; ++i) {
    const AgentUpdate u = agent.process(test::synthetic_frame(room, rig, i));
    for (const KeyframeSnapshot& kf : u.new_keyframes) EXPECT_FALSE(kf.dense_cam.has_value());
  }
  EXPECT_TRUE(agent.dense_cloud().empty());
}

}  // namespace
}  // namespace fleetslam::slam
