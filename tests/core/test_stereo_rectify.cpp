// Stereo rectification of synthetic raw rigs: points seen by both raw cameras land on one row of the
// rectified pair and their disparity gives their depth back; the remap tables agree with the point
// mapping; bad rigs are rejected.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "fleetslam/core/camera.hpp"
#include "fleetslam/core/se3.hpp"
#include "fleetslam/core/stereo_rectify.hpp"

namespace fleetslam::core {
namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

struct RawRig {
  const char* name;
  PinholeCamera cam0;
  PinholeCamera cam1;
  Eigen::Isometry3d T_cam0_cam1;
};

// EuRoC's calibration (ORB-SLAM3 Stereo-Inertial_EuRoC.yaml): nearly parallel cameras.
RawRig euroc_rig() {
  Eigen::Matrix4d M;
  M << 0.999997256477797, -0.002317135723275, -0.000343393120620, 0.110074137800478,
       0.002312067192432, 0.999898048507103, -0.014090668452683, -0.000156612054392,
       0.000376008102320, 0.014089835846691, 0.999900662638081, 0.000889382785432,
       0, 0, 0, 1;
  return {"euroc",
          PinholeCamera(752, 480, 458.654, 457.296, 367.215, 248.375,
                        Distortion{-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.0}),
          PinholeCamera(752, 480, 457.587, 456.134, 379.999, 255.238,
                        Distortion{-0.28368365, 0.07451284, -0.00010473, -3.55590700e-05, 0.0}),
          normalized(Eigen::Isometry3d(M))};
}

// A deliberately misaligned pair: cam1 toed in by 4 degrees, rolled by 2, and offset in y and z.
RawRig skewed_rig() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = so3_exp(Eigen::Vector3d(1.0 * kDegToRad, -4.0 * kDegToRad, 2.0 * kDegToRad));
  T.translation() = Eigen::Vector3d(0.12, 0.006, -0.004);
  return {"skewed",
          PinholeCamera(640, 480, 520.0, 518.0, 322.0, 241.0, Distortion{0.1, -0.25, 0.001, -0.0005, 0.05}),
          PinholeCamera(640, 480, 505.0, 507.0, 315.0, 236.0, Distortion{-0.2, 0.05, 0.0, 0.001, 0.0}), T};
}

// TUM-VI's fisheye pair (equidistant model), 10 cm apart, slightly rotated.
RawRig tumvi_rig() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = so3_exp(Eigen::Vector3d(0.4 * kDegToRad, 0.3 * kDegToRad, -0.2 * kDegToRad));
  T.translation() = Eigen::Vector3d(0.101, -0.0019, -0.0010);
  return {"tumvi",
          PinholeCamera(512, 512, 190.97847715128717, 190.9733070521226, 254.93170605935475, 256.8974428996504,
                        Distortion::equidistant(0.0034823894022493434, 0.0007150348452162257,
                                                -0.0020532361418706202, 0.00020293673591811182)),
          PinholeCamera(512, 512, 190.44236969414825, 190.4344384721956, 252.59949716835982, 254.91723064636983,
                        Distortion::equidistant(0.0034003170790442797, 0.001766278153469831, -0.00266312569781606,
                                                0.0003299517423931039)),
          T};
}

std::vector<RawRig> rigs() { return {euroc_rig(), skewed_rig(), tumvi_rig()}; }

// Points in the cam0 frame, 0.5 to 15 m away, that project inside both raw images.
std::vector<Eigen::Vector3d> points_seen_by_both(const RawRig& rig, int count, unsigned seed) {
  std::mt19937 engine(seed);
  std::uniform_real_distribution<double> lateral(-0.7, 0.7);
  std::uniform_real_distribution<double> depth(0.5, 15.0);
  const Eigen::Isometry3d T_cam1_cam0 = rig.T_cam0_cam1.inverse();
  std::vector<Eigen::Vector3d> points;
  while (static_cast<int>(points.size()) < count) {
    const double z = depth(engine);
    const Eigen::Vector3d p(lateral(engine) * z, lateral(engine) * z * 0.6, z);
    const auto uv0 = rig.cam0.project(p);
    const auto uv1 = rig.cam1.project(T_cam1_cam0 * p);
    if (uv0 && uv1 && rig.cam0.in_image(*uv0, 20.0) && rig.cam1.in_image(*uv1, 20.0)) points.push_back(p);
  }
  return points;
}

TEST(StereoRectify, PointsLandOnOneRowAndDisparityGivesDepth) {
  for (const RawRig& raw : rigs()) {
    const StereoRectification rect = compute_stereo_rectification(raw.cam0, raw.cam1, raw.T_cam0_cam1);
    EXPECT_TRUE(rect.rig.camera.distortion().is_zero());
    EXPECT_NEAR(rect.rig.baseline_m, raw.T_cam0_cam1.translation().norm(), 1e-9) << raw.name;
    const Eigen::Isometry3d T_cam1_cam0 = raw.T_cam0_cam1.inverse();
    int checked = 0;
    for (const Eigen::Vector3d& p_cam0 : points_seen_by_both(raw, 300, 31)) {
      const auto left = rectify_pixel(rect, 0, *raw.cam0.project(p_cam0));
      const auto right = rectify_pixel(rect, 1, *raw.cam1.project(T_cam1_cam0 * p_cam0));
      ASSERT_TRUE(left && right) << raw.name;
      EXPECT_NEAR(left->y(), right->y(), 1e-6) << raw.name << " point " << p_cam0.transpose();
      const double depth_rect_m = (rect.R_rect0_cam0 * p_cam0).z();
      const std::optional<double> depth_m = rect.rig.depth_from_disparity(left->x() - right->x());
      ASSERT_TRUE(depth_m.has_value()) << raw.name;
      EXPECT_NEAR(*depth_m, depth_rect_m, 1e-7 * depth_rect_m) << raw.name;
      // And the rectified left pixel is the point's projection with the rectified intrinsics.
      EXPECT_LT((*left - *rect.rig.camera.project(rect.R_rect0_cam0 * p_cam0)).norm(), 1e-6);
      ++checked;
    }
    EXPECT_EQ(checked, 300);
  }
}

TEST(StereoRectify, RectifiedCamerasDifferOnlyByTheBaseline) {
  for (const RawRig& raw : rigs()) {
    const StereoRectification rect = compute_stereo_rectification(raw.cam0, raw.cam1, raw.T_cam0_cam1);
    Eigen::Isometry3d T_cam1_rect1 = Eigen::Isometry3d::Identity();
    T_cam1_rect1.linear() = rect.R_rect1_cam1.transpose();
    const Eigen::Isometry3d T_rect0_rect1 = rect.T_cam0_rect0().inverse() * raw.T_cam0_cam1 * T_cam1_rect1;
    EXPECT_LT((T_rect0_rect1.matrix() - rect.T_rect0_rect1().matrix()).cwiseAbs().maxCoeff(), 1e-9) << raw.name;
    for (const Eigen::Matrix3d& R : {rect.R_rect0_cam0, rect.R_rect1_cam1}) {
      EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
      EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
    }
  }
}

TEST(StereoRectify, RemapTablesAgreeWithThePointMapping) {
  for (const RawRig& raw : rigs()) {
    const StereoRectification rect = compute_stereo_rectification(raw.cam0, raw.cam1, raw.T_cam0_cam1);
    ASSERT_EQ(rect.map0_x.type(), CV_32FC1);
    ASSERT_EQ(rect.map0_x.cols, raw.cam0.width());
    ASSERT_EQ(rect.map1_y.rows, raw.cam1.height());
    for (int camera = 0; camera < 2; ++camera) {
      const cv::Mat& map_x = camera == 0 ? rect.map0_x : rect.map1_x;
      const cv::Mat& map_y = camera == 0 ? rect.map0_y : rect.map1_y;
      for (int v = 0; v < map_x.rows; v += 23) {
        for (int u = 0; u < map_x.cols; u += 23) {
          // The table says rectified (u, v) samples raw (x, y); mapping (x, y) forward must give (u, v).
          const Eigen::Vector2d uv_raw(map_x.at<float>(v, u), map_y.at<float>(v, u));
          const auto uv_rect = rectify_pixel(rect, camera, uv_raw);
          ASSERT_TRUE(uv_rect.has_value());
          EXPECT_LT((*uv_rect - Eigen::Vector2d(u, v)).norm(), 2e-3) << raw.name << " camera " << camera;
        }
      }
    }
  }
}

TEST(StereoRectify, AlphaZeroKeepsOnlyValidPixels) {
  for (const RawRig& raw : rigs()) {
    const StereoRectification rect = compute_stereo_rectification(raw.cam0, raw.cam1, raw.T_cam0_cam1);
    const cv::Mat gray0(raw.cam0.height(), raw.cam0.width(), CV_8UC1, cv::Scalar(200));
    const cv::Mat gray1(raw.cam1.height(), raw.cam1.width(), CV_8UC1, cv::Scalar(200));
    const auto [left, right] = rectify_images(rect, gray0, gray1);
    ASSERT_EQ(left.size(), gray0.size());
    // Every rectified pixel comes from inside the raw image (the outermost rows may blend a border).
    const cv::Rect inner(1, 1, left.cols - 2, left.rows - 2);
    EXPECT_EQ(cv::countNonZero(left(inner) != 200), 0) << raw.name;
    EXPECT_EQ(cv::countNonZero(right(inner) != 200), 0) << raw.name;
  }
}

// Intensity-weighted centroid of a window around `centre`.
Eigen::Vector2d centroid(const cv::Mat& image, const Eigen::Vector2d& centre, int radius) {
  double sum = 0.0;
  Eigen::Vector2d weighted = Eigen::Vector2d::Zero();
  const int u0 = static_cast<int>(std::lround(centre.x()));
  const int v0 = static_cast<int>(std::lround(centre.y()));
  for (int v = v0 - radius; v <= v0 + radius; ++v) {
    for (int u = u0 - radius; u <= u0 + radius; ++u) {
      const double w = image.at<float>(v, u);
      sum += w;
      weighted += w * Eigen::Vector2d(u, v);
    }
  }
  return weighted / sum;
}

cv::Mat blob_image(const PinholeCamera& camera, const Eigen::Vector2d& uv, double sigma_px) {
  cv::Mat image(camera.height(), camera.width(), CV_32FC1, cv::Scalar(0.0f));
  for (int v = 0; v < image.rows; ++v) {
    for (int u = 0; u < image.cols; ++u) {
      const double r2 = (Eigen::Vector2d(u, v) - uv).squaredNorm();
      image.at<float>(v, u) = static_cast<float>(std::exp(-0.5 * r2 / (sigma_px * sigma_px)));
    }
  }
  return image;
}

TEST(StereoRectify, RectifiedImagesShowAPointOnOneRow) {
  const RawRig raw = skewed_rig();
  const StereoRectification rect = compute_stereo_rectification(raw.cam0, raw.cam1, raw.T_cam0_cam1);
  const Eigen::Vector3d p_cam0(0.3, -0.15, 2.0);
  const Eigen::Vector2d uv0 = *raw.cam0.project(p_cam0);
  const Eigen::Vector2d uv1 = *raw.cam1.project(raw.T_cam0_cam1.inverse() * p_cam0);
  const auto [left, right] = rectify_images(rect, blob_image(raw.cam0, uv0, 2.0), blob_image(raw.cam1, uv1, 2.0));
  const Eigen::Vector2d expected_left = *rectify_pixel(rect, 0, uv0);
  const Eigen::Vector2d expected_right = *rectify_pixel(rect, 1, uv1);
  const Eigen::Vector2d seen_left = centroid(left, expected_left, 9);
  const Eigen::Vector2d seen_right = centroid(right, expected_right, 9);
  EXPECT_LT((seen_left - expected_left).norm(), 0.1);
  EXPECT_LT((seen_right - expected_right).norm(), 0.1);
  EXPECT_NEAR(seen_left.y(), seen_right.y(), 0.1);
  const double depth_m = *rect.rig.depth_from_disparity(seen_left.x() - seen_right.x());
  EXPECT_NEAR(depth_m, (rect.R_rect0_cam0 * p_cam0).z(), 0.01);
}

TEST(StereoRectify, RejectsNonsenseRigs) {
  const RawRig raw = euroc_rig();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  EXPECT_THROW(compute_stereo_rectification(raw.cam0, raw.cam1, T), std::invalid_argument);  // zero baseline
  T.translation() = Eigen::Vector3d(0.0, 0.1, 0.0);
  EXPECT_THROW(compute_stereo_rectification(raw.cam0, raw.cam1, T), std::invalid_argument);  // vertical
  T.translation() = Eigen::Vector3d(0.01, 0.0, 0.2);
  EXPECT_THROW(compute_stereo_rectification(raw.cam0, raw.cam1, T), std::invalid_argument);  // forward
  T.translation() = Eigen::Vector3d(-0.1, 0.0, 0.0);
  EXPECT_THROW(compute_stereo_rectification(raw.cam0, raw.cam1, T), std::invalid_argument);  // cam1 on the left
  T.translation() = Eigen::Vector3d(0.1, 0.0, 0.0);
  T.linear() *= 1.01;
  EXPECT_THROW(compute_stereo_rectification(raw.cam0, raw.cam1, T), std::invalid_argument);  // not rigid
  const PinholeCamera small(320, 240, 200, 200, 160, 120);
  EXPECT_THROW(compute_stereo_rectification(raw.cam0, small, raw.T_cam0_cam1), std::invalid_argument);
  try {
    compute_stereo_rectification(raw.cam0, raw.cam1, Eigen::Isometry3d::Identity());
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("baseline"), std::string::npos) << e.what();
  }
}

TEST(StereoRectify, RejectsWrongImagesAndCameraIndex) {
  const RawRig raw = euroc_rig();
  const StereoRectification rect = compute_stereo_rectification(raw.cam0, raw.cam1, raw.T_cam0_cam1);
  const cv::Mat good(raw.cam0.height(), raw.cam0.width(), CV_8UC1, cv::Scalar(0));
  const cv::Mat wrong(100, 100, CV_8UC1, cv::Scalar(0));
  EXPECT_THROW(rectify_images(rect, good, wrong), std::invalid_argument);
  EXPECT_THROW(rectify_images(rect, cv::Mat(), good), std::invalid_argument);
  EXPECT_THROW(rectify_pixel(rect, 2, Eigen::Vector2d(1, 1)), std::invalid_argument);
}

}  // namespace
}  // namespace fleetslam::core
