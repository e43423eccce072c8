#pragma once
// Camera models as value types. Pixel coordinates follow OpenCV: (0,0) is the centre of the top-left
// pixel, u to the right, v down; the camera frame has z forward, x right, y down.

#include <cstdint>
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <vector>

namespace fleetslam::core {

enum class DistortionModel {
  kRadialTangential,  // OpenCV's "plumb bob" (EuRoC's radial-tangential, ORB-SLAM's PinHole)
  kEquidistant,       // Kannala-Brandt / OpenCV fisheye (TUM-VI's equidistant, ORB-SLAM's KannalaBrandt8)
};

// Lens distortion on normalised coordinates x = X / Z:
//  - radial-tangential: x_d = x (1 + k1 r^2 + k2 r^4 + k3 r^6) + tangential terms in p1, p2 (OpenCV order
//    k1 k2 p1 p2 k3); all zero is no distortion;
//  - equidistant: with r = |x| and theta = atan(r), x_d = x theta_d / r where
//    theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8) (cv::fisheye); p1 and p2 unused.
//    Even with all coefficients zero it is a fisheye (r_d = theta), not a pinhole.
struct Distortion {
  double k1 = 0.0;
  double k2 = 0.0;
  double p1 = 0.0;
  double p2 = 0.0;
  double k3 = 0.0;
  double k4 = 0.0;  // equidistant only
  DistortionModel model = DistortionModel::kRadialTangential;

  static Distortion equidistant(double k1, double k2, double k3, double k4) {
    Distortion d;
    d.k1 = k1;
    d.k2 = k2;
    d.k3 = k3;
    d.k4 = k4;
    d.model = DistortionModel::kEquidistant;
    return d;
  }
  bool is_equidistant() const { return model == DistortionModel::kEquidistant; }
  // No distortion at all: the plain pinhole.
  bool is_zero() const {
    return model == DistortionModel::kRadialTangential && k1 == 0.0 && k2 == 0.0 && p1 == 0.0 && p2 == 0.0 &&
           k3 == 0.0;
  }
};

// "radial-tangential" or "equidistant" (EuRoC / TUM-VI sensor.yaml names).
const char* to_string(DistortionModel model);

// Pinhole camera with lens distortion (radial-tangential or equidistant). Points are projected from
// the half-space in front of the camera (z > 0): a fisheye's view beyond 90 degrees is not modelled.
class PinholeCamera {
 public:
  PinholeCamera() = default;
  // Throws std::invalid_argument on non-positive size or focal length, or non-finite values.
  PinholeCamera(int width, int height, double fx, double fy, double cx, double cy, Distortion distortion = {});

  int width() const { return width_; }
  int height() const { return height_; }
  double fx() const { return fx_; }
  double fy() const { return fy_; }
  double cx() const { return cx_; }
  double cy() const { return cy_; }
  const Distortion& distortion() const { return distortion_; }
  Eigen::Matrix3d K() const;
  // Same intrinsics without distortion (the ideal camera undistorted points live in).
  PinholeCamera undistorted() const;
  // Intrinsics for this image resized by s with cv::resize (pyramid levels, reduced resolution).
  // The new size is round(width * s) x round(height * s); intrinsics follow the effective per-axis
  // ratios new_width / width and new_height / height and OpenCV's pixel-centre convention
  // (u' = (u + 0.5) r - 0.5), so a point projects onto the same image content. Throws
  // std::invalid_argument when s is not positive and finite or the new size would be empty.
  PinholeCamera scaled(double s) const;

  // Camera-frame point -> distorted pixel. nullopt when z <= min_depth (behind or on the camera plane) or
  // where distort() folds over (det of its Jacobian <= 0), as undistort_normalized refuses those points.
  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& p_cam) const;
  // Same, with the 2x3 Jacobian d(uv)/d(p_cam) when J is not null. Returns false where the other does not
  // project.
  bool project(const Eigen::Vector3d& p_cam, Eigen::Vector2d* uv, Eigen::Matrix<double, 2, 3>* J) const;

  // Distorted pixel -> point on the z = 1 plane (iterative undistortion). nullopt when it does not converge.
  std::optional<Eigen::Vector3d> unproject(const Eigen::Vector2d& uv) const;
  // Distorted pixel and depth along z -> camera-frame point. nullopt also for depth_m <= 0 or non-finite.
  std::optional<Eigen::Vector3d> unproject(const Eigen::Vector2d& uv, double depth_m) const;

  // Normalised undistorted -> normalised distorted coordinates, with the 2x2 Jacobian when J is not null.
  Eigen::Vector2d distort(const Eigen::Vector2d& xn, Eigen::Matrix2d* J = nullptr) const;
  // Inverse of distort (radial-tangential: Newton with step halving, from xn = xd; equidistant: Newton on
  // the angle, nullopt from 90 degrees on); nullopt when it does not converge within
  // undistort_max_iterations to undistort_tolerance, or converges where distort() folds over
  // (det of its Jacobian <= 0: beyond the calibrated region of strong radial distortion).
  std::optional<Eigen::Vector2d> undistort_normalized(const Eigen::Vector2d& xd) const;
  // Distorted pixels -> pixels of the undistorted() camera. Points that do not converge become NaN.
  std::vector<Eigen::Vector2d> undistort_points(const std::vector<Eigen::Vector2d>& uv) const;

  // True when uv lies in the image shrunk by border_px on every side. With pixel centres at integers,
  // the image covers [-0.5, width - 0.5) x [-0.5, height - 0.5). False for NaN.
  bool in_image(const Eigen::Vector2d& uv, double border_px = 0.0) const;

  static constexpr double min_depth = 1e-6;
  // Undistortion stops when |distort(xn) - xd| (normalised units) is below the tolerance: 1e-12 times
  // fx ~ 500 is ~1e-9 px, far below any feature's noise.
  static constexpr int undistort_max_iterations = 30;
  static constexpr double undistort_tolerance = 1e-12;

 private:
  Eigen::Vector2d distort_equidistant(const Eigen::Vector2d& xn, Eigen::Matrix2d* J) const;
  std::optional<Eigen::Vector2d> undistort_equidistant(const Eigen::Vector2d& xd) const;

  int width_ = 0;
  int height_ = 0;
  double fx_ = 1.0;
  double fy_ = 1.0;
  double cx_ = 0.0;
  double cy_ = 0.0;
  Distortion distortion_;
};

// Rectified stereo rig: both images share the (distortion-free) intrinsics `camera`; the right camera
// sits baseline_m along +x of the left one.
struct StereoRig {
  PinholeCamera camera;
  double baseline_m = 0.0;

  double bf() const { return baseline_m * camera.fx(); }
  // Disparity (u_left - u_right) in pixels -> depth in metres; nullopt for disparity <= 0.
  // Both conversions require baseline_m > 0 (a FLEETSLAM_CHECK).
  std::optional<double> depth_from_disparity(double disparity_px) const;
  // Depth in metres -> disparity in pixels; nullopt for depth <= 0.
  std::optional<double> disparity_from_depth(double depth_m) const;
  // Right-image u coordinate of a left-image u at a given depth ("virtual right" for RGB-D).
  double right_u(double u_left, double depth_m) const { return u_left - bf() / depth_m; }
};

// RGB-D camera: the colour camera, how raw depth maps to metres, and the virtual baseline
// (ORB-SLAM's Camera.bf) used to give depth measurements a stereo-like uncertainty.
struct RgbdCamera {
  PinholeCamera camera;
  double depth_scale = 5000.0;  // raw depth units per metre (TUM: 5000, metres = raw / 5000)
  double bf = 40.0;             // virtual baseline times fx, pixel*metres
  double min_depth_m = 0.1;
  double max_depth_m = 10.0;

  // Raw 16-bit depth -> metres; 0 (no measurement) or out-of-range values give 0.
  double depth_m_from_raw(std::uint16_t raw) const;
};

}  // namespace fleetslam::core
