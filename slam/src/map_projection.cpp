// Visibility of map points from a camera and the local-map projection search.

#include "fleetslam/slam/map_projection.hpp"

#include <algorithm>
#include <limits>

#include "fleetslam/slam/matcher.hpp"

namespace fleetslam::slam {

std::optional<ProjectedPoint> project_map_point(const MapPoint& point, const Frame& frame,
                                                const Eigen::Isometry3d& T_cam_world,
                                                const ProjectionSearchConfig& config) {
  const Eigen::Vector3d p_cam = T_cam_world * point.position;
  if (p_cam.z() <= 0.0) return std::nullopt;
  const core::PinholeCamera& camera = frame.camera;
  const Eigen::Vector2d uv(camera.fx() * p_cam.x() / p_cam.z() + camera.cx(),
                           camera.fy() * p_cam.y() / p_cam.z() + camera.cy());
  // Undistorted coordinates of a distorted camera spread beyond the image rectangle: the frame's bounds.
  const ImageBounds& b = frame.bounds;
  const bool inside = b.empty() ? camera.in_image(uv)
                                : uv.x() >= b.min_u && uv.x() < b.max_u && uv.y() >= b.min_v && uv.y() < b.max_v;
  if (!inside) return std::nullopt;
  // Scale invariance: ORB only sees the point over the distance range its pyramid covers.
  const Eigen::Vector3d camera_center = T_cam_world.inverse().translation();
  const Eigen::Vector3d ray = point.position - camera_center;
  const double distance = ray.norm();
  if (distance < (1.0 - config.distance_margin) * point.min_distance_m ||
      distance > (1.0 + config.distance_margin) * point.max_distance_m) {
    return std::nullopt;
  }
  const double view_cos = ray.dot(point.normal) / distance;
  if (view_cos < config.min_view_cos) return std::nullopt;
  ProjectedPoint projected;
  projected.id = point.id;
  projected.uv = uv;
  projected.depth_m = p_cam.z();
  if (frame.bf > 0.0) projected.u_right = uv.x() - frame.bf / p_cam.z();
  projected.level = point.predict_level(distance, frame.pyramid);
  projected.view_cos = view_cos;
  return projected;
}

namespace {

struct Candidate {
  int feature = -1;
  int distance = std::numeric_limits<int>::max();
  int level = -1;
  int second_distance = std::numeric_limits<int>::max();
  int second_level = -1;
};

bool feature_is_free(const Frame& frame, int feature, const Map& map) {
  const MapPointId held = frame.map_points[static_cast<std::size_t>(feature)];
  return held == kNoMapPoint || map.point(held) == nullptr;
}

Candidate best_candidate(const Frame& frame, const ProjectedPoint& p, const Descriptor& descriptor, double radius,
                         const Map& map) {
  Candidate c;
  const std::vector<int> features =
      frame.grid.features_in_area(p.uv.x(), p.uv.y(), radius, p.level - 1, p.level);
  for (int i : features) {
    if (!feature_is_free(frame, i, map)) continue;
    const auto index = static_cast<std::size_t>(i);
    // With a (virtual) right coordinate, depth must agree too: the same radius on u_right.
    if (p.u_right && frame.has_right(index) && std::abs(*p.u_right - frame.u_right[index]) > radius) {
      continue;
    }
    const int distance = hamming_distance(descriptor.data(), frame.descriptors.ptr<std::uint8_t>(i));
    if (distance < c.distance) {
      c.second_distance = c.distance, c.second_level = c.level;
      c.feature = i, c.distance = distance, c.level = frame.level[index];
    } else if (distance < c.second_distance) {
      c.second_distance = distance, c.second_level = frame.level[index];
    }
  }
  return c;
}

}  // namespace

int search_by_projection(Frame& frame, const std::vector<ProjectedPoint>& projected, const Map& map,
                         const ProjectionSearchConfig& config) {
  // Points the frame already holds (seed matches) are not matched a second time: two features on one
  // point would count it twice and pair the second with a wrong feature (ORB-SLAM's "already found").
  std::vector<MapPointId> held;
  for (const MapPointId id : frame.map_points) {
    if (id != kNoMapPoint) held.push_back(id);
  }
  std::sort(held.begin(), held.end());
  int matches = 0;
  for (const ProjectedPoint& p : projected) {
    if (std::binary_search(held.begin(), held.end(), p.id)) continue;
    const MapPoint* point = map.point(p.id);
    if (point == nullptr) continue;
    // A nearly frontal view needs a smaller window than an oblique one (ORB-SLAM's RadiusByViewingCos).
    const double view_factor = p.view_cos > 0.998 ? 2.5 : 4.0;
    const double radius = config.radius_factor * view_factor * frame.pyramid.scale[static_cast<std::size_t>(p.level)];
    const Candidate c = best_candidate(frame, p, point->descriptor, radius, map);
    if (c.feature < 0 || c.distance > config.max_distance) continue;
    if (c.level == c.second_level && c.distance > config.nn_ratio * c.second_distance) continue;
    frame.map_points[static_cast<std::size_t>(c.feature)] = p.id;
    ++matches;
  }
  return matches;
}

}  // namespace fleetslam::slam
