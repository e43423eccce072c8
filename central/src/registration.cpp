#include "fleetslam/central/registration.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "fleetslam/central/kdtree.hpp"
#include "fleetslam/central/sampling.hpp"
#include "fleetslam/core/error.hpp"
#include "normal_test.hpp"
#include "with_pcl/registration_pcl.hpp"

namespace fleetslam::central {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

constexpr std::size_t kMinPoints = 10;

// Finite points (and their normals, when the cloud has them), uniformly sampled when voxel_size_m > 0.
struct Prepared {
  std::vector<Eigen::Vector3f> points;
  std::vector<Eigen::Vector3f> normals;  // empty, or one per point (zero: unknown)
};

Prepared prepare(const core::PointCloud& cloud, double voxel_size_m) {
  core::PointCloud kept;
  kept.points = cloud.points;
  if (cloud.has_normals()) kept.normals = cloud.normals;
  if (voxel_size_m > 0.0) {
    UniformSamplingConfig sampling;
    sampling.voxel_size_m = voxel_size_m;
    kept = UniformSampler(sampling).sample(kept).cloud;
  } else {
    core::remove_non_finite(kept);
  }
  return Prepared{std::move(kept.points), std::move(kept.normals)};
}

// GICP's plane-to-plane covariance of point i (Segal et al. section III-B): the covariance of its k
// nearest points, its eigenvalues replaced by (epsilon, 1, 1), into `covariance`. `near` is scratch space.
void neighbours_plane(const std::vector<Eigen::Vector3f>& points, const KdTree& tree, std::size_t i, int neighbours,
                      double epsilon, std::vector<Neighbour>& near, Eigen::Matrix3d& covariance) {
  tree.knn(points[i], static_cast<std::size_t>(neighbours), std::numeric_limits<float>::infinity(), near);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Neighbour& n : near) mean += points[n.index].cast<double>();
  mean /= static_cast<double>(near.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Neighbour& n : near) {
    const Eigen::Vector3d d = points[n.index].cast<double>() - mean;
    scatter += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);  // eigenvalues ascending
  const Eigen::Matrix3d& U = solver.eigenvectors();
  const Eigen::Vector3d flattened(epsilon, 1.0, 1.0);
  covariance = U * flattened.asDiagonal() * U.transpose();
}

// Each point's plane covariance: about its own normal (config.covariance normals, the point has one:
// C = epsilon n n^T + (I - n n^T)), otherwise about its neighbours' plane.
std::vector<Eigen::Matrix3d> covariances(const Prepared& set, const KdTree& tree, const RegistrationConfig& config) {
  const bool from_normals = config.covariance == PlaneCovariance::kNormals && !set.normals.empty();
  std::vector<Eigen::Matrix3d> covariances(set.points.size());
  std::vector<Neighbour> near;
  for (std::size_t i = 0; i < set.points.size(); ++i) {
    const Eigen::Vector3d n = from_normals ? Eigen::Vector3d(set.normals[i].cast<double>()) : Eigen::Vector3d::Zero();
    if (n.squaredNorm() > 0.25) {  // unit normals, or zero where unknown
      const Eigen::Vector3d u = n.normalized();
      covariances[i] = Eigen::Matrix3d::Identity() - (1.0 - config.plane_epsilon) * u * u.transpose();
    } else {
      neighbours_plane(set.points, tree, i, config.covariance_neighbours, config.plane_epsilon, near, covariances[i]);
    }
  }
  return covariances;
}

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return S;
}

struct Fitness {
  double mean_sq_m2 = std::numeric_limits<double>::infinity();
  double inlier_ratio = 0.0;
};

Fitness fitness(const std::vector<Eigen::Vector3f>& source, const KdTree& target, const Eigen::Isometry3d& T,
                double max_distance_m) {
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  double sum = 0.0;
  std::size_t inliers = 0;
  for (const Eigen::Vector3f& s : source) {
    const Neighbour n = target.nearest(R * s + t, static_cast<float>(max_distance_m));
    if (!n.found()) continue;
    sum += static_cast<double>(n.distance_sq_m2);
    ++inliers;
  }
  Fitness f;
  if (inliers > 0) f.mean_sq_m2 = sum / static_cast<double>(inliers);
  if (!source.empty()) f.inlier_ratio = static_cast<double>(inliers) / static_cast<double>(source.size());
  return f;
}

// Gauss-Newton on SE(3), left perturbation about the source centroid c, p -> exp(omega)(p - c) + c + v,
// with xi = (radius * omega, v): d_i(xi) = b_i - p_i' ~ d_i + [p_i - c]x omega - v, p_i = T a_i, so
// J_i = [[p_i - c]x / radius, -I] and the normal equations sum J_i^T M_i J_i xi = -sum J_i^T M_i d_i with
// M_i = (C_i^B + R C_i^A R^T)^-1, solved in their eigenbasis (see the header on degenerate directions).
RegistrationResult align_native(const Prepared& source_set, const Prepared& target_set, const KdTree& target_tree,
                                const Eigen::Isometry3d& guess, const RegistrationConfig& config) {
  const std::vector<Eigen::Vector3f>& source = source_set.points;
  const std::vector<Eigen::Vector3f>& target = target_set.points;
  const float min_normal_cos = detail::min_normal_cos(config.max_normal_angle_deg);
  const bool use_normals = !source_set.normals.empty() && !target_set.normals.empty();
  const KdTree source_tree(source);
  const std::vector<Eigen::Matrix3d> source_cov = covariances(source_set, source_tree, config);
  const std::vector<Eigen::Matrix3d> target_cov = covariances(target_set, target_tree, config);
  const auto max_distance = static_cast<float>(config.max_correspondence_distance_m);

  // The centroid of the source set (at the guess) and its RMS radius: the point and scale the update is
  // parametrised about (see the header).
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3f& a : source) centroid += guess * a.cast<double>();
  centroid /= static_cast<double>(source.size());
  double radius_sq = 0.0;
  for (const Eigen::Vector3f& a : source) radius_sq += (guess * a.cast<double>() - centroid).squaredNorm();
  const double radius_m = std::max(std::sqrt(radius_sq / static_cast<double>(source.size())), 1e-3);

  RegistrationResult result;
  result.status = "max iterations";
  Eigen::Isometry3d T = guess;
  for (int iteration = 1; iteration <= config.max_iterations; ++iteration) {
    result.iterations = iteration;
    const Eigen::Matrix3d R = T.linear();
    const Eigen::Matrix3f R_f = R.cast<float>();
    Matrix6d H = Matrix6d::Zero();
    Vector6d g = Vector6d::Zero();
    std::size_t correspondences = 0;
    for (std::size_t i = 0; i < source.size(); ++i) {
      const Eigen::Vector3d p = T * source[i].cast<double>();
      const Neighbour n = target_tree.nearest(p.cast<float>(), max_distance);
      if (!n.found()) continue;
      // Opposite faces of a thin wall are near but not the same surface.
      if (use_normals &&
          !detail::normals_agree(R_f * source_set.normals[i], target_set.normals[n.index], min_normal_cos)) {
        continue;
      }
      ++correspondences;
      const Eigen::Vector3d d = target[n.index].cast<double>() - p;
      const Eigen::Matrix3d M = (target_cov[n.index] + R * source_cov[i] * R.transpose()).inverse();
      // Rotation about the centroid, scaled by the radius: J_i = [[p_i - c]x / radius, -I].
      const Eigen::Matrix3d S = skew(p - centroid) / radius_m;
      const Eigen::Matrix3d StM = S.transpose() * M;
      H.block<3, 3>(0, 0) += StM * S;
      H.block<3, 3>(0, 3) -= StM;
      H.block<3, 3>(3, 3) += M;
      g.head<3>() += StM * d;
      g.tail<3>() -= M * d;
    }
    if (correspondences < kMinPoints) {
      result.status = "degenerate";
      break;
    }
    H.block<3, 3>(3, 0) = H.block<3, 3>(0, 3).transpose();
    // The step in H's eigenbasis; directions with too little information get none.
    const Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(H);
    const Vector6d& lambda = eigen.eigenvalues();  // ascending
    if (eigen.info() != Eigen::Success || !(lambda(5) > 0.0)) {
      result.status = "degenerate";
      break;
    }
    result.information_ratio = std::max(lambda(0), 0.0) / lambda(5);
    result.degenerate_directions = 0;
    Vector6d xi_scaled = Vector6d::Zero();
    for (int k = 0; k < 6; ++k) {
      if (!(lambda(k) > config.degeneracy_ratio * lambda(5)) || !(lambda(k) > 0.0)) {
        ++result.degenerate_directions;
        continue;
      }
      const Vector6d v = eigen.eigenvectors().col(k);
      xi_scaled -= v * (v.dot(g) / lambda(k));
    }
    if (!xi_scaled.allFinite()) {
      result.status = "degenerate";
      break;
    }
    // Back to a rotation about the centroid and a translation: p -> R_step (p - c) + c + v.
    const Eigen::Vector3d omega = xi_scaled.head<3>() / radius_m;
    const Eigen::Vector3d v = xi_scaled.tail<3>();
    Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
    if (omega.norm() > 0.0) step.linear() = Eigen::AngleAxisd(omega.norm(), omega.normalized()).toRotationMatrix();
    step.translation() = centroid - step.linear() * centroid + v;
    T = step * T;
    T.linear() = Eigen::Quaterniond(T.linear()).normalized().toRotationMatrix();  // no drift from rigidity
    if (omega.norm() < config.rotation_epsilon_rad && v.norm() < config.translation_epsilon_m) {
      result.converged = true;
      result.status = "converged";
      break;
    }
  }
  result.T_target_source = T;
  return result;
}

}  // namespace

GicpRegistration::GicpRegistration(const Config& config) : config_(config) {
  const auto require = [](bool ok, const char* key, const std::string& why) {
    if (!ok) throw InputError(std::string("registration.") + key, why);
  };
  require(config_.max_iterations >= 1, "max_iterations", "must be at least 1");
  require(config_.max_correspondence_distance_m > 0.0 && std::isfinite(config_.max_correspondence_distance_m),
          "max_correspondence_distance_m", "must be positive");
  require(config_.translation_epsilon_m >= 0.0, "translation_epsilon_m", "must not be negative");
  require(config_.rotation_epsilon_rad >= 0.0, "rotation_epsilon_rad", "must not be negative");
  require(config_.voxel_size_m >= 0.0 && std::isfinite(config_.voxel_size_m), "voxel_size_m",
          "must be 0 (no sampling) or positive");
  require(config_.covariance_neighbours >= 3, "covariance_neighbours", "must be at least 3");
  require(config_.plane_epsilon > 0.0 && config_.plane_epsilon <= 1.0, "plane_epsilon", "must be in (0, 1]");
  require(config_.max_normal_angle_deg >= 0.0 && config_.max_normal_angle_deg <= 180.0, "max_normal_angle_deg",
          "must be in [0, 180]");
  require(config_.degeneracy_ratio >= 0.0 && config_.degeneracy_ratio < 1.0, "degeneracy_ratio", "must be in [0, 1)");
}

RegistrationResult GicpRegistration::align(const core::PointCloud& source, const core::PointCloud& target,
                                           const Eigen::Isometry3d& T_target_source_guess) const {
  if (!config_.enabled) {
    RegistrationResult result;
    result.T_target_source = T_target_source_guess;
    result.status = "disabled";
    return result;
  }
  const Prepared source_set = prepare(source, config_.voxel_size_m);
  const Prepared target_set = prepare(target, config_.voxel_size_m);
  const std::vector<Eigen::Vector3f>& source_points = source_set.points;
  const std::vector<Eigen::Vector3f>& target_points = target_set.points;
  RegistrationResult result;
  // PCL's GICP needs covariance_neighbours points in each cloud for their covariances: with fewer it only
  // logs an error and then reads covariances it never computed.
  const std::size_t min_points = config_.backend == RegistrationBackend::kPcl
                                     ? std::max(kMinPoints, static_cast<std::size_t>(std::max(0, config_.covariance_neighbours)) + 1)
                                     : kMinPoints;
  if (source_points.size() < min_points || target_points.size() < min_points || !T_target_source_guess.matrix().allFinite()) {
    result.T_target_source = T_target_source_guess;
    result.source_points = source_points.size();
    result.target_points = target_points.size();
    result.status = "too few points";
    return result;
  }
  const KdTree target_tree(target_points);
  if (config_.backend == RegistrationBackend::kPcl) {
    const detail::PclAlignment pcl = detail::align_with_pcl(source_points, target_points, T_target_source_guess, config_);
    result.T_target_source = pcl.T_target_source;
    result.converged = pcl.converged;
    result.iterations = pcl.iterations;
    result.status = pcl.converged ? "converged" : "max iterations";
  } else {
    result = align_native(source_set, target_set, target_tree, T_target_source_guess, config_);
  }
  result.source_points = source_points.size();
  result.target_points = target_points.size();
  const Fitness f = fitness(source_points, target_tree, result.T_target_source, config_.max_correspondence_distance_m);
  result.fitness_m2 = f.mean_sq_m2;
  result.inlier_ratio = f.inlier_ratio;
  return result;
}

}  // namespace fleetslam::central
