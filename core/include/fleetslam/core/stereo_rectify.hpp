#pragma once
// Stereo rectification of a raw (distorted, non-parallel) camera pair into a StereoRig: both rectified
// images share distortion-free intrinsics, their rows are epipolar lines, and the right camera sits
// baseline_m along +x of the left one. Computed once per rig with OpenCV (cv::stereoRectify with
// alpha = 0, so every rectified pixel sees valid raw data, and CALIB_ZERO_DISPARITY, so both images
// share cx), plus the remap tables that produce rectified images from raw ones.
//
// Frames: cam0/cam1 are the raw cameras, rect0/rect1 the rectified ones. Rectification only rotates
// each camera about its centre, so a pose of the left camera maps as
//   T_world_rect0 = T_world_cam0 * T_cam0_rect0, with T_cam0_rect0.linear() = R_rect0_cam0^T,
// and p_rect0 = R_rect0_cam0 * p_cam0.

#include <optional>
#include <utility>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>

#include "fleetslam/core/camera.hpp"

namespace fleetslam::core {

struct StereoRectification {
  StereoRig rig;                                             // rectified intrinsics (no distortion), baseline
  Eigen::Matrix3d R_rect0_cam0 = Eigen::Matrix3d::Identity();  // rotates raw left points into rectified left
  Eigen::Matrix3d R_rect1_cam1 = Eigen::Matrix3d::Identity();  // rotates raw right points into rectified right
  PinholeCamera raw0;                                        // the raw cameras the tables were built for
  PinholeCamera raw1;
  // Remap tables (CV_32FC1, rectified image size): rectified pixel (u, v) samples the raw image at
  // (map_x(v, u), map_y(v, u)). Single-precision tables keep cv::remap's result exact to ~1e-4 px.
  cv::Mat map0_x, map0_y;
  cv::Mat map1_x, map1_y;

  // Pose of the rectified left camera in the raw left camera frame (a pure rotation).
  Eigen::Isometry3d T_cam0_rect0() const;
  // Pose of the rectified right camera in the rectified left camera frame: (baseline_m, 0, 0).
  Eigen::Isometry3d T_rect0_rect1() const;
};

// Builds the rectification of two raw cameras with T_cam0_cam1 the pose of cam1 in the cam0 frame.
// Throws std::invalid_argument when the cameras differ in image size, the baseline is (near) zero
// (< 1e-6 m), the pair is not side by side (|y| or |z| of the baseline not below |x|: a vertical pair
// cannot become a StereoRig), cam1 is not on the +x side of cam0 (swap the cameras), or the pose
// is not rigid.
StereoRectification compute_stereo_rectification(const PinholeCamera& cam0, const PinholeCamera& cam1,
                                                 const Eigen::Isometry3d& T_cam0_cam1);

// Raw pixel of camera 0 or 1 -> pixel of the rectified image (undistort, rotate, project with the
// rectified intrinsics). nullopt when undistortion fails or the point falls behind the rectified camera.
std::optional<Eigen::Vector2d> rectify_pixel(const StereoRectification& rectification, int camera_index,
                                             const Eigen::Vector2d& uv_raw);

// Rectified left and right images from raw ones (cv::remap, bilinear, black outside).
// Throws std::invalid_argument when an image is empty or its size differs from the raw camera's.
std::pair<cv::Mat, cv::Mat> rectify_images(const StereoRectification& rectification, const cv::Mat& raw0,
                                           const cv::Mat& raw1);

}  // namespace fleetslam::core
