// The dataset readers on the real sequences under FLEETSLAM_DATA_DIR (skipped when the folder is absent):
// TUM RGB-D freiburg1_rpy (first 200 frames) and the EuRoC V1_01_easy micro excerpt.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "fleetslam/core/dataset.hpp"
#include "fleetslam/core/euroc.hpp"
#include "fleetslam/core/trajectory.hpp"

namespace fleetslam::core {
namespace {

const std::filesystem::path kData = FLEETSLAM_DATA_DIR;
const std::filesystem::path kTum = kData / "tum" / "rgbd_dataset_freiburg1_rpy_200";
const std::filesystem::path kEuroc = kData / "euroc" / "V1_01_easy_micro";

#define SKIP_WITHOUT(folder)                                                                      \
  if (!std::filesystem::is_directory(folder)) {                                                   \
    GTEST_SKIP() << "real data not found at " << (folder) << " (set FLEETSLAM_DATA_DIR to the shared data)"; \
  }

double rotation_angle_deg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() * 180.0 / M_PI;
}

// Depth statistics of one frame: share of pixels with a measurement, and the share of those in [0.3, 6] m.
struct DepthStats {
  double valid_share = 0.0;
  double plausible_share = 0.0;
  double median_m = 0.0;
};

DepthStats depth_stats(const cv::Mat& depth_m) {
  std::vector<float> valid;
  for (int r = 0; r < depth_m.rows; ++r) {
    for (int c = 0; c < depth_m.cols; ++c) {
      if (depth_m.at<float>(r, c) > 0.0f) valid.push_back(depth_m.at<float>(r, c));
    }
  }
  DepthStats stats;
  if (valid.empty()) return stats;
  const auto plausible = std::count_if(valid.begin(), valid.end(), [](float d) { return d >= 0.3f && d <= 6.0f; });
  stats.valid_share = static_cast<double>(valid.size()) / static_cast<double>(depth_m.total());
  stats.plausible_share = static_cast<double>(plausible) / static_cast<double>(valid.size());
  std::nth_element(valid.begin(), valid.begin() + static_cast<std::ptrdiff_t>(valid.size() / 2), valid.end());
  stats.median_m = static_cast<double>(valid[valid.size() / 2]);
  return stats;
}

TEST(RealDataTum, Freiburg1RpyReadsAllFramesWithDepthGroundTruthAndAccelerometer) {
  SKIP_WITHOUT(kTum);
  const auto source = open_dataset(kTum, std::nullopt, {}, null_logger());
  EXPECT_EQ(source->info().format, DatasetFormat::kTumRgbd);
  ASSERT_EQ(source->size(), 200u);
  EXPECT_TRUE(source->info().skipped.empty());
  EXPECT_EQ(source->info().frames_with_groundtruth, 200u);
  EXPECT_DOUBLE_EQ(source->rig().cam0.fx(), 517.3);
  EXPECT_DOUBLE_EQ(source->rig().cam0.distortion().k1, 0.2624);
  const Trajectory groundtruth = read_trajectory(kTum / "groundtruth.txt");

  double worst_translation_m = 0.0, worst_angle_deg = 0.0, min_plausible = 1.0, min_valid = 1.0;
  std::size_t accel_samples = 0;
  double accel_norm_sum = 0.0;
  while (const auto frame = source->next()) {
    ASSERT_EQ(frame->image.type(), CV_8UC3);
    ASSERT_EQ(frame->image.size(), cv::Size(640, 480));
    ASSERT_EQ(frame->depth_m.type(), CV_32FC1);
    const DepthStats depth = depth_stats(frame->depth_m);
    min_valid = std::min(min_valid, depth.valid_share);
    min_plausible = std::min(min_plausible, depth.plausible_share);
    EXPECT_GT(depth.median_m, 0.3);
    EXPECT_LT(depth.median_m, 6.0);
    // The pose lies between the motion-capture poses around the frame (100 Hz): close to the nearest.
    ASSERT_TRUE(frame->T_world_cam_gt.has_value());
    const auto nearest = std::min_element(groundtruth.begin(), groundtruth.end(), [&](const auto& a, const auto& b) {
      return std::llabs(a.t_ns - frame->t_ns) < std::llabs(b.t_ns - frame->t_ns);
    });
    EXPECT_LT(std::llabs(nearest->t_ns - frame->t_ns), 10000000);
    worst_translation_m = std::max(worst_translation_m,
                                   (nearest->T_world_body.translation() - frame->T_world_cam_gt->translation()).norm());
    worst_angle_deg = std::max(worst_angle_deg, rotation_angle_deg(nearest->T_world_body, *frame->T_world_cam_gt));
    for (const ImuSample& s : frame->imu) accel_norm_sum += s.accel_mps2.norm();
    accel_samples += frame->imu.size();
  }
  EXPECT_GT(min_valid, 0.5);
  EXPECT_GT(min_plausible, 0.95);
  EXPECT_LT(worst_translation_m, 0.005);
  EXPECT_LT(worst_angle_deg, 1.5);
  ASSERT_GT(accel_samples, 0u);
  const double mean_accel_norm = accel_norm_sum / static_cast<double>(accel_samples);
  EXPECT_NEAR(mean_accel_norm, 9.81, 1.0);  // a hand-held camera: mostly gravity
  std::printf("TUM fr1_rpy: 200 frames, min valid depth share %.3f, min share in [0.3,6] m %.4f, "
              "GT vs nearest pose <= %.4f m / %.3f deg, %zu accelerometer samples, mean |a| %.3f m/s^2\n",
              min_valid, min_plausible, worst_translation_m, worst_angle_deg, accel_samples, mean_accel_norm);
}

TEST(RealDataTum, AssociationMatchesTheBenchmarkRule) {
  SKIP_WITHOUT(kTum);
  DatasetConfig config;
  config.load_images = false;
  const auto source = open_dataset(kTum, DatasetFormat::kTumRgbd, config, null_logger());
  const auto first = source->next();
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(first->t_ns, *parse_seconds("1305031229.528748"));
  EXPECT_EQ(first->image_path, (kTum / "rgb" / "1305031229.528748.png").string());
}

TEST(RealDataEuroc, MicroExcerptIsStereoInertialWithSkippedRowsAndGroundTruth) {
  SKIP_WITHOUT(kEuroc);
  DatasetConfig config;
  config.groundtruth_file = (kEuroc / "groundtruth_leftcam_tum.txt").string();
  const auto source = open_dataset(kEuroc, std::nullopt, config, null_logger());
  const DatasetInfo& info = source->info();
  EXPECT_EQ(info.format, DatasetFormat::kEuroc);
  ASSERT_EQ(source->size(), 95u);
  ASSERT_EQ(info.skipped.size(), 4u);
  for (const SkippedRow& row : info.skipped) EXPECT_NE(row.where.find("cam1/data.csv:"), std::string::npos);
  EXPECT_EQ(info.frames_with_groundtruth, 74u);
  EXPECT_NEAR(info.imu_rate_hz, 200.0, 0.5);
  EXPECT_NEAR(info.rate_hz(), 20.0, 0.01);

  const SensorRig& rig = source->rig();
  EXPECT_EQ(rig.mode, SensorMode::kStereoInertial);
  EXPECT_DOUBLE_EQ(rig.cam0.fx(), 458.654);
  EXPECT_DOUBLE_EQ(rig.cam0.cy(), 248.375);
  EXPECT_DOUBLE_EQ(rig.cam0.distortion().k1, -0.28340811);
  ASSERT_TRUE(rig.cam1.has_value());
  EXPECT_DOUBLE_EQ(rig.cam1->cx(), 379.999);
  EXPECT_DOUBLE_EQ(rig.cam1->distortion().p2, -3.55590700e-05);
  ASSERT_TRUE(rig.T_body_cam0.has_value());
  EXPECT_NEAR(rig.T_body_cam0->translation().x(), -0.0216401454975, 1e-12);
  // ORB-SLAM3's Stereo-Inertial_EuRoC.yaml gives T_c1_c2 translation (0.110074, -0.000157, 0.000889).
  EXPECT_NEAR(rig.T_cam0_cam1.translation().x(), 0.110074137800478, 1e-6);
  EXPECT_NEAR(rig.T_cam0_cam1.translation().y(), -0.000156612054392, 1e-6);
  EXPECT_NEAR(rig.T_cam0_cam1.translation().z(), 0.000889382785432, 1e-6);
  EXPECT_NEAR(rig.T_cam0_cam1.linear()(0, 1), -0.002317135723275, 1e-6);
  ASSERT_TRUE(rig.imu.has_value());
  EXPECT_DOUBLE_EQ(rig.imu->gyro_noise_density, 1.6968e-04);
  EXPECT_DOUBLE_EQ(rig.imu->accel_random_walk, 3.0e-3);

  const Trajectory groundtruth = read_trajectory(kEuroc / "groundtruth_leftcam_tum.txt");
  std::size_t index = 0, imu_total = 0, min_imu = 1000, max_imu = 0;
  while (const auto frame = source->next()) {
    SCOPED_TRACE(index);
    ASSERT_EQ(frame->image.type(), CV_8UC1);
    ASSERT_EQ(frame->image.size(), cv::Size(752, 480));
    ASSERT_TRUE(frame->is_stereo());
    if (index > 0) {
      min_imu = std::min(min_imu, frame->imu.size());
      max_imu = std::max(max_imu, frame->imu.size());
    }
    for (const ImuSample& s : frame->imu) EXPECT_LE(s.t_ns, frame->t_ns);
    imu_total += frame->imu.size();
    EXPECT_EQ(frame->T_world_cam_gt.has_value(), index >= 21);
    if (frame->T_world_cam_gt) {
      const auto match = std::find_if(groundtruth.begin(), groundtruth.end(),
                                      [&](const StampedPose& p) { return p.t_ns == frame->t_ns; });
      ASSERT_NE(match, groundtruth.end());
      EXPECT_TRUE(match->T_world_body.isApprox(*frame->T_world_cam_gt, 1e-12));
    }
    ++index;
  }
  EXPECT_EQ(index, 95u);
  EXPECT_GE(min_imu, 9u);
  EXPECT_LE(max_imu, 11u);
  std::printf("EuRoC micro: 95 stereo frames, %zu IMU samples attached (%zu..%zu per frame after the first), "
              "74 frames with ground truth\n", imu_total, min_imu, max_imu);
}

TEST(RealDataEuroc, WithoutAGroundTruthFileThereIsNone) {
  SKIP_WITHOUT(kEuroc);
  DatasetConfig config;
  config.load_images = false;
  const auto source = open_euroc(kEuroc, DatasetFormat::kEuroc, config, null_logger());
  EXPECT_EQ(source->info().frames_with_groundtruth, 0u);
  EXPECT_TRUE(source->info().groundtruth_file.empty());
}

}  // namespace
}  // namespace fleetslam::core
