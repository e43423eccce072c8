// The PCL GICP backend: the one source of the module that includes PCL (each PCL source costs ~40 s and
// 1.2 GB to compile), kept for comparison with the native backend (see registration.hpp).

#include "with_pcl/registration_pcl.hpp"

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/gicp.h>

namespace fleetslam::central::detail {
namespace {

using PclCloud = pcl::PointCloud<pcl::PointXYZ>;

// Exposes the iteration count, which PCL keeps protected.
class Gicp : public pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> {
 public:
  int iterations() const { return nr_iterations_; }
};

PclCloud::Ptr to_pcl(const std::vector<Eigen::Vector3f>& points) {
  PclCloud::Ptr cloud(new PclCloud);
  cloud->reserve(points.size());
  for (const Eigen::Vector3f& p : points) cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  return cloud;
}

}  // namespace

PclAlignment align_with_pcl(const std::vector<Eigen::Vector3f>& source, const std::vector<Eigen::Vector3f>& target,
                            const Eigen::Isometry3d& T_target_source_guess, const RegistrationConfig& config) {
  Gicp gicp;
  gicp.setInputSource(to_pcl(source));
  gicp.setInputTarget(to_pcl(target));
  gicp.setMaximumIterations(config.max_iterations);
  gicp.setMaxCorrespondenceDistance(config.max_correspondence_distance_m);
  gicp.setTransformationEpsilon(config.translation_epsilon_m);
  gicp.setRotationEpsilon(config.rotation_epsilon_rad);
  gicp.setCorrespondenceRandomness(config.covariance_neighbours);
  PclCloud aligned;
  gicp.align(aligned, T_target_source_guess.matrix().cast<float>());
  PclAlignment result;
  result.T_target_source.matrix() = gicp.getFinalTransformation().cast<double>();
  result.iterations = gicp.iterations();
  // PCL reports convergence also when it ran out of iterations (gicp.hpp: nr_iterations_ >= max_iterations_
  // sets converged_).
  result.converged = gicp.hasConverged() && result.iterations < config.max_iterations;
  return result;
}

}  // namespace fleetslam::central::detail
