#pragma once
// Per-frame scratch of the tracker, shared by its source files.

#include <optional>
#include <vector>

#include <Eigen/Core>

#include "fleetslam/slam/tracker.hpp"

namespace fleetslam::slam {

struct Tracker::Working {
  explicit Working(Frame& f) : frame(f), temporary(f.size()) {}

  Frame& frame;
  // World points of features matched to the last frame's temporary depth points (not map points).
  std::vector<std::optional<Eigen::Vector3d>> temporary;
  int temporary_inliers = 0;  // after the last pose optimisation

  // Drops the matches pose optimisation flagged as outliers (map points and temporary points).
  void drop_outliers() {
    for (std::size_t i = 0; i < frame.size(); ++i) {
      if (!frame.outlier[i]) continue;
      frame.map_points[i] = kNoMapPoint;
      temporary[i].reset();
      frame.outlier[i] = false;
    }
  }
  void clear_matches() {
    frame.map_points.assign(frame.size(), kNoMapPoint);
    frame.outlier.assign(frame.size(), false);
    temporary.assign(frame.size(), std::nullopt);
  }
};

}  // namespace fleetslam::slam
