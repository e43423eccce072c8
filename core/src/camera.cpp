#include "fleetslam/core/camera.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "fleetslam/core/error.hpp"

namespace fleetslam::core {
namespace {

void require(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument("PinholeCamera: " + message);
}

void require_finite(double value, const char* name) {
  require(std::isfinite(value), std::string(name) + " must be finite, got " + std::to_string(value));
}

}  // namespace

PinholeCamera::PinholeCamera(int width, int height, double fx, double fy, double cx, double cy,
                             Distortion distortion)
    : width_(width), height_(height), fx_(fx), fy_(fy), cx_(cx), cy_(cy), distortion_(distortion) {
  require(width > 0 && height > 0, "image size must be positive, got " + std::to_string(width) + "x" +
                                       std::to_string(height));
  require(std::isfinite(fx) && fx > 0.0, "fx must be positive and finite, got " + std::to_string(fx));
  require(std::isfinite(fy) && fy > 0.0, "fy must be positive and finite, got " + std::to_string(fy));
  require_finite(cx, "cx");
  require_finite(cy, "cy");
  require_finite(distortion.k1, "k1");
  require_finite(distortion.k2, "k2");
  require_finite(distortion.p1, "p1");
  require_finite(distortion.p2, "p2");
  require_finite(distortion.k3, "k3");
  require_finite(distortion.k4, "k4");
  require(!distortion.is_equidistant() || (distortion.p1 == 0.0 && distortion.p2 == 0.0),
          "the equidistant model has no tangential terms (p1, p2)");
  require(distortion.is_equidistant() || distortion.k4 == 0.0, "k4 belongs to the equidistant model");
}

const char* to_string(DistortionModel model) {
  return model == DistortionModel::kEquidistant ? "equidistant" : "radial-tangential";
}

Eigen::Matrix3d PinholeCamera::K() const {
  Eigen::Matrix3d K;
  K << fx_, 0.0, cx_,
       0.0, fy_, cy_,
       0.0, 0.0, 1.0;
  return K;
}

PinholeCamera PinholeCamera::undistorted() const {
  return PinholeCamera(width_, height_, fx_, fy_, cx_, cy_);
}

PinholeCamera PinholeCamera::scaled(double s) const {
  if (!(std::isfinite(s) && s > 0.0)) {
    throw std::invalid_argument("PinholeCamera::scaled: scale must be positive and finite, got " +
                                std::to_string(s));
  }
  const long new_width = std::lround(width_ * s);
  const long new_height = std::lround(height_ * s);
  if (new_width < 1 || new_height < 1 || new_width > std::numeric_limits<int>::max() ||
      new_height > std::numeric_limits<int>::max()) {
    throw std::invalid_argument("PinholeCamera::scaled: scale " + std::to_string(s) +
                                " gives an empty or oversized image");
  }
  // cv::resize maps pixel centres by u' = (u + 0.5) r - 0.5 with r the actual size ratio.
  const double rx = static_cast<double>(new_width) / width_;
  const double ry = static_cast<double>(new_height) / height_;
  return PinholeCamera(static_cast<int>(new_width), static_cast<int>(new_height), fx_ * rx, fy_ * ry,
                       (cx_ + 0.5) * rx - 0.5, (cy_ + 0.5) * ry - 0.5, distortion_);
}

std::optional<Eigen::Vector2d> PinholeCamera::project(const Eigen::Vector3d& p_cam) const {
  Eigen::Vector2d uv;
  if (!project(p_cam, &uv, nullptr)) return std::nullopt;
  return uv;
}

bool PinholeCamera::project(const Eigen::Vector3d& p_cam, Eigen::Vector2d* uv,
                            Eigen::Matrix<double, 2, 3>* J) const {
  const double z = p_cam.z();
  if (!(z > min_depth)) return false;  // also rejects NaN
  const double inv_z = 1.0 / z;
  const Eigen::Vector2d xn(p_cam.x() * inv_z, p_cam.y() * inv_z);
  Eigen::Matrix2d J_dist;
  const bool distorted = !distortion_.is_zero();
  const Eigen::Vector2d xd = distort(xn, J != nullptr || distorted ? &J_dist : nullptr);
  // Where the lens model folds over (beyond the calibrated region of strong radial distortion), a point far
  // outside the field of view lands back inside the image: no projection, as undistort_normalized refuses.
  if (distorted && !(J_dist.determinant() > 0.0)) return false;
  if (uv != nullptr) *uv = Eigen::Vector2d(fx_ * xd.x() + cx_, fy_ * xd.y() + cy_);
  if (J != nullptr) {
    // Chain rule: d(uv)/d(xd) * d(xd)/d(xn) * d(xn)/d(p).
    Eigen::Matrix<double, 2, 3> J_norm;
    J_norm << inv_z, 0.0, -xn.x() * inv_z,
              0.0, inv_z, -xn.y() * inv_z;
    const Eigen::Matrix2d J_pixel = Eigen::Vector2d(fx_, fy_).asDiagonal();
    *J = J_pixel * J_dist * J_norm;
  }
  return true;
}

Eigen::Vector2d PinholeCamera::distort(const Eigen::Vector2d& xn, Eigen::Matrix2d* J) const {
  if (distortion_.is_equidistant()) return distort_equidistant(xn, J);
  // OpenCV's model: x_d = x (1 + k1 r^2 + k2 r^4 + k3 r^6) + 2 p1 x y + p2 (r^2 + 2 x^2), and
  // y_d likewise with p1 and p2 swapped roles (OpenCV docs, "Camera Calibration and 3D Reconstruction").
  const Distortion& d = distortion_;
  const double x = xn.x();
  const double y = xn.y();
  const double x2 = x * x;
  const double y2 = y * y;
  const double xy = x * y;
  const double r2 = x2 + y2;
  const double radial = 1.0 + r2 * (d.k1 + r2 * (d.k2 + r2 * d.k3));
  const Eigen::Vector2d xd(x * radial + 2.0 * d.p1 * xy + d.p2 * (r2 + 2.0 * x2),
                           y * radial + d.p1 * (r2 + 2.0 * y2) + 2.0 * d.p2 * xy);
  if (J != nullptr) {
    // d(radial)/d(r^2); d(r^2)/dx = 2x.
    const double dradial = d.k1 + r2 * (2.0 * d.k2 + 3.0 * r2 * d.k3);
    const double off_diagonal = 2.0 * xy * dradial + 2.0 * d.p1 * x + 2.0 * d.p2 * y;
    (*J)(0, 0) = radial + 2.0 * x2 * dradial + 2.0 * d.p1 * y + 6.0 * d.p2 * x;
    (*J)(0, 1) = off_diagonal;
    (*J)(1, 0) = off_diagonal;
    (*J)(1, 1) = radial + 2.0 * y2 * dradial + 6.0 * d.p1 * y + 2.0 * d.p2 * x;
  }
  return xd;
}

// cv::fisheye's model on r = |xn|: theta = atan(r), theta_d = theta (1 + k1 theta^2 + ... + k4 theta^8),
// xd = xn theta_d / r. With s(r) = theta_d / r, d(xd)/d(xn) = s I + s'(r) xn xn^T / r.
Eigen::Vector2d PinholeCamera::distort_equidistant(const Eigen::Vector2d& xn, Eigen::Matrix2d* J) const {
  const Distortion& d = distortion_;
  const double r = xn.norm();
  if (r < 1e-10) {  // theta_d / r -> 1 at the centre
    if (J != nullptr) J->setIdentity();
    return xn;
  }
  const double theta = std::atan(r);
  const double t2 = theta * theta;
  const double theta_d = theta * (1.0 + t2 * (d.k1 + t2 * (d.k2 + t2 * (d.k3 + t2 * d.k4))));
  const double s = theta_d / r;
  if (J != nullptr) {
    const double dtheta_d = 1.0 + t2 * (3.0 * d.k1 + t2 * (5.0 * d.k2 + t2 * (7.0 * d.k3 + t2 * 9.0 * d.k4)));
    const double ds_dr = (dtheta_d / (1.0 + r * r) * r - theta_d) / (r * r);
    *J = s * Eigen::Matrix2d::Identity() + (ds_dr / r) * (xn * xn.transpose());
  }
  return s * xn;
}

// Inverse of distort_equidistant: theta from theta_d = |xd| by Newton on the odd polynomial (as
// cv::fisheye::undistortPoints), then xn = xd tan(theta) / theta_d. nullopt beyond 90 degrees (no point
// of the z = 1 plane) or where the polynomial stops rising (the lens model folds over).
std::optional<Eigen::Vector2d> PinholeCamera::undistort_equidistant(const Eigen::Vector2d& xd) const {
  const Distortion& d = distortion_;
  const double theta_d = xd.norm();
  if (theta_d < 1e-10) return xd;
  const auto poly = [&](double theta) {
    const double t2 = theta * theta;
    return theta * (1.0 + t2 * (d.k1 + t2 * (d.k2 + t2 * (d.k3 + t2 * d.k4))));
  };
  const auto slope = [&](double theta) {
    const double t2 = theta * theta;
    return 1.0 + t2 * (3.0 * d.k1 + t2 * (5.0 * d.k2 + t2 * (7.0 * d.k3 + t2 * 9.0 * d.k4)));
  };
  double theta = theta_d;
  bool converged = false;
  for (int iteration = 0; iteration < undistort_max_iterations; ++iteration) {
    const double derivative = slope(theta);
    if (!(derivative > 0.0)) return std::nullopt;
    const double step = (poly(theta) - theta_d) / derivative;
    theta -= step;
    if (std::abs(step) < undistort_tolerance) {
      converged = true;
      break;
    }
  }
  constexpr double kMaxTheta = 1.5707963267948966 - 1e-6;  // just short of 90 degrees
  if (!converged || !(theta > 0.0 && theta < kMaxTheta) || !(slope(theta) > 0.0)) return std::nullopt;
  return xd * (std::tan(theta) / theta_d);
}

std::optional<Eigen::Vector2d> PinholeCamera::undistort_normalized(const Eigen::Vector2d& xd) const {
  if (!xd.allFinite()) return std::nullopt;
  if (distortion_.is_zero()) return xd;
  if (distortion_.is_equidistant()) return undistort_equidistant(xd);
  // Newton on f(xn) = distort(xn) - xd from xn = xd (distortion is a perturbation of the identity
  // inside the calibrated field of view). A step that does not reduce |f| is halved, which keeps the
  // iteration from jumping onto another branch of the polynomial; when halving cannot reduce |f|
  // either, the iteration is stuck and gives up.
  constexpr int kMaxHalvings = 20;
  const double tolerance_sq = undistort_tolerance * undistort_tolerance;
  Eigen::Vector2d xn = xd;
  Eigen::Matrix2d J;
  Eigen::Vector2d residual = distort(xn, &J) - xd;
  double error = residual.squaredNorm();
  for (int iteration = 0; iteration < undistort_max_iterations && error > tolerance_sq; ++iteration) {
    if (!(std::abs(J.determinant()) > 1e-12)) return std::nullopt;
    const Eigen::Vector2d step = J.inverse() * residual;
    bool improved = false;
    double scale = 1.0;
    for (int halving = 0; halving < kMaxHalvings && !improved; ++halving, scale *= 0.5) {
      const Eigen::Vector2d candidate = xn - scale * step;
      Eigen::Matrix2d J_candidate;
      const Eigen::Vector2d r = distort(candidate, &J_candidate) - xd;
      if (r.squaredNorm() < error) {
        xn = candidate;
        J = J_candidate;
        residual = r;
        error = r.squaredNorm();
        improved = true;
      }
    }
    if (!improved) break;
  }
  if (!(error <= tolerance_sq) || !(J.determinant() > 0.0)) return std::nullopt;
  return xn;
}

std::optional<Eigen::Vector3d> PinholeCamera::unproject(const Eigen::Vector2d& uv) const {
  const Eigen::Vector2d xd((uv.x() - cx_) / fx_, (uv.y() - cy_) / fy_);
  const std::optional<Eigen::Vector2d> xn = undistort_normalized(xd);
  if (!xn) return std::nullopt;
  return Eigen::Vector3d(xn->x(), xn->y(), 1.0);
}

std::optional<Eigen::Vector3d> PinholeCamera::unproject(const Eigen::Vector2d& uv, double depth_m) const {
  if (!(std::isfinite(depth_m) && depth_m > 0.0)) return std::nullopt;
  const std::optional<Eigen::Vector3d> ray = unproject(uv);
  if (!ray) return std::nullopt;
  return depth_m * *ray;
}

std::vector<Eigen::Vector2d> PinholeCamera::undistort_points(const std::vector<Eigen::Vector2d>& uv) const {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  std::vector<Eigen::Vector2d> out;
  out.reserve(uv.size());
  for (const Eigen::Vector2d& p : uv) {
    const std::optional<Eigen::Vector3d> ray = unproject(p);
    out.push_back(ray ? Eigen::Vector2d(fx_ * ray->x() + cx_, fy_ * ray->y() + cy_)
                      : Eigen::Vector2d(kNaN, kNaN));
  }
  return out;
}

bool PinholeCamera::in_image(const Eigen::Vector2d& uv, double border_px) const {
  return uv.x() >= border_px - 0.5 && uv.x() < width_ - 0.5 - border_px &&
         uv.y() >= border_px - 0.5 && uv.y() < height_ - 0.5 - border_px;
}

std::optional<double> StereoRig::depth_from_disparity(double disparity_px) const {
  FLEETSLAM_CHECK(baseline_m > 0.0, "stereo rig needs a positive baseline");
  if (!(disparity_px > 0.0) || !std::isfinite(disparity_px)) return std::nullopt;
  return bf() / disparity_px;
}

std::optional<double> StereoRig::disparity_from_depth(double depth_m) const {
  FLEETSLAM_CHECK(baseline_m > 0.0, "stereo rig needs a positive baseline");
  if (!(depth_m > 0.0) || !std::isfinite(depth_m)) return std::nullopt;
  return bf() / depth_m;
}

double RgbdCamera::depth_m_from_raw(std::uint16_t raw) const {
  FLEETSLAM_CHECK(depth_scale > 0.0, "RGB-D depth scale must be positive");
  if (raw == 0) return 0.0;
  const double depth_m = static_cast<double>(raw) / depth_scale;
  if (depth_m < min_depth_m || depth_m > max_depth_m) return 0.0;
  return depth_m;
}

}  // namespace fleetslam::core
