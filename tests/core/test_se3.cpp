// Law-based tests of the SE(3)/SO(3) helpers over seeded random poses and the edge cases (identity,
// tiny angles, angles at and next to pi). Eigen's AngleAxis serves as an independent oracle for exp.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/se3.hpp"

namespace fleetslam::core {
namespace {

constexpr double kPi = 3.14159265358979323846;

class Random {
 public:
  explicit Random(unsigned seed) : engine_(seed) {}

  Eigen::Vector3d unit_vector() {
    std::normal_distribution<double> normal(0.0, 1.0);
    Eigen::Vector3d v(normal(engine_), normal(engine_), normal(engine_));
    return v.normalized();
  }
  double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(engine_); }
  // Rotation vector with angle uniform in [0, max_angle).
  Eigen::Vector3d rotation_vector(double max_angle) { return uniform(0.0, max_angle) * unit_vector(); }
  Eigen::Isometry3d pose() {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(uniform(0.0, kPi), unit_vector()).toRotationMatrix();
    T.translation() = Eigen::Vector3d(uniform(-10, 10), uniform(-10, 10), uniform(-10, 10));
    return T;
  }

 private:
  std::mt19937 engine_;
};

Eigen::Matrix3d angle_axis(double angle, const Eigen::Vector3d& axis) {
  return Eigen::AngleAxisd(angle, axis).toRotationMatrix();
}

double max_abs_diff(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) { return (a - b).cwiseAbs().maxCoeff(); }

TEST(Se3, HatIsTheCrossProduct) {
  Random rng(1);
  for (int i = 0; i < 20; ++i) {
    const Eigen::Vector3d a = rng.rotation_vector(5.0);
    const Eigen::Vector3d b = rng.rotation_vector(5.0);
    EXPECT_LT(max_abs_diff(hat(a) * b, a.cross(b)), 1e-14);
  }
}

TEST(Se3, So3ExpMatchesAngleAxis) {
  Random rng(2);
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d phi = rng.rotation_vector(2.0 * kPi);
    EXPECT_LT(max_abs_diff(so3_exp(phi), angle_axis(phi.norm(), phi.normalized())), 1e-14) << phi.transpose();
  }
}

TEST(Se3, IdentityAndZero) {
  EXPECT_EQ(so3_log(Eigen::Matrix3d::Identity()), Eigen::Vector3d::Zero());
  EXPECT_EQ(so3_exp(Eigen::Vector3d::Zero()), Eigen::Matrix3d::Identity());
  EXPECT_EQ(se3_log(Eigen::Isometry3d::Identity()), Vector6d::Zero());
  EXPECT_TRUE(se3_exp(Vector6d::Zero()).isApprox(Eigen::Isometry3d::Identity(), 0.0));
  EXPECT_EQ(so3_left_jacobian(Eigen::Vector3d::Zero()), Eigen::Matrix3d::Identity());
  EXPECT_EQ(so3_left_jacobian_inverse(Eigen::Vector3d::Zero()), Eigen::Matrix3d::Identity());
  EXPECT_EQ(rotation_angle_rad(Eigen::Matrix3d::Identity()), 0.0);
}

TEST(Se3, TinyAnglesKeepRelativePrecision) {
  Random rng(3);
  for (double angle : {1e-15, 1e-12, 1e-9, 1e-6, 1e-4, 1e-3, 1e-2}) {
    const Eigen::Vector3d phi = angle * rng.unit_vector();
    const Eigen::Matrix3d R = so3_exp(phi);
    EXPECT_LT(max_abs_diff(R, angle_axis(angle, phi.normalized())), 3e-16) << angle;
    // The skew part carries the angle: it must be exact relative to the angle, not just to 1.
    const Eigen::Matrix3d skew = 0.5 * (R - R.transpose());
    EXPECT_LT(max_abs_diff(skew, std::sin(angle) / angle * hat(phi)), 1e-15 * angle) << angle;
    const Eigen::Vector3d back = so3_log(so3_exp(phi));
    EXPECT_LT((back - phi).norm(), 1e-15 + 1e-9 * angle) << angle;
  }
}

TEST(Se3, ExpOfLogIsIdentityMapOnRandomPoses) {
  Random rng(4);
  for (int i = 0; i < 1000; ++i) {
    const Eigen::Isometry3d T = rng.pose();
    const Eigen::Isometry3d back = se3_exp(se3_log(T));
    EXPECT_LT(max_abs_diff(back.matrix(), T.matrix()), 1e-11) << i;
  }
}

TEST(Se3, LogOfExpIsIdentityMapInsideThePiBall) {
  Random rng(5);
  for (int i = 0; i < 1000; ++i) {
    Vector6d xi;
    xi.head<3>() = Eigen::Vector3d(rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-5, 5));
    xi.tail<3>() = rng.rotation_vector(kPi - 1e-3);
    EXPECT_LT((se3_log(se3_exp(xi)) - xi).cwiseAbs().maxCoeff(), 1e-10) << xi.transpose();
  }
}

TEST(Se3, LogNextToPiRecoversTheAngle) {
  Random rng(6);
  for (double gap : {1e-3, 1e-6, 1e-9, 1e-12}) {
    for (int i = 0; i < 50; ++i) {
      const Eigen::Vector3d axis = rng.unit_vector();
      const double angle = kPi - gap;
      const Eigen::Matrix3d R = angle_axis(angle, axis);
      const Eigen::Vector3d phi = so3_log(R);
      // Below pi the axis sign is determined: the result must be +axis, not -axis.
      EXPECT_LT((phi - angle * axis).norm(), 1e-9) << "gap " << gap;
      EXPECT_LT(max_abs_diff(so3_exp(phi), R), 1e-14);
      EXPECT_NEAR(rotation_angle_rad(R), angle, 1e-12);
    }
  }
}

TEST(Se3, LogAtExactlyPi) {
  Random rng(7);
  std::vector<Eigen::Vector3d> axes = {Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(),
                                       Eigen::Vector3d::UnitZ(), Eigen::Vector3d(1, 1, 0).normalized()};
  for (int i = 0; i < 50; ++i) axes.push_back(rng.unit_vector());
  for (const Eigen::Vector3d& axis : axes) {
    // Rotation by pi: R = 2 a a^T - I, exactly symmetric.
    const Eigen::Matrix3d R = 2.0 * axis * axis.transpose() - Eigen::Matrix3d::Identity();
    const Eigen::Vector3d phi = so3_log(R);
    EXPECT_NEAR(phi.norm(), kPi, 1e-9) << axis.transpose();
    // Either sign is a valid logarithm at pi.
    EXPECT_NEAR(std::abs(phi.normalized().dot(axis)), 1.0, 1e-12);
    EXPECT_LT(max_abs_diff(so3_exp(phi), R), 1e-12);
    EXPECT_NEAR(rotation_angle_rad(R), kPi, 1e-9);

    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = R;
    T.translation() = Eigen::Vector3d(0.3, -1.2, 2.0);
    EXPECT_LT(max_abs_diff(se3_exp(se3_log(T)).matrix(), T.matrix()), 1e-12);
  }
}

// J_l(phi) is defined by exp(phi + d) = exp(J_l(phi) d) exp(phi) to first order in d.
Eigen::Matrix3d numeric_left_jacobian(const Eigen::Vector3d& phi) {
  constexpr double h = 1e-6;
  Eigen::Matrix3d J;
  const Eigen::Matrix3d R_inv = so3_exp(phi).transpose();
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d d = h * Eigen::Vector3d::Unit(i);
    J.col(i) = (so3_log(so3_exp(phi + d) * R_inv) - so3_log(so3_exp(phi - d) * R_inv)) / (2.0 * h);
  }
  return J;
}

TEST(Se3, LeftJacobianMatchesNumericDifferentiation) {
  Random rng(8);
  std::vector<Eigen::Vector3d> phis = {Eigen::Vector3d::Zero(), Eigen::Vector3d(1e-5, 0, 0),
                                       Eigen::Vector3d(0, 0, 3.0)};
  for (int i = 0; i < 200; ++i) phis.push_back(rng.rotation_vector(3.0));
  for (const Eigen::Vector3d& phi : phis) {
    EXPECT_LT(max_abs_diff(so3_left_jacobian(phi), numeric_left_jacobian(phi)), 1e-7) << phi.transpose();
  }
}

TEST(Se3, LeftJacobianInverseIsTheInverse) {
  Random rng(9);
  std::vector<Eigen::Vector3d> phis = {Eigen::Vector3d::Zero(), Eigen::Vector3d(1e-7, -1e-7, 0),
                                       Eigen::Vector3d(0, kPi, 0), kPi * Eigen::Vector3d(1, 1, 1).normalized(),
                                       (kPi - 1e-9) * Eigen::Vector3d::UnitZ()};
  for (int i = 0; i < 200; ++i) phis.push_back(rng.rotation_vector(kPi));
  for (const Eigen::Vector3d& phi : phis) {
    const Eigen::Matrix3d product = so3_left_jacobian(phi) * so3_left_jacobian_inverse(phi);
    EXPECT_LT(max_abs_diff(product, Eigen::Matrix3d::Identity()), 1e-12) << phi.transpose();
  }
}

TEST(Se3, AdjointLaw) {
  Random rng(10);
  for (int i = 0; i < 300; ++i) {
    const Eigen::Isometry3d T = rng.pose();
    Vector6d xi;
    xi.head<3>() = Eigen::Vector3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    xi.tail<3>() = rng.rotation_vector(2.0);
    const Eigen::Isometry3d lhs = T * se3_exp(xi) * T.inverse();
    const Eigen::Isometry3d rhs = se3_exp(se3_adjoint(T) * xi);
    EXPECT_LT(max_abs_diff(lhs.matrix(), rhs.matrix()), 1e-11) << i;
  }
}

TEST(Se3, InterpolateEndpointsAndMidpoint) {
  Random rng(11);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Isometry3d T_a = rng.pose();
    const Eigen::Vector3d phi = rng.rotation_vector(kPi - 1e-3);
    Eigen::Isometry3d T_b = T_a;
    T_b.linear() = T_a.linear() * so3_exp(phi);
    T_b.translation() = Eigen::Vector3d(rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-3, 3));

    EXPECT_LT(max_abs_diff(interpolate(T_a, T_b, 0.0).matrix(), T_a.matrix()), 1e-12);
    EXPECT_LT(max_abs_diff(interpolate(T_a, T_b, 1.0).matrix(), T_b.matrix()), 1e-11);

    const Eigen::Isometry3d mid = interpolate(T_a, T_b, 0.5);
    EXPECT_LT(max_abs_diff(mid.linear(), T_a.linear() * so3_exp(0.5 * phi)), 1e-12);
    EXPECT_LT((mid.translation() - 0.5 * (T_a.translation() + T_b.translation())).norm(), 1e-12);
    // The midpoint is equally far (in angle) from both ends, each half of the whole.
    const double to_a = rotation_angle_rad(T_a.linear().transpose() * mid.linear());
    const double to_b = rotation_angle_rad(mid.linear().transpose() * T_b.linear());
    EXPECT_NEAR(to_a, 0.5 * phi.norm(), 1e-9);
    EXPECT_NEAR(to_b, 0.5 * phi.norm(), 1e-9);
  }
}

TEST(Se3, AverageOfSymmetricRotationsIsTheCentre) {
  Random rng(12);
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Matrix3d R_mean = so3_exp(rng.rotation_vector(kPi));
    std::vector<Eigen::Matrix3d> rotations;
    for (int k = 0; k < 5; ++k) {
      // Pairs R exp(+d), R exp(-d): their chordal mean is exactly R for |d| < pi / 2.
      const Eigen::Vector3d d = rng.rotation_vector(1.5);
      rotations.push_back(R_mean * so3_exp(d));
      rotations.push_back(R_mean * so3_exp(-d));
    }
    EXPECT_LT(max_abs_diff(average_rotations(rotations), R_mean), 1e-12) << trial;
  }
}

TEST(Se3, WeightedAverageFollowsTheWeights) {
  const Eigen::Matrix3d R_a = so3_exp(Eigen::Vector3d(0.3, 0.0, 0.0));
  const Eigen::Matrix3d R_b = so3_exp(Eigen::Vector3d(0.0, 0.0, -0.7));
  EXPECT_LT(max_abs_diff(average_rotations({R_a, R_b}, {1.0, 0.0}), R_a), 1e-12);
  EXPECT_LT(max_abs_diff(average_rotations({R_a, R_b}, {0.0, 2.0}), R_b), 1e-12);
  // Two rotations about one axis: the chordal mean lies on the geodesic between them, at the middle.
  const Eigen::Matrix3d R_c = so3_exp(Eigen::Vector3d(0.0, 0.0, 0.7));
  EXPECT_LT(max_abs_diff(average_rotations({R_b, R_c}), Eigen::Matrix3d::Identity()), 1e-12);
}

TEST(Se3, AverageOfIdenticalPosesIsThatPose) {
  Random rng(13);
  for (int i = 0; i < 20; ++i) {
    const Eigen::Isometry3d T = rng.pose();
    const std::vector<Eigen::Isometry3d> poses(7, T);
    EXPECT_LT(max_abs_diff(average_poses(poses).matrix(), T.matrix()), 1e-12);
    EXPECT_LT(max_abs_diff(average_poses(poses, {1, 2, 3, 4, 5, 6, 7}).matrix(), T.matrix()), 1e-12);
  }
}

TEST(Se3, AveragePosesWeightsTranslations) {
  Eigen::Isometry3d T_a = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_b = Eigen::Isometry3d::Identity();
  T_b.translation() = Eigen::Vector3d(4.0, 0.0, 0.0);
  EXPECT_LT((average_poses({T_a, T_b}, {3.0, 1.0}).translation() - Eigen::Vector3d(1.0, 0.0, 0.0)).norm(),
            1e-15);
}

TEST(Se3, AveragingNothingIsABug) {
  EXPECT_THROW(average_rotations({}), InvariantError);
  EXPECT_THROW(average_poses({}), InvariantError);
  EXPECT_THROW(average_rotations({Eigen::Matrix3d::Identity()}, {1.0, 2.0}), InvariantError);
  EXPECT_THROW(average_rotations({Eigen::Matrix3d::Identity()}, {-1.0}), InvariantError);
  EXPECT_THROW(average_rotations({Eigen::Matrix3d::Identity()}, {0.0}), InvariantError);
}

TEST(Se3, MakePoseNormalisesTheQuaternion) {
  const Eigen::Quaterniond q(2.0, 0.0, 0.0, 2.0);  // 90 degrees about z, norm 2*sqrt(2)
  const Eigen::Isometry3d T = make_pose(Eigen::Vector3d(1, 2, 3), q);
  EXPECT_LT(max_abs_diff(T.linear(), angle_axis(kPi / 2, Eigen::Vector3d::UnitZ())), 1e-15);
  EXPECT_EQ(T.translation(), Eigen::Vector3d(1, 2, 3));
  EXPECT_THROW(make_pose(Eigen::Vector3d::Zero(), Eigen::Quaterniond(0, 0, 0, 0)), InvariantError);
}

TEST(Se3, NormalizedRestoresOrthonormality) {
  Random rng(14);
  for (int i = 0; i < 50; ++i) {
    Eigen::Isometry3d T = rng.pose();
    const Eigen::Isometry3d original = T;
    Eigen::Matrix3d noise;
    for (int k = 0; k < 9; ++k) noise(k / 3, k % 3) = rng.uniform(-1e-6, 1e-6);
    T.linear() += noise;
    const Eigen::Isometry3d fixed = normalized(T);
    const Eigen::Matrix3d R = fixed.linear();
    EXPECT_LT(max_abs_diff(R.transpose() * R, Eigen::Matrix3d::Identity()), 1e-14);
    EXPECT_NEAR(R.determinant(), 1.0, 1e-14);
    EXPECT_LT(max_abs_diff(R, original.linear()), 1e-5);
    EXPECT_EQ(fixed.translation(), T.translation());
  }
}

TEST(Se3, RotationAngleOfKnownRotations) {
  for (double angle : {0.0, 1e-10, 0.1, 1.0, 2.0, 3.0, kPi - 1e-9}) {
    EXPECT_NEAR(rotation_angle_rad(angle_axis(angle, Eigen::Vector3d(1, -2, 0.5).normalized())), angle, 1e-12);
  }
  // Angles beyond pi come back as 2 pi - angle.
  EXPECT_NEAR(rotation_angle_rad(angle_axis(4.0, Eigen::Vector3d::UnitY())), 2 * kPi - 4.0, 1e-12);
}

}  // namespace
}  // namespace fleetslam::core
