#pragma once
// Synthetic world-frame clouds for the planners' tests: floors, walls and boxes sampled on regular grids.

#include <cmath>
#include <functional>
#include <utility>
#include <vector>

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

// A grid of [0, w] x [0, h] metres at resolution_m, free except where occupied(cell centre) holds, with a
// one-cell occupied border.
inline OccupancyGrid make_grid(double w_m, double h_m, const std::function<bool(const Eigen::Vector2d&)>& occupied,
                               double robot_radius_m = 0.2, double resolution_m = 0.05) {
  OccupancyGridConfig config = grid_config(robot_radius_m);
  config.resolution_m = resolution_m;
  OccupancyGrid grid(config);
  const int w = static_cast<int>(std::lround(w_m / resolution_m));
  const int h = static_cast<int>(std::lround(h_m / resolution_m));
  std::vector<CellState> cells(static_cast<std::size_t>(w) * static_cast<std::size_t>(h), CellState::kFree);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const Eigen::Vector2d c = resolution_m * Eigen::Vector2d(x + 0.5, y + 0.5);
      const bool border = x == 0 || y == 0 || x == w - 1 || y == h - 1;
      if (border || occupied(c)) cells[static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)] = CellState::kOccupied;
    }
  }
  grid.set_cells(Eigen::Vector2d::Zero(), w, h, std::move(cells));
  return grid;
}

}  // namespace fleetslam::planners::test
