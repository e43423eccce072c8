#include "fleetslam/core/se3.hpp"

#include <cmath>

#include <Eigen/SVD>

#include "fleetslam/core/error.hpp"

// Formulas: Barfoot, "State Estimation for Robotics" (2017), sections 7.1.3-7.1.5 (SO(3)/SE(3) exp,
// log, left Jacobian and its inverse) and Sola et al., "A micro Lie theory" (2018), appendix B.
namespace fleetslam::core {
namespace {

// Below this squared angle the closed forms lose digits to cancellation; their Taylor series are used
// instead. At theta^2 = 1e-8 the first dropped term is ~theta^4/120 ~ 1e-18, below double epsilon.
constexpr double kSmallAngleSq = 1e-8;

// sin(theta)/theta and (1 - cos(theta))/theta^2, the two coefficients of Rodrigues' formula.
struct RodriguesCoefficients {
  double a;  // sin(theta) / theta
  double b;  // (1 - cos(theta)) / theta^2
  double c;  // (theta - sin(theta)) / theta^3
};

RodriguesCoefficients rodrigues_coefficients(double theta_sq) {
  if (theta_sq < kSmallAngleSq) {
    return {1.0 - theta_sq / 6.0, 0.5 - theta_sq / 24.0, 1.0 / 6.0 - theta_sq / 120.0};
  }
  const double theta = std::sqrt(theta_sq);
  const double s = std::sin(theta);
  // 1 - cos(theta) = 2 sin^2(theta / 2) avoids cancellation for small theta.
  const double half_sin = std::sin(0.5 * theta);
  return {s / theta, 2.0 * half_sin * half_sin / theta_sq, (theta - s) / (theta_sq * theta)};
}

Eigen::Matrix3d project_to_so3(const Eigen::Matrix3d& M) {
  // Closest rotation in the Frobenius norm: U diag(1, 1, det(U V^T)) V^T.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

// Checks a weight vector against `count` items and returns the weights to use (uniform when empty).
std::vector<double> checked_weights(std::size_t count, const std::vector<double>& weights) {
  FLEETSLAM_CHECK(count > 0, "cannot average an empty set");
  if (weights.empty()) return std::vector<double>(count, 1.0);
  FLEETSLAM_CHECK(weights.size() == count, "one weight per item is required");
  double sum = 0.0;
  for (double w : weights) {
    FLEETSLAM_CHECK(std::isfinite(w) && w >= 0.0, "weights must be finite and non-negative");
    sum += w;
  }
  FLEETSLAM_CHECK(sum > 0.0, "weights must not all be zero");
  return weights;
}

}  // namespace

Eigen::Matrix3d hat(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(),
       v.z(), 0.0, -v.x(),
       -v.y(), v.x(), 0.0;
  return m;
}

Eigen::Matrix3d so3_exp(const Eigen::Vector3d& phi) {
  // Rodrigues: R = I + a hat(phi) + b hat(phi)^2.
  const RodriguesCoefficients k = rodrigues_coefficients(phi.squaredNorm());
  const Eigen::Matrix3d W = hat(phi);
  return Eigen::Matrix3d::Identity() + k.a * W + k.b * W * W;
}

Eigen::Vector3d so3_log(const Eigen::Matrix3d& R) {
  // Through the unit quaternion (Eigen uses Shepperd's method, stable for every angle): the angle
  // 2 atan2(|v|, w) keeps full precision near 0 and near pi, where acos((trace - 1) / 2) does not.
  Eigen::Quaterniond q(R);
  q.normalize();
  // q and -q are the same rotation; w >= 0 picks the angle in [0, pi].
  const double w = q.w() < 0.0 ? -q.w() : q.w();
  const Eigen::Vector3d v = q.w() < 0.0 ? Eigen::Vector3d(-q.vec()) : Eigen::Vector3d(q.vec());
  const double n_sq = v.squaredNorm();
  if (n_sq < kSmallAngleSq) {
    // 2 atan(n / w) / n = (2 / w) (1 - n^2 / (3 w^2)) + O(n^4); w ~ 1 here.
    return (2.0 / w) * (1.0 - n_sq / (3.0 * w * w)) * v;
  }
  const double n = std::sqrt(n_sq);
  return (2.0 * std::atan2(n, w) / n) * v;
}

Eigen::Matrix3d so3_left_jacobian(const Eigen::Vector3d& phi) {
  // J_l = I + b hat(phi) + c hat(phi)^2 (Barfoot eq. 7.37).
  const RodriguesCoefficients k = rodrigues_coefficients(phi.squaredNorm());
  const Eigen::Matrix3d W = hat(phi);
  return Eigen::Matrix3d::Identity() + k.b * W + k.c * W * W;
}

Eigen::Matrix3d so3_left_jacobian_inverse(const Eigen::Vector3d& phi) {
  // J_l^-1 = I - hat(phi) / 2 + e hat(phi)^2 with e = 1/theta^2 - (1 + cos theta) / (2 theta sin theta)
  // (Barfoot eq. 7.45). Writing (1 + cos) / sin = cot(theta / 2) keeps e finite at theta = pi.
  const double theta_sq = phi.squaredNorm();
  double e;
  if (theta_sq < kSmallAngleSq) {
    e = 1.0 / 12.0 + theta_sq / 720.0;
  } else {
    const double theta = std::sqrt(theta_sq);
    const double half = 0.5 * theta;
    e = 1.0 / theta_sq - std::cos(half) / (2.0 * theta * std::sin(half));
  }
  const Eigen::Matrix3d W = hat(phi);
  return Eigen::Matrix3d::Identity() - 0.5 * W + e * W * W;
}

Eigen::Isometry3d se3_exp(const Vector6d& xi) {
  const Eigen::Vector3d rho = xi.head<3>();
  const Eigen::Vector3d phi = xi.tail<3>();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = so3_exp(phi);
  T.translation() = so3_left_jacobian(phi) * rho;
  return T;
}

Vector6d se3_log(const Eigen::Isometry3d& T) {
  const Eigen::Vector3d phi = so3_log(T.linear());
  Vector6d xi;
  xi.head<3>() = so3_left_jacobian_inverse(phi) * T.translation();
  xi.tail<3>() = phi;
  return xi;
}

Matrix6d se3_adjoint(const Eigen::Isometry3d& T) {
  // For xi = [rho; phi]: Ad(T) = [R, hat(t) R; 0, R] (Barfoot eq. 7.46).
  const Eigen::Matrix3d R = T.linear();
  Matrix6d Ad = Matrix6d::Zero();
  Ad.topLeftCorner<3, 3>() = R;
  Ad.topRightCorner<3, 3>() = hat(T.translation()) * R;
  Ad.bottomRightCorner<3, 3>() = R;
  return Ad;
}

Eigen::Isometry3d make_pose(const Eigen::Vector3d& t, const Eigen::Quaterniond& q) {
  const double norm = q.norm();
  FLEETSLAM_CHECK(std::isfinite(norm) && norm > 0.0, "quaternion must be finite and non-zero");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(q.coeffs() / norm).toRotationMatrix();
  T.translation() = t;
  return T;
}

double rotation_angle_rad(const Eigen::Matrix3d& R) { return so3_log(R).norm(); }

Eigen::Isometry3d interpolate(const Eigen::Isometry3d& T_a, const Eigen::Isometry3d& T_b, double s) {
  // Geodesic on SO(3) (slerp): R_a exp(s log(R_a^T R_b)); translation along the straight line.
  const Eigen::Matrix3d R_a = T_a.linear();
  const Eigen::Vector3d phi_ab = so3_log(R_a.transpose() * T_b.linear());
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R_a * so3_exp(s * phi_ab);
  T.translation() = (1.0 - s) * T_a.translation() + s * T_b.translation();
  return T;
}

Eigen::Matrix3d average_rotations(const std::vector<Eigen::Matrix3d>& rotations,
                                  const std::vector<double>& weights) {
  // Chordal L2 mean: argmin_R sum w_i ||R - R_i||_F^2 is the projection of sum w_i R_i onto SO(3)
  // (Hartley et al., "Rotation Averaging", IJCV 2013, section 5.3).
  const std::vector<double> w = checked_weights(rotations.size(), weights);
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < rotations.size(); ++i) M += w[i] * rotations[i];
  return project_to_so3(M);
}

Eigen::Isometry3d average_poses(const std::vector<Eigen::Isometry3d>& poses,
                                const std::vector<double>& weights) {
  const std::vector<double> w = checked_weights(poses.size(), weights);
  std::vector<Eigen::Matrix3d> rotations;
  rotations.reserve(poses.size());
  Eigen::Vector3d t_sum = Eigen::Vector3d::Zero();
  double w_sum = 0.0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    rotations.push_back(poses[i].linear());
    t_sum += w[i] * poses[i].translation();
    w_sum += w[i];
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = average_rotations(rotations, w);
  T.translation() = t_sum / w_sum;
  return T;
}

Eigen::Isometry3d normalized(const Eigen::Isometry3d& T) {
  Eigen::Isometry3d out = T;
  out.linear() = project_to_so3(T.linear());
  return out;
}

}  // namespace fleetslam::core
