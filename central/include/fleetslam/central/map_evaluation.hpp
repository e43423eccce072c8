#pragma once
// Judging a map against ground truth (issue: "judging maps against ground truth"): the true surfaces as
// a dense sample of points (the simulator's surface_points, or any reference cloud).
//   accuracy      distance from each map point to the true surface: to the plane fitted to its nearest
//                 truth samples (so the sampling spacing does not inflate it), or to the nearest sample
//                 where the samples there are not planar; mean, median and 95th percentile (each the
//                 sorted distance at rank floor(q (n - 1)), not interpolated: maps hold 1e4+ points);
//   completeness  share of truth samples with a map point within `completeness_radius_m`.
// Map points farther than `max_distance_m` from any truth sample (outliers, moving robots seen by
// another robot) count as max_distance_m in the statistics and are counted separately.

#include <cstddef>
#include <limits>
#include <vector>

#include <Eigen/Core>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/point_cloud.hpp"

namespace fleetslam::central {

struct MapEvaluationConfig {
  double completeness_radius_m = 0.05;
  double max_distance_m = 0.5;
  int plane_neighbours = 8;  // truth samples the local plane is fitted to

  template <class V>
  void visit(V& v) {
    v("completeness_radius_m", completeness_radius_m, core::Limits<double>{1e-4, 10.0});
    v("max_distance_m", max_distance_m, core::Limits<double>{1e-3, 100.0});
    v("plane_neighbours", plane_neighbours, core::Limits<int>{3, 100});
  }
};

// What cannot be measured is NaN (written as null in JSON, failed by pass criteria): the error statistics
// of an empty map or of a map without truth, the completeness without truth. An empty map against truth
// is complete to 0.
struct MapAccuracy {
  std::size_t map_points = 0;
  std::size_t truth_points = 0;
  std::size_t far_points = 0;   // beyond max_distance_m
  double mean_m = std::numeric_limits<double>::quiet_NaN();
  double median_m = std::numeric_limits<double>::quiet_NaN();
  double p95_m = std::numeric_limits<double>::quiet_NaN();
  double completeness = std::numeric_limits<double>::quiet_NaN();  // in [0, 1]
};

MapAccuracy evaluate_map(const core::PointCloud& map_world, const std::vector<Eigen::Vector3f>& truth_world,
                         const MapEvaluationConfig& config = MapEvaluationConfig{});

}  // namespace fleetslam::central
