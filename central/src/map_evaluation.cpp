#include "fleetslam/central/map_evaluation.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "fleetslam/central/kdtree.hpp"

namespace fleetslam::central {

MapAccuracy evaluate_map(const core::PointCloud& map_world, const std::vector<Eigen::Vector3f>& truth_world,
                         const MapEvaluationConfig& config) {
  MapAccuracy out;
  std::vector<Eigen::Vector3f> truth;
  truth.reserve(truth_world.size());
  for (const Eigen::Vector3f& p : truth_world) {
    if (p.allFinite()) truth.push_back(p);
  }
  std::vector<Eigen::Vector3f> map;
  map.reserve(map_world.size());
  for (const Eigen::Vector3f& p : map_world.points) {
    if (p.allFinite()) map.push_back(p);
  }
  out.map_points = map.size();
  out.truth_points = truth.size();
  if (truth.empty()) return out;
  if (map.empty()) {
    out.completeness = 0.0;
    return out;
  }

  const float max_d = static_cast<float>(config.max_distance_m);
  const KdTree truth_tree(truth);
  std::vector<double> distances;
  distances.reserve(map.size());
  std::vector<Neighbour> near;
  for (const Eigen::Vector3f& p : map) {
    truth_tree.knn(p, static_cast<std::size_t>(config.plane_neighbours), max_d, near);
    if (near.empty()) {
      ++out.far_points;
      distances.push_back(config.max_distance_m);
      continue;
    }
    double d = std::sqrt(static_cast<double>(near.front().distance_sq_m2));
    if (near.size() >= 3) {
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (const Neighbour& n : near) mean += truth[n.index].cast<double>();
      mean /= static_cast<double>(near.size());
      Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
      for (const Neighbour& n : near) {
        const Eigen::Vector3d q = truth[n.index].cast<double>() - mean;
        cov += q * q.transpose();
      }
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
      const Eigen::Vector3d values = eig.eigenvalues();  // ascending
      // Planar where the smallest spread is well below the others: distance to the patch of that plane the
      // samples span (a disk around their mean as wide as their farthest in-plane offset). The plane alone
      // scored a point in its extension past the surface's edge (a phantom wall across a doorway) as on it.
      if (values(0) < 0.05 * values(1)) {
        const Eigen::Vector3d normal = eig.eigenvectors().col(0);
        const auto in_plane = [&normal](const Eigen::Vector3d& v) { return (v - normal.dot(v) * normal).norm(); };
        double patch_radius = 0.0;
        for (const Neighbour& n : near) patch_radius = std::max(patch_radius, in_plane(truth[n.index].cast<double>() - mean));
        const Eigen::Vector3d offset = p.cast<double>() - mean;
        const double beyond = std::max(0.0, in_plane(offset) - patch_radius);
        d = std::min(d, std::hypot(normal.dot(offset), beyond));
      }
    }
    distances.push_back(d);
  }
  double sum = 0.0;
  for (double d : distances) sum += d;
  out.mean_m = sum / static_cast<double>(distances.size());
  std::sort(distances.begin(), distances.end());
  const auto at = [&distances](double q) {
    return distances[static_cast<std::size_t>(q * static_cast<double>(distances.size() - 1))];
  };
  out.median_m = at(0.5);
  out.p95_m = at(0.95);

  const KdTree map_tree(map);
  const float radius = static_cast<float>(config.completeness_radius_m);
  std::size_t covered = 0;
  for (const Eigen::Vector3f& q : truth) covered += map_tree.nearest(q, radius).found() ? 1 : 0;
  out.completeness = static_cast<double>(covered) / static_cast<double>(truth.size());
  return out;
}

}  // namespace fleetslam::central
