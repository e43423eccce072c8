#include "fleetslam/core/point_cloud.hpp"

#include <cmath>

namespace fleetslam::core {

void PointCloud::reserve(std::size_t n, bool with_colors) {
  points.reserve(n);
  if (with_colors) colors.reserve(n);
}

void PointCloud::clear() {
  points.clear();
  colors.clear();
  normals.clear();
}

void PointCloud::push_back(const Eigen::Vector3f& p) { points.push_back(p); }

void PointCloud::push_back(const Eigen::Vector3f& p, const Rgb& rgb) {
  points.push_back(p);
  colors.push_back(rgb);
}

void PointCloud::push_back(const Eigen::Vector3f& p, const Rgb& rgb, const Eigen::Vector3f& normal) {
  points.push_back(p);
  colors.push_back(rgb);
  normals.push_back(normal);
}

void PointCloud::push_back_from(const PointCloud& other, std::size_t i) {
  points.push_back(other.points[i]);
  if (other.has_colors()) colors.push_back(other.colors[i]);
  if (other.has_normals()) normals.push_back(other.normals[i]);
}

void PointCloud::append(const PointCloud& other) {
  if (other.empty()) return;  // nothing to add, and no attribute to lose
  const bool keep_colors = (empty() || has_colors()) && other.has_colors();
  // Normals have a value for "unknown" (zero): the side without them is padded, so one cloud without
  // normals does not take them from the other's points.
  const bool keep_normals = has_normals() || other.has_normals();
  if (!keep_colors) colors.clear();
  if (keep_normals && !has_normals()) normals.assign(points.size(), Eigen::Vector3f::Zero());
  if (!keep_normals) normals.clear();
  points.insert(points.end(), other.points.begin(), other.points.end());
  if (keep_colors) colors.insert(colors.end(), other.colors.begin(), other.colors.end());
  if (keep_normals) {
    if (other.has_normals()) {
      normals.insert(normals.end(), other.normals.begin(), other.normals.end());
    } else {
      normals.resize(points.size(), Eigen::Vector3f::Zero());
    }
  }
}

void transform_in_place(PointCloud& cloud, const Eigen::Isometry3d& T) {
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  for (Eigen::Vector3f& p : cloud.points) p = R * p + t;
  for (Eigen::Vector3f& n : cloud.normals) n = R * n;
}

std::vector<Eigen::Vector3f> transformed_points(const std::vector<Eigen::Vector3f>& points, const Eigen::Isometry3d& T) {
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  std::vector<Eigen::Vector3f> out;
  out.reserve(points.size());
  for (const Eigen::Vector3f& p : points) out.push_back(R * p + t);
  return out;
}

PointCloud transformed(const PointCloud& cloud, const Eigen::Isometry3d& T) {
  PointCloud out = cloud;
  transform_in_place(out, T);
  return out;
}

std::size_t remove_non_finite(PointCloud& cloud) {
  const bool colored = cloud.has_colors();
  const bool with_normals = cloud.has_normals();
  std::size_t kept = 0;
  for (std::size_t i = 0; i < cloud.points.size(); ++i) {
    if (!cloud.points[i].allFinite()) continue;
    cloud.points[kept] = cloud.points[i];
    if (colored) cloud.colors[kept] = cloud.colors[i];
    if (with_normals) {
      const Eigen::Vector3f& n = cloud.normals[i];
      cloud.normals[kept] = n.allFinite() ? n : Eigen::Vector3f::Zero();  // unknown, not opposite to all
    }
    ++kept;
  }
  const std::size_t dropped = cloud.points.size() - kept;
  cloud.points.resize(kept);
  if (colored) cloud.colors.resize(kept);
  if (with_normals) cloud.normals.resize(kept);
  return dropped;
}

Bounds3f bounds(const PointCloud& cloud) {
  Bounds3f b;
  bool any = false;
  for (const Eigen::Vector3f& p : cloud.points) {
    if (!p.allFinite()) continue;
    if (!any) {
      b.min = b.max = p;
      any = true;
    } else {
      b.min = b.min.cwiseMin(p);
      b.max = b.max.cwiseMax(p);
    }
  }
  return b;
}

}  // namespace fleetslam::core
