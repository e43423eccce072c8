// FrameBuilder on synthetic sensor frames: RGB-D (features, depth at the raw keypoints, undistorted
// coordinates), stereo with a distorted, slightly rotated rig (rectified once, depth of a plane),
// an already rectified stereo rig, monocular, and every kind of bad input (a status, never a throw).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/se3.hpp"
#include "fleetslam/core/stereo_rectify.hpp"
#include "fleetslam/slam/frame_builder.hpp"
#include "front_end_test_util.hpp"

namespace fleetslam::slam {
namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

// TUM freiburg1's colour camera (ORB-SLAM's TUM1.yaml).
core::SensorRig rgbd_rig() {
  core::SensorRig rig;
  rig.mode = core::SensorMode::kRgbd;
  rig.cam0 = core::PinholeCamera(640, 480, 517.306408, 516.469215, 318.643040, 255.313989,
                                 core::Distortion{0.262383, -0.953104, -0.005358, 0.002628, 1.163314});
  rig.bf = 40.0;
  rig.rgb_order = false;
  return rig;
}

// Depth rising from 1 m on the left to 3 m on the right, without measurements in the top-left quarter.
cv::Mat ramp_depth() {
  cv::Mat depth(480, 640, CV_32FC1);
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) depth.at<float>(v, u) = (u < 320 && v < 240) ? 0.0f : 1.0f + 2.0f * u / 640.0f;
  }
  return depth;
}

core::SensorFrame rgbd_frame() {
  core::SensorFrame frame;
  frame.sequence = 17;
  frame.t_ns = 1'000'000'000;
  cv::cvtColor(test::textured_image(640, 480, 21), frame.image, cv::COLOR_GRAY2BGR);
  frame.depth_m = ramp_depth();
  return frame;
}

TEST(FrameBuilder, RgbdFrameHasFeaturesDepthAndUndistortedCoordinates) {
  const core::SensorRig rig = rgbd_rig();
  const FrameBuilder builder(FrameBuilderConfig{}, rig);
  EXPECT_FALSE(builder.rectifies());
  const core::SensorFrame sensor = rgbd_frame();
  const FrameBuildResult result = builder.build(sensor);
  ASSERT_TRUE(result.ok()) << result.reason;
  const Frame& f = result.frame;
  EXPECT_EQ(f.id, 17);
  EXPECT_EQ(f.t_ns, 1'000'000'000);
  EXPECT_GE(f.size(), 950u);
  EXPECT_TRUE(f.camera.distortion().is_zero());
  EXPECT_DOUBLE_EQ(f.camera.fx(), rig.cam0.fx());
  EXPECT_DOUBLE_EQ(f.bf, 40.0);
  EXPECT_NEAR(f.close_depth_m, 40.0 * 40.0 / rig.cam0.fx(), 1e-12);
  EXPECT_EQ(f.pyramid.levels, 8);
  EXPECT_EQ(f.descriptors.rows, static_cast<int>(f.size()));
  EXPECT_EQ(f.map_points.size(), f.size());

  std::vector<Eigen::Vector2d> raw;
  for (const cv::KeyPoint& k : f.keypoints) raw.emplace_back(k.pt.x, k.pt.y);
  const std::vector<Eigen::Vector2d> undistorted = rig.cam0.undistort_points(raw);
  int with_depth = 0, in_hole = 0;
  for (std::size_t i = 0; i < f.size(); ++i) {
    EXPECT_NEAR((f.uv[i] - undistorted[i]).norm(), 0.0, 1e-9);
    EXPECT_EQ(f.level[i], f.keypoints[i].octave);
    const int u = static_cast<int>(std::lround(f.keypoints[i].pt.x));
    const int v = static_cast<int>(std::lround(f.keypoints[i].pt.y));
    const double expected = sensor.depth_m.at<float>(v, u);
    if (expected <= 0.0) {
      EXPECT_FALSE(f.has_depth(i));
      ++in_hole;
      continue;
    }
    ASSERT_TRUE(f.has_depth(i));
    ++with_depth;
    EXPECT_DOUBLE_EQ(f.depth_m[i], expected);
    EXPECT_NEAR(f.u_right[i], f.uv[i].x() - 40.0 / expected, 1e-9);
    // The grid finds every feature at its own coordinates.
    const std::vector<int> near = f.grid.features_in_area(f.uv[i].x(), f.uv[i].y(), 0.5);
    EXPECT_NE(std::find(near.begin(), near.end(), static_cast<int>(i)), near.end());
  }
  EXPECT_EQ(result.features_with_depth, with_depth);
  EXPECT_GT(in_hole, 100);
  EXPECT_GT(with_depth, 600);
}

TEST(FrameBuilder, RgbdDepthOutsideTheConfiguredRangeIsDropped) {
  FrameBuilderConfig config;
  config.max_depth_m = 2.0;
  const FrameBuildResult result = FrameBuilder(config, rgbd_rig()).build(rgbd_frame());
  ASSERT_TRUE(result.ok());
  int with_depth = 0;
  for (std::size_t i = 0; i < result.frame.size(); ++i) {
    if (!result.frame.has_depth(i)) continue;
    ++with_depth;
    EXPECT_LE(result.frame.depth_m[i], 2.0);
    EXPECT_LT(result.frame.keypoints[i].pt.x, 321.0f);
  }
  EXPECT_GT(with_depth, 100);
}

// A raw stereo pair that needs rectification: distorted cameras with different intrinsics, cam1 turned
// by about a degree and rolled, 0.11 m to the right.
core::SensorRig distorted_stereo_rig() {
  core::SensorRig rig;
  rig.mode = core::SensorMode::kStereo;
  rig.cam0 = core::PinholeCamera(640, 480, 460.0, 458.0, 322.0, 243.0, core::Distortion{-0.28, 0.07, 0.0002, 0.00002, 0.0});
  rig.cam1 = core::PinholeCamera(640, 480, 457.0, 456.0, 316.0, 236.0, core::Distortion{-0.27, 0.068, -0.0001, 0.0, 0.0});
  rig.T_cam0_cam1 = Eigen::Isometry3d::Identity();
  rig.T_cam0_cam1.linear() = core::so3_exp(Eigen::Vector3d(0.3 * kDegToRad, -1.0 * kDegToRad, 0.5 * kDegToRad));
  rig.T_cam0_cam1.translation() = Eigen::Vector3d(0.11, 0.001, -0.0005);
  rig.bf = 0.11 * 460.0;
  return rig;
}

// The raw image camera `index` takes of a scene whose rectified view is `rectified`: each raw pixel
// samples the rectified image where it rectifies to.
cv::Mat raw_from_rectified(const core::StereoRectification& rect, int index, const cv::Mat& rectified) {
  const core::PinholeCamera& raw = index == 0 ? rect.raw0 : rect.raw1;
  cv::Mat map_x(raw.height(), raw.width(), CV_32FC1), map_y(raw.height(), raw.width(), CV_32FC1);
  for (int v = 0; v < raw.height(); ++v) {
    for (int u = 0; u < raw.width(); ++u) {
      const auto p = core::rectify_pixel(rect, index, Eigen::Vector2d(u, v));
      map_x.at<float>(v, u) = p ? static_cast<float>(p->x()) : -1000.0f;
      map_y.at<float>(v, u) = p ? static_cast<float>(p->y()) : -1000.0f;
    }
  }
  cv::Mat out;
  cv::remap(rectified, out, map_x, map_y, cv::INTER_CUBIC, cv::BORDER_CONSTANT, cv::Scalar(0));
  return out;
}

// A fisheye pair as TUM-VI's (equidistant model, 512x512, about 190 degrees across), 10 cm apart.
core::SensorRig fisheye_stereo_rig() {
  core::SensorRig rig;
  rig.mode = core::SensorMode::kStereo;
  rig.cam0 = core::PinholeCamera(512, 512, 190.98, 190.97, 254.93, 256.90,
                                 core::Distortion::equidistant(0.00348, 0.000715, -0.00205, 0.000203));
  rig.cam1 = core::PinholeCamera(512, 512, 190.44, 190.43, 252.60, 254.92,
                                 core::Distortion::equidistant(0.00340, 0.00177, -0.00266, 0.00033));
  rig.T_cam0_cam1 = Eigen::Isometry3d::Identity();
  rig.T_cam0_cam1.linear() = core::so3_exp(Eigen::Vector3d(0.4 * kDegToRad, 0.3 * kDegToRad, -0.2 * kDegToRad));
  rig.T_cam0_cam1.translation() = Eigen::Vector3d(0.101, -0.0019, -0.001);
  rig.bf = 0.101 * 190.98;
  return rig;
}

// The rig's raw images of a plane 2 m ahead of the rectified left camera (textured in the rectified
// view), built into a frame: rectified coordinates, and the plane's disparity on most features.
void expect_rectified_plane_depth(const core::SensorRig& rig, std::size_t min_features) {
  const FrameBuilder builder(FrameBuilderConfig{}, rig);
  ASSERT_TRUE(builder.rectifies());
  const core::StereoRectification rect = core::compute_stereo_rectification(rig.cam0, *rig.cam1, rig.T_cam0_cam1);
  EXPECT_DOUBLE_EQ(builder.camera().fx(), rect.rig.camera.fx());
  EXPECT_DOUBLE_EQ(builder.bf(), rect.rig.bf());
  EXPECT_TRUE(builder.T_cam0_rect0().isApprox(rect.T_cam0_rect0(), 1e-12));
  EXPECT_FALSE(builder.T_cam0_rect0().linear().isIdentity(1e-6));

  // A fronto-parallel plane 2 m ahead of the rectified left camera: in the rectified pair a pure shift.
  const double depth_m = 2.0;
  const test::StereoScene scene = test::make_stereo_scene(rig.cam0.width(), rig.cam0.height(), rect.rig.bf(),
                                                          cv::Rect(0, 0, 1, 1), depth_m, depth_m, 31);
  core::SensorFrame sensor;
  sensor.image = raw_from_rectified(rect, 0, scene.left);
  sensor.right = raw_from_rectified(rect, 1, scene.right);
  const FrameBuildResult result = builder.build(sensor);
  ASSERT_TRUE(result.ok()) << result.reason;
  const Frame& f = result.frame;
  EXPECT_TRUE(f.camera.distortion().is_zero());
  EXPECT_DOUBLE_EQ(f.camera.cx(), rect.rig.camera.cx());
  EXPECT_DOUBLE_EQ(f.bf, rect.rig.bf());
  EXPECT_NEAR(f.close_depth_m, 40.0 * rect.rig.baseline_m, 1e-12);
  EXPECT_GT(result.right_features, static_cast<int>(min_features));
  EXPECT_GE(f.size(), min_features);
  int good = 0;
  for (std::size_t i = 0; i < f.size(); ++i) {
    // Rectified coordinates: keypoints are the frame's coordinates.
    EXPECT_DOUBLE_EQ(f.uv[i].x(), static_cast<double>(f.keypoints[i].pt.x));
    // Within 0.75 px of the true disparity (3 % of depth for the first rig's 25 px at 2 m).
    if (f.has_depth(i) && std::abs(f.bf / f.depth_m[i] - f.bf / depth_m) < 0.75) ++good;
  }
  EXPECT_GT(result.features_with_depth, static_cast<int>(f.size()) * 6 / 10);
  EXPECT_GE(good, result.features_with_depth * 95 / 100) << good << " of " << result.features_with_depth;
  ::testing::Test::RecordProperty("features", static_cast<int>(f.size()));
  ::testing::Test::RecordProperty("with_depth", result.features_with_depth);
  ::testing::Test::RecordProperty("within_0_75_px", good);
}

TEST(FrameBuilder, DistortedRotatedStereoRigIsRectifiedAndGivesPlaneDepth) {
  expect_rectified_plane_depth(distorted_stereo_rig(), 900);
}

TEST(FrameBuilder, FisheyeStereoRigIsRectifiedAndGivesPlaneDepth) {
  expect_rectified_plane_depth(fisheye_stereo_rig(), 800);
}

TEST(FrameBuilder, RectifiedStereoRigIsUsedAsItComes) {
  core::SensorRig rig;
  rig.mode = core::SensorMode::kStereoInertial;
  rig.cam0 = core::PinholeCamera(640, 480, 500.0, 500.0, 319.5, 239.5);
  rig.cam1 = rig.cam0;
  rig.T_cam0_cam1.translation() = Eigen::Vector3d(0.0975, 0.0, 0.0);
  const FrameBuilder builder(FrameBuilderConfig{}, rig);
  EXPECT_FALSE(builder.rectifies());
  EXPECT_DOUBLE_EQ(builder.bf(), 48.75);  // rig.bf is 0: baseline * fx
  EXPECT_TRUE(builder.T_cam0_rect0().isApprox(Eigen::Isometry3d::Identity()));
  const test::StereoScene scene = test::make_stereo_scene(640, 480, 48.75, cv::Rect(200, 120, 240, 240), 1.0, 2.5, 41);
  core::SensorFrame sensor;
  sensor.image = scene.left;
  sensor.right = scene.right;
  const FrameBuildResult result = builder.build(sensor);
  ASSERT_TRUE(result.ok()) << result.reason;
  EXPECT_GT(result.features_with_depth, static_cast<int>(result.frame.size()) / 2);
  for (std::size_t i = 0; i < result.frame.size(); ++i) {
    if (result.frame.has_depth(i)) {
      EXPECT_GT(result.frame.depth_m[i], 0.9);
    }
  }
}

TEST(FrameBuilder, MonocularFrameHasFeaturesWithoutDepth) {
  core::SensorRig rig = rgbd_rig();
  rig.mode = core::SensorMode::kMonocular;
  const FrameBuildResult result = FrameBuilder(FrameBuilderConfig{}, rig).build(rgbd_frame());
  ASSERT_TRUE(result.ok());
  EXPECT_GE(result.frame.size(), 950u);
  EXPECT_EQ(result.features_with_depth, 0);
  EXPECT_EQ(result.frame.bf, 0.0);
  EXPECT_EQ(result.frame.close_depth_m, 0.0);
  for (std::size_t i = 0; i < result.frame.size(); ++i) EXPECT_FALSE(result.frame.has_depth(i));
}

struct BadInput {
  const char* name;
  bool stereo;
  void (*spoil)(core::SensorFrame&);
  FrameBuildStatus status;
  bool keeps_features;
};

TEST(FrameBuilder, BadInputGivesAStatusNotACrash) {
  const std::vector<BadInput> cases{
      {"empty image", false, [](core::SensorFrame& s) { s.image = cv::Mat(); }, FrameBuildStatus::kEmptyImage, false},
      {"wrong size", false, [](core::SensorFrame& s) { cv::resize(s.image, s.image, cv::Size(320, 240)); },
       FrameBuildStatus::kWrongImageSize, false},
      {"16-bit image", false, [](core::SensorFrame& s) { s.image = cv::Mat(480, 640, CV_16UC1, cv::Scalar(300)); },
       FrameBuildStatus::kUnsupportedImage, false},
      {"all-zero depth", false, [](core::SensorFrame& s) { s.depth_m.setTo(0.0f); }, FrameBuildStatus::kNoDepth, true},
      {"no depth", false, [](core::SensorFrame& s) { s.depth_m = cv::Mat(); }, FrameBuildStatus::kNoDepth, true},
      {"depth of another size", false, [](core::SensorFrame& s) { s.depth_m = cv::Mat(240, 320, CV_32FC1, cv::Scalar(1.0f)); },
       FrameBuildStatus::kNoDepth, true},
      {"raw 16-bit depth", false, [](core::SensorFrame& s) { s.depth_m = cv::Mat(480, 640, CV_16UC1, cv::Scalar(5000)); },
       FrameBuildStatus::kNoDepth, true},
      {"missing right image", true, [](core::SensorFrame& s) { s.right = cv::Mat(); }, FrameBuildStatus::kBadRightImage,
       true},
      {"right image of another size", true, [](core::SensorFrame& s) { s.right = cv::Mat(240, 320, CV_8UC1, cv::Scalar(9)); },
       FrameBuildStatus::kBadRightImage, true},
      {"stereo, empty left image", true, [](core::SensorFrame& s) { s.image = cv::Mat(); }, FrameBuildStatus::kEmptyImage,
       false},
      {"16-bit right image", true, [](core::SensorFrame& s) { s.right = cv::Mat(480, 640, CV_16UC1, cv::Scalar(300)); },
       FrameBuildStatus::kBadRightImage, true},
      {"black right image", true, [](core::SensorFrame& s) { s.right.setTo(0); }, FrameBuildStatus::kNoDepth, true},
  };
  const FrameBuilder rgbd(FrameBuilderConfig{}, rgbd_rig());
  const FrameBuilder stereo(FrameBuilderConfig{}, distorted_stereo_rig());
  for (const BadInput& c : cases) {
    core::SensorFrame sensor = rgbd_frame();
    if (c.stereo) {
      cv::cvtColor(sensor.image, sensor.image, cv::COLOR_BGR2GRAY);
      sensor.right = sensor.image.clone();
      sensor.depth_m = cv::Mat();
    }
    c.spoil(sensor);
    const cv::Mat image_before = sensor.image.clone();
    FrameBuildResult result;
    ASSERT_NO_THROW(result = (c.stereo ? stereo : rgbd).build(sensor)) << c.name;
    // build() takes the frame as const: its pixels stay as they were (a gray left image without a right
    // one had been overwritten by its rectified view).
    EXPECT_EQ(sensor.image.size(), image_before.size()) << c.name;
    if (!image_before.empty()) {
      EXPECT_EQ(cv::norm(sensor.image, image_before, cv::NORM_INF), 0.0) << c.name;
    }
    EXPECT_EQ(result.status, c.status) << c.name;
    EXPECT_NE(result.reason.find("frame 17"), std::string::npos) << c.name << ": " << result.reason;
    EXPECT_EQ(result.frame.size() > 0, c.keeps_features) << c.name;
    EXPECT_EQ(result.features_with_depth, 0) << c.name;
    for (std::size_t i = 0; i < result.frame.size(); ++i) EXPECT_FALSE(result.frame.has_depth(i)) << c.name;
    EXPECT_FALSE(result.frame.grid.empty()) << c.name;
    EXPECT_GT(result.frame.camera.width(), 0) << c.name;
    EXPECT_EQ(result.frame.map_points.size(), result.frame.size()) << c.name;
  }
}

TEST(FrameBuilder, UnusableRigsAreConfigurationErrors) {
  core::SensorRig no_bf = rgbd_rig();
  no_bf.bf = 0.0;
  EXPECT_THROW(FrameBuilder(FrameBuilderConfig{}, no_bf), InputError);
  core::SensorRig no_right = distorted_stereo_rig();
  no_right.cam1.reset();
  no_right.bf = 0.0;
  EXPECT_THROW(FrameBuilder(FrameBuilderConfig{}, no_right), InputError);
  core::SensorRig vertical = distorted_stereo_rig();
  vertical.T_cam0_cam1.translation() = Eigen::Vector3d(0.0, 0.11, 0.0);
  EXPECT_THROW(FrameBuilder(FrameBuilderConfig{}, vertical), InputError);
  FrameBuilderConfig bad_orb;
  bad_orb.orb.min_fast_threshold = 50;
  EXPECT_THROW(FrameBuilder(bad_orb, rgbd_rig()), InputError);
  FrameBuilderConfig empty_range;  // each value within its limits, the range empty
  empty_range.min_depth_m = 5.0;
  empty_range.max_depth_m = 2.0;
  EXPECT_THROW(FrameBuilder(empty_range, rgbd_rig()), InputError);
  // A fisheye cam0 would be undistorted to a pinhole camera outside stereo.
  for (const core::SensorMode mode : {core::SensorMode::kRgbd, core::SensorMode::kMonocular}) {
    core::SensorRig fisheye = fisheye_stereo_rig();
    fisheye.mode = mode;
    fisheye.cam1.reset();
    EXPECT_THROW(FrameBuilder(FrameBuilderConfig{}, fisheye), InputError) << core::to_string(mode);
  }
  EXPECT_NO_THROW(FrameBuilder(FrameBuilderConfig{}, fisheye_stereo_rig()));
}

TEST(FrameBuilder, AColourLeftAndAGrayRightImageMakeAStereoPair) {
  const FrameBuilder stereo(FrameBuilderConfig{}, distorted_stereo_rig());
  core::SensorFrame sensor = rgbd_frame();
  sensor.depth_m = cv::Mat();
  cv::Mat gray;
  cv::cvtColor(sensor.image, gray, cv::COLOR_BGR2GRAY);
  sensor.right = gray;  // whatever depth this pair gives, the gray pair of the same images gives it too
  const FrameBuildResult mixed = stereo.build(sensor);
  EXPECT_NE(mixed.status, FrameBuildStatus::kBadRightImage) << mixed.reason;
  EXPECT_GT(mixed.right_features, 0);
  core::SensorFrame same = sensor;
  same.image = gray;
  const FrameBuildResult gray_pair = stereo.build(same);
  EXPECT_EQ(mixed.status, gray_pair.status);
  EXPECT_EQ(mixed.right_features, gray_pair.right_features);
  EXPECT_EQ(mixed.features_with_depth, gray_pair.features_with_depth);
}

TEST(FrameBuilder, ConfigReadsFromYamlAndStatusesHaveNames) {
  const auto config = core::load_config<FrameBuilderConfig>(
      core::ConfigReader::from_string("front:\n  max_depth_m: 5.0\n  orb:\n    num_features: 1500\n"
                                      "  stereo:\n    max_distance: 60\n",
                                      "agent.yaml"),
      "front");
  EXPECT_DOUBLE_EQ(config.max_depth_m, 5.0);
  EXPECT_EQ(config.orb.num_features, 1500);
  EXPECT_EQ(config.stereo.max_distance, 60);
  EXPECT_DOUBLE_EQ(config.close_depth_baselines, 40.0);
  EXPECT_NE(core::config_to_yaml(config).find("close_depth_baselines"), std::string::npos);
  EXPECT_THROW(core::load_config<FrameBuilderConfig>(core::ConfigReader::from_string("front:\n  max_dept_m: 5\n", "a.yaml"),
                                                     "front"),
               InputError);
  EXPECT_EQ(to_string(FrameBuildStatus::kOk), "ok");
  EXPECT_EQ(to_string(FrameBuildStatus::kNoDepth), "no_depth");
  EXPECT_EQ(to_string(FrameBuildStatus::kBadRightImage), "bad_right_image");
}

}  // namespace
}  // namespace fleetslam::slam
