#pragma once
// Synthetic world-frame clouds for the planners' tests: floors, walls and boxes sampled on regular grids.

#include <Eigen/Core>

#include "fleetslam/core/point_cloud.hpp"
#include "fleetslam/planners/occupancy_grid.hpp"

namespace fleetslam::planners::test {

// Floor points (z = z_m) over [x0, x1] x [y0, y1] every step_m.
inline void add_floor(core::PointCloud& cloud, double x0, double y0, double x1, double y1, double step_m = 0.025,
                      double z_m = 0.0) {
  for (double y = y0; y <= y1 + 1e-9; y += step_m) {
    for (double x = x0; x <= x1 + 1e-9; x += step_m) {
      cloud.push_back(Eigen::Vector3f(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z_m)));
    }
  }
}

// A solid box [x0, x1] x [y0, y1] x [z0, z1] sampled every step_m (walls are thin boxes).
inline void add_box(core::PointCloud& cloud, double x0, double y0, double x1, double y1, double z0, double z1,
                    double step_m = 0.025) {
  for (double z = z0; z <= z1 + 1e-9; z += step_m) {
    for (double y = y0; y <= y1 + 1e-9; y += step_m) {
      for (double x = x0; x <= x1 + 1e-9; x += step_m) {
        cloud.push_back(Eigen::Vector3f(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)));
      }
    }
  }
}

// A room [0, w] x [0, h] with a floor and 1.2 m walls 5 cm thick just outside it.
inline core::PointCloud room(double w, double h) {
  core::PointCloud cloud;
  add_floor(cloud, 0.0, 0.0, w, h);
  add_box(cloud, -0.05, -0.05, w + 0.05, -0.01, 0.0, 1.2);
  add_box(cloud, -0.05, h + 0.01, w + 0.05, h + 0.05, 0.0, 1.2);
  add_box(cloud, -0.05, -0.05, -0.01, h + 0.05, 0.0, 1.2);
  add_box(cloud, w + 0.01, -0.05, w + 0.05, h + 0.05, 0.0, 1.2);
  return cloud;
}

inline OccupancyGridConfig grid_config(double robot_radius_m = 0.2) {
  OccupancyGridConfig config;
  config.resolution_m = 0.05;
  config.robot_radius_m = robot_radius_m;
  return config;
}

}  // namespace fleetslam::planners::test
