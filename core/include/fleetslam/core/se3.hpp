#pragma once
// SE(3)/SO(3) helpers on Eigen. Poses are Eigen::Isometry3d named by frames: T_world_cam maps a point
// expressed in the camera frame into the world frame (p_world = T_world_cam * p_cam).
// Tangent vectors are ordered [rho (translation part); phi (rotation part)], as in Sophus.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

namespace fleetslam::core {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// Skew-symmetric matrix: hat(a) * b == a.cross(b).
Eigen::Matrix3d hat(const Eigen::Vector3d& v);

// SO(3) exponential (Rodrigues) of a rotation vector; exact near zero and near pi.
Eigen::Matrix3d so3_exp(const Eigen::Vector3d& phi);
// SO(3) logarithm; returns phi with |phi| in [0, pi]. Input must be a rotation matrix. Keeps full
// precision near 0 and near pi (computed through the quaternion, not acos of the trace); at exactly pi
// both phi and -phi are logarithms and either may be returned.
Eigen::Vector3d so3_log(const Eigen::Matrix3d& R);
// Left Jacobian of SO(3) and its inverse.
Eigen::Matrix3d so3_left_jacobian(const Eigen::Vector3d& phi);
Eigen::Matrix3d so3_left_jacobian_inverse(const Eigen::Vector3d& phi);

// SE(3) exponential and logarithm with xi = [rho; phi].
Eigen::Isometry3d se3_exp(const Vector6d& xi);
Vector6d se3_log(const Eigen::Isometry3d& T);

// Adjoint of T: Ad(T) * xi == log(T * exp(xi) * T^-1) for the [rho; phi] ordering.
Matrix6d se3_adjoint(const Eigen::Isometry3d& T);

// Pose from a translation and a quaternion (normalised here).
Eigen::Isometry3d make_pose(const Eigen::Vector3d& t, const Eigen::Quaterniond& q);

// Rotation angle of a rotation matrix, in [0, pi].
double rotation_angle_rad(const Eigen::Matrix3d& R);

// Interpolation: translation linear, rotation slerp; s in [0, 1] (extrapolates outside).
Eigen::Isometry3d interpolate(const Eigen::Isometry3d& T_a, const Eigen::Isometry3d& T_b, double s);

// Chordal L2 mean of rotations (SVD projection of the mean matrix), weights optional (uniform if empty).
Eigen::Matrix3d average_rotations(const std::vector<Eigen::Matrix3d>& rotations,
                                  const std::vector<double>& weights = {});
// Pose average: weighted mean translation, chordal rotation mean.
Eigen::Isometry3d average_poses(const std::vector<Eigen::Isometry3d>& poses,
                                const std::vector<double>& weights = {});

// Re-orthonormalises the rotation part (accumulated round-off).
Eigen::Isometry3d normalized(const Eigen::Isometry3d& T);

}  // namespace fleetslam::core
