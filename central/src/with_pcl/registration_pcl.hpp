#pragma once
// Internal: the PCL GICP backend (registration_pcl.cpp, the module's only source that includes PCL).

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "fleetslam/central/registration.hpp"

namespace fleetslam::central::detail {

struct PclAlignment {
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  bool converged = false;
  int iterations = 0;
};

// Inputs finite (and already sampled); uses the config's iterations, distance, epsilons and neighbours.
PclAlignment align_with_pcl(const std::vector<Eigen::Vector3f>& source, const std::vector<Eigen::Vector3f>& target,
                            const Eigen::Isometry3d& T_target_source_guess, const RegistrationConfig& config);

}  // namespace fleetslam::central::detail
