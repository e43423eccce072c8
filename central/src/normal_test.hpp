#pragma once
// Internal: the normal check shared by the coarse overlap and GICP (PointCloud::normals; zero: unknown).

#include <cmath>

#include <Eigen/Core>

namespace fleetslam::central::detail {

// cos(max_angle_deg), or below -1 for 180 (and more): then every pair agrees, rounding included.
inline float min_normal_cos(double max_angle_deg) {
  constexpr double kRadiansPerDegree = 3.14159265358979323846 / 180.0;
  return max_angle_deg >= 180.0 ? -2.0f : static_cast<float>(std::cos(max_angle_deg * kRadiansPerDegree));
}

// Whether two normals may belong to the same surface: either unknown, or at most the angle apart.
inline bool normals_agree(const Eigen::Vector3f& a, const Eigen::Vector3f& b, float min_cos) {
  return a.isZero() || b.isZero() || a.dot(b) >= min_cos;
}

}  // namespace fleetslam::central::detail
