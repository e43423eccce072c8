#pragma once
// Fine matching (PAPER.md section 4, paper eqs. 8-12): generalized ICP (Segal et al. 2009) between the
// overlap sets. Each point gets a plane covariance, eigenvalues (plane_epsilon, 1, 1) ("plane-to-plane"),
// about the plane of its `covariance_neighbours` nearest points in the sampled set (covariance:
// neighbours, as PCL) or about its own normal (covariance: normals; the dense maps' normals come from the
// depth image, a few pixels across; points without one take the neighbours' plane). On sets sampled
// at 10 cm the neighbourhoods span a quarter metre and mix a doorway's wall, jamb and floor; normals keep
// each plane local (MapMerger's local hypothesis uses them). Correspondences are nearest neighbours
// within max_correspondence_distance_m; the transform minimises
//   sum_i d_i^T (C_i^B + R C_i^A R^T)^-1 d_i,  d_i = b_i - T a_i      (paper eq. 12)
// Both sets are first uniformly sampled at voxel_size_m (0: not sampled), which sets the cost. When both
// clouds carry normals (the agents' dense maps do), a pair whose normals disagree by more than
// max_normal_angle_deg (120) is no correspondence: the two faces of a 12 cm wall are nearer than most prior
// errors, and pairing them pulls the maps together by the wall's thickness.
//
// Degenerate overlaps (a corridor's floor and two walls say nothing about where along it a map lies):
// each Gauss-Newton step is solved in the eigenbasis of the normal equations' information, taken about
// the source set's centroid with rotation scaled by the set's RMS radius (so that the six directions
// compare in metres and rotation and translation do not mix through a far-away origin); directions
// whose eigenvalue is below degeneracy_ratio of the largest get no update, so they keep the guess
// (solution remapping, Zhang, Kaess & Singh, ICRA 2016). The native backend only.
//
// Backends: `native` (this project's Gauss-Newton on SE(3) with exact kd-tree correspondences, the
// default) and `pcl` (pcl::GeneralizedIterativeClosestPoint, kept for comparison). Measured on the
// overlap sets of two 200k-point synthetic rooms with a 10 cm + 5 degree prior error (bench_merge BM_Fine,
// 2-core build machine, one thread): native 47 / 140 / 196 ms vs PCL 90 / 268 / 461 ms with the sets
// sampled at 10 / 5 / 2 cm, equally accurate; hence native at 10 cm (bench_merge.cpp has all figures).

#include <cstddef>
#include <limits>
#include <string>

#include <Eigen/Geometry>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/point_cloud.hpp"

namespace fleetslam::central {

enum class RegistrationBackend { kNative, kPcl };
enum class PlaneCovariance { kNormals, kNeighbours };

struct RegistrationConfig {
  bool enabled = true;  // false: align() returns the guess (status "disabled")
  RegistrationBackend backend = RegistrationBackend::kNative;
  int max_iterations = 30;
  // Must exceed the prior's error over the overlap (see OverlapConfig::coarse_radius_m).
  double max_correspondence_distance_m = 0.5;
  // Converged when one update moves less than both epsilons.
  double translation_epsilon_m = 1e-4;
  double rotation_epsilon_rad = 1e-4;
  double voxel_size_m = 0.1;      // uniform pre-sampling of both sets (0: none); see bench_merge.cpp
  PlaneCovariance covariance = PlaneCovariance::kNeighbours;  // native backend; pcl always uses neighbours
  int covariance_neighbours = 20;  // PCL's default k
  double plane_epsilon = 1e-3;     // PCL's gicp_epsilon
  double degeneracy_ratio = 0.0;   // 0: every direction is updated (see above)
  // Native backend, clouds with normals (PointCloud::normals): a nearest neighbour whose normal differs
  // from the source point's by more than this is no correspondence (the opposite face of a thin wall).
  // 180: normals are not used.
  double max_normal_angle_deg = 120.0;  // as OverlapConfig::max_normal_angle_deg

  template <class V>
  void visit(V& v) {
    v("enabled", enabled);
    v.choice("backend", backend, {{"native", RegistrationBackend::kNative}, {"pcl", RegistrationBackend::kPcl}});
    v("max_iterations", max_iterations, core::Limits<int>{1, 1000});
    v("max_correspondence_distance_m", max_correspondence_distance_m, core::Limits<double>{1e-4, 100.0});
    v("translation_epsilon_m", translation_epsilon_m, core::Limits<double>{0.0, 1.0});
    v("rotation_epsilon_rad", rotation_epsilon_rad, core::Limits<double>{0.0, 1.0});
    v("voxel_size_m", voxel_size_m, core::Limits<double>{0.0, 10.0});
    v.choice("covariance", covariance, {{"normals", PlaneCovariance::kNormals}, {"neighbours", PlaneCovariance::kNeighbours}});
    v("covariance_neighbours", covariance_neighbours, core::Limits<int>{3, 200});
    v("plane_epsilon", plane_epsilon, core::Limits<double>{1e-9, 1.0});
    v("degeneracy_ratio", degeneracy_ratio, core::Limits<double>{0.0, 1.0});
    v("max_normal_angle_deg", max_normal_angle_deg, core::Limits<double>{0.0, 180.0});
  }
};

struct RegistrationResult {
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();  // maps source points onto the target
  bool converged = false;
  int iterations = 0;
  // After alignment, on the sampled sets: mean squared distance from the source points to their nearest
  // target point, over the source points that have one within max_correspondence_distance_m (PCL's
  // getFitnessScore), and the share of source points that have one. Sampling at voxel_size_m puts
  // neighbours up to about that far apart, so the fitness says more about density than about accuracy.
  double fitness_m2 = std::numeric_limits<double>::infinity();
  double inlier_ratio = 0.0;
  // The information about the source centroid at the last iteration (eigenvalues ascending, scaled as
  // described above): its smallest eigenvalue over its largest, and the directions that kept the guess.
  double information_ratio = 0.0;
  int degenerate_directions = 0;
  std::size_t source_points = 0;  // used, after sampling
  std::size_t target_points = 0;
  std::string status;  // "converged", "max iterations", "too few points", "degenerate", "disabled"
};

class GicpRegistration {
 public:
  using Config = RegistrationConfig;

  // Throws InputError ("registration.<key>: ...") for out-of-range settings.
  explicit GicpRegistration(const Config& config);

  // Aligns source onto target starting from the guess. Non-finite points are ignored. Failure is in the
  // result (converged false, status), never an exception.
  RegistrationResult align(const core::PointCloud& source, const core::PointCloud& target,
                           const Eigen::Isometry3d& T_target_source_guess = Eigen::Isometry3d::Identity()) const;

  const Config& config() const { return config_; }

 private:
  Config config_;
};

}  // namespace fleetslam::central
