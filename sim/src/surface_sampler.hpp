#pragma once
// Internal: deterministic points on the rendered static geometry of a model (ground truth for maps).

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "mujoco_util.hpp"

namespace fleetslam::sim::detail {

// Points about spacing_m apart on every visible geom (groups 0-2, not transparent) that does not belong
// to `excluded_bodies` (the robots). Infinite planes are clipped to the bounds of the other geometry.
// Supported: plane, box, sphere, capsule, ellipsoid, cylinder, mesh (height fields are skipped).
std::vector<Eigen::Vector3f> sample_static_surfaces(const mjModel* model, const mjData* data,
                                                    const std::vector<int>& excluded_bodies, double spacing_m);

}  // namespace fleetslam::sim::detail
