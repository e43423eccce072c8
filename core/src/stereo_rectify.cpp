#include "fleetslam/core/stereo_rectify.hpp"

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

cv::Matx<double, 5, 1> distortion_coefficients(const PinholeCamera& camera) {
  const RadTan& d = camera.distortion();
  return {d.k1, d.k2, d.p1, d.p2, d.k3};  // OpenCV's order
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
  // OpenCV wants the transform taking cam0 points into cam1: p_cam1 = R p_cam0 + T.
  const Eigen::Isometry3d T_cam1_cam0 = T_cam0_cam1.inverse();
  const cv::Matx33d R = to_cv(T_cam1_cam0.linear());
  const Eigen::Vector3d t = T_cam1_cam0.translation();
  const cv::Vec3d T(t.x(), t.y(), t.z());
  const cv::Size size(cam0.width(), cam0.height());

  cv::Mat R1, R2, P1, P2, Q;
  cv::stereoRectify(to_cv(cam0.K()), distortion_coefficients(cam0), to_cv(cam1.K()),
                    distortion_coefficients(cam1), size, R, T, R1, R2, P1, P2, Q,
                    cv::CALIB_ZERO_DISPARITY, 0.0);

  StereoRectification out;
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

  cv::initUndistortRectifyMap(to_cv(cam0.K()), distortion_coefficients(cam0), R1, P1, size, CV_32FC1,
                              out.map0_x, out.map0_y);
  cv::initUndistortRectifyMap(to_cv(cam1.K()), distortion_coefficients(cam1), R2, P2, size, CV_32FC1,
                              out.map1_x, out.map1_y);
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
