#include "fleetslam/core/stereo_rectify.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace fleetslam::core {
namespace {

constexpr double kMinBaselineM = 1e-6;
constexpr double kRigidTolerance = 1e-6;

void require(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument("stereo rectification: " + message);
}

cv::Matx33d to_cv(const Eigen::Matrix3d& m) {
  cv::Matx33d out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out(r, c) = m(r, c);
  }
  return out;
}

Eigen::Matrix3d to_eigen(const cv::Mat& m) {
  Eigen::Matrix3d out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out(r, c) = m.at<double>(r, c);
  }
  return out;
}

// OpenCV's coefficients: k1 k2 p1 p2 k3 (radial-tangential) or k1 k2 k3 k4 (cv::fisheye).
cv::Mat distortion_coefficients(const PinholeCamera& camera) {
  const Distortion& d = camera.distortion();
  if (d.is_equidistant()) return (cv::Mat_<double>(4, 1) << d.k1, d.k2, d.k3, d.k4);
  return (cv::Mat_<double>(5, 1) << d.k1, d.k2, d.p1, d.p2, d.k3);
}

void validate_pair(const PinholeCamera& cam0, const PinholeCamera& cam1, const Eigen::Isometry3d& T_cam0_cam1) {
  require(cam0.width() == cam1.width() && cam0.height() == cam1.height(),
          "both cameras must have the same image size, got " + std::to_string(cam0.width()) + "x" +
              std::to_string(cam0.height()) + " and " + std::to_string(cam1.width()) + "x" +
              std::to_string(cam1.height()));
  const Eigen::Matrix3d R = T_cam0_cam1.linear();
  const double orthogonality_error = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  require(T_cam0_cam1.matrix().allFinite() && orthogonality_error < kRigidTolerance && R.determinant() > 0.0,
          "T_cam0_cam1 is not a rigid transformation");
  const Eigen::Vector3d t = T_cam0_cam1.translation();
  require(t.norm() >= kMinBaselineM, "baseline is zero (cam1 sits on cam0)");
  require(std::abs(t.x()) > std::abs(t.y()) && std::abs(t.x()) > std::abs(t.z()),
          "the cameras are not side by side along x (baseline in cam0: " + std::to_string(t.x()) + ", " +
              std::to_string(t.y()) + ", " + std::to_string(t.z()) + " m)");
  require(t.x() > 0.0, "cam1 must lie on the +x (right) side of cam0; swap the cameras");
}

// Whether every entry of a remap table lies inside the image (so that remap reads no border).
bool inside(const cv::Mat& map_x, const cv::Mat& map_y, const cv::Size& size) {
  double min_x = 0.0, max_x = 0.0, min_y = 0.0, max_y = 0.0;
  cv::minMaxLoc(map_x, &min_x, &max_x);
  cv::minMaxLoc(map_y, &min_y, &max_y);
  return cv::checkRange(map_x) && cv::checkRange(map_y) && min_x >= 0.0 && max_x <= size.width - 1.0 &&
         min_y >= 0.0 && max_y <= size.height - 1.0;
}

constexpr int kMaxNarrowings = 60;  // 0.95^60: a twentieth of the field of view
constexpr double kNarrowing = 0.95;

}  // namespace

Eigen::Isometry3d StereoRectification::T_cam0_rect0() const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R_rect0_cam0.transpose();
  return T;
}

Eigen::Isometry3d StereoRectification::T_rect0_rect1() const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(rig.baseline_m, 0.0, 0.0);
  return T;
}

StereoRectification compute_stereo_rectification(const PinholeCamera& cam0, const PinholeCamera& cam1,
                                                 const Eigen::Isometry3d& T_cam0_cam1) {
  validate_pair(cam0, cam1, T_cam0_cam1);
  require(cam0.distortion().model == cam1.distortion().model,
          "both cameras must use the same distortion model, got " + std::string(to_string(cam0.distortion().model)) +
              " and " + to_string(cam1.distortion().model));
  const bool fisheye = cam0.distortion().is_equidistant();
  // OpenCV wants the transform taking cam0 points into cam1: p_cam1 = R p_cam0 + T.
  const Eigen::Isometry3d T_cam1_cam0 = T_cam0_cam1.inverse();
  const cv::Matx33d R = to_cv(T_cam1_cam0.linear());
  const Eigen::Vector3d t = T_cam1_cam0.translation();
  const cv::Vec3d T(t.x(), t.y(), t.z());
  const cv::Size size(cam0.width(), cam0.height());

  cv::Mat R1, R2, P1, P2, Q;
  StereoRectification out;
  const auto maps = [&](const PinholeCamera& camera, const cv::Mat& R_rect, const cv::Mat& P, cv::Mat& map_x,
                         cv::Mat& map_y) {
    if (fisheye) {
      cv::fisheye::initUndistortRectifyMap(to_cv(camera.K()), distortion_coefficients(camera), R_rect, P, size,
                                           CV_32FC1, map_x, map_y);
    } else {
      cv::initUndistortRectifyMap(to_cv(camera.K()), distortion_coefficients(camera), R_rect, P, size, CV_32FC1,
                                  map_x, map_y);
    }
  };
  if (fisheye) {
    // cv::fisheye's own choice (balance 0) squeezes most of the fisheye view into the image: on TUM-VI a
    // focal length of 63 px for lenses of 190 px, so a third of the resolution at the centre and a third of
    // the disparity (3 px at 2 m), and corners that can still lie outside the images (black corners, whose
    // edges would give features of their own). The rectified view keeps the lenses' focal length instead
    // (fov_scale, the divisor of cv::fisheye's focal length; about 107 degrees across on TUM-VI), and is
    // narrowed further until every rectified pixel of both images comes from inside them, as alpha 0
    // gives for radial-tangential pairs.
    cv::fisheye::stereoRectify(to_cv(cam0.K()), distortion_coefficients(cam0), to_cv(cam1.K()),
                               distortion_coefficients(cam1), size, R, T, R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY,
                               size, 0.0, 1.0);
    const double lens_focal = 0.25 * (cam0.fx() + cam0.fy() + cam1.fx() + cam1.fy());
    double fov_scale = std::min(1.0, P1.at<double>(0, 0) / lens_focal);
    for (int attempt = 0;; ++attempt) {
      cv::fisheye::stereoRectify(to_cv(cam0.K()), distortion_coefficients(cam0), to_cv(cam1.K()),
                                 distortion_coefficients(cam1), size, R, T, R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY,
                                 size, 0.0, fov_scale);
      maps(cam0, R1, P1, out.map0_x, out.map0_y);
      maps(cam1, R2, P2, out.map1_x, out.map1_y);
      if (inside(out.map0_x, out.map0_y, size) && inside(out.map1_x, out.map1_y, size)) break;
      require(attempt < kMaxNarrowings, "no rectified view of the fisheye pair lies inside both images");
      fov_scale *= kNarrowing;
    }
  } else {
    cv::stereoRectify(to_cv(cam0.K()), distortion_coefficients(cam0), to_cv(cam1.K()),
                      distortion_coefficients(cam1), size, R, T, R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY, 0.0);
    maps(cam0, R1, P1, out.map0_x, out.map0_y);
    maps(cam1, R2, P2, out.map1_x, out.map1_y);
  }

  out.raw0 = cam0;
  out.raw1 = cam1;
  out.R_rect0_cam0 = to_eigen(R1);
  out.R_rect1_cam1 = to_eigen(R2);
  // P1 = [f 0 cx 0; 0 f cy 0; 0 0 1 0], P2 = P1 with P2(0,3) = -f * baseline for a right camera at +x.
  const double f = P1.at<double>(0, 0);
  out.rig.camera = PinholeCamera(cam0.width(), cam0.height(), f, P1.at<double>(1, 1), P1.at<double>(0, 2),
                                 P1.at<double>(1, 2));
  out.rig.baseline_m = -P2.at<double>(0, 3) / P2.at<double>(0, 0);
  require(out.rig.baseline_m > 0.0, "OpenCV returned a non-positive rectified baseline");
  return out;
}

std::optional<Eigen::Vector2d> rectify_pixel(const StereoRectification& rectification, int camera_index,
                                             const Eigen::Vector2d& uv_raw) {
  if (camera_index != 0 && camera_index != 1) {
    throw std::invalid_argument("rectify_pixel: camera_index must be 0 or 1, got " +
                                std::to_string(camera_index));
  }
  const PinholeCamera& raw = camera_index == 0 ? rectification.raw0 : rectification.raw1;
  const Eigen::Matrix3d& R_rect_cam = camera_index == 0 ? rectification.R_rect0_cam0 : rectification.R_rect1_cam1;
  const std::optional<Eigen::Vector3d> ray_cam = raw.unproject(uv_raw);
  if (!ray_cam) return std::nullopt;
  // Both rectified images share K (CALIB_ZERO_DISPARITY). P2's fourth column only shifts points given in
  // the rect0 frame; a ray already in its own rectified frame projects with K alone.
  return rectification.rig.camera.project(R_rect_cam * *ray_cam);
}

std::pair<cv::Mat, cv::Mat> rectify_images(const StereoRectification& rectification, const cv::Mat& raw0,
                                           const cv::Mat& raw1) {
  const auto check = [](const cv::Mat& image, const PinholeCamera& camera, const char* name) {
    if (image.empty() || image.cols != camera.width() || image.rows != camera.height()) {
      throw std::invalid_argument(std::string("rectify_images: ") + name + " image is " +
                                  std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                                  ", the raw camera is " + std::to_string(camera.width()) + "x" +
                                  std::to_string(camera.height()));
    }
  };
  check(raw0, rectification.raw0, "left");
  check(raw1, rectification.raw1, "right");
  std::pair<cv::Mat, cv::Mat> out;
  cv::remap(raw0, out.first, rectification.map0_x, rectification.map0_y, cv::INTER_LINEAR,
            cv::BORDER_CONSTANT, cv::Scalar::all(0));
  cv::remap(raw1, out.second, rectification.map1_x, rectification.map1_y, cv::INTER_LINEAR,
            cv::BORDER_CONSTANT, cv::Scalar::all(0));
  return out;
}

}  // namespace fleetslam::core
