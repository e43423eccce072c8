#pragma once
// Map points seen from a camera: the visibility test (in front, inside the image, within the point's
// scale-invariance distance range, viewing angle close enough to its mean viewing direction) and the
// projection search that matches local map points to a frame's features on its grid (ORB-SLAM's
// SearchByProjection for the local map: radius grows with the predicted pyramid level and with an
// oblique view, Hamming threshold, ratio test between the two best candidates of the same level).

#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "fleetslam/core/config.hpp"
#include "fleetslam/slam/frame.hpp"
#include "fleetslam/slam/map.hpp"

namespace fleetslam::slam {

struct ProjectionSearchConfig {
  // ORB-SLAM's th for RGB-D local map tracking (x2.5 or x4 x level scale). ORB-SLAM takes 1 for stereo;
  // here 3 for both, measured no worse on stereo (ATE RMSE with 1 -> 3, one deterministic replay each):
  // EuRoC micro 1.09 -> 0.88 mm, a synthetic stereo office (15 s) 2.90 -> 2.21 mm and 3.17 -> 3.49 mm.
  double radius_factor = 3.0;
  int max_distance = 100;      // TH_HIGH
  double nn_ratio = 0.8;       // best / second best of the same level
  double min_view_cos = 0.5;   // 60 degrees from the mean viewing direction at most
  double distance_margin = 0.2;  // the distance range is widened by this share on each side

  template <class V>
  void visit(V& v) {
    v("radius_factor", radius_factor, core::Limits<double>{0.1, 100.0});
    v("max_distance", max_distance, core::Limits<int>{0, 256});
    v("nn_ratio", nn_ratio, core::Limits<double>{0.1, 1.0});
    v("min_view_cos", min_view_cos, core::Limits<double>{-1.0, 1.0});
    v("distance_margin", distance_margin, core::Limits<double>{0.0, 1.0});
  }
};

// Where a visible map point lands in a frame.
struct ProjectedPoint {
  MapPointId id = kNoMapPoint;
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();  // undistorted pixel
  std::optional<double> u_right;                 // (virtual) right u, may be negative; none without a baseline
  double depth_m = 0.0;
  int level = 0;                                 // predicted pyramid level
  double view_cos = 1.0;
};

// nullopt when the point is not visible from the camera (T_cam_world) of `frame`.
std::optional<ProjectedPoint> project_map_point(const MapPoint& point, const Frame& frame,
                                                const Eigen::Isometry3d& T_cam_world,
                                                const ProjectionSearchConfig& config);

// Matches projected points to the features of `frame` that hold no live map point yet (a feature
// holds one point; the first match wins). A point some feature of the frame holds already is not matched
// again. Sets frame.map_points and returns the number of matches.
// `map` provides the points' descriptors.
int search_by_projection(Frame& frame, const std::vector<ProjectedPoint>& projected, const Map& map,
                         const ProjectionSearchConfig& config);

}  // namespace fleetslam::slam
