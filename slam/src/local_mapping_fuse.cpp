// Fusion of duplicated map points between the current keyframe and its neighbours (ORB-SLAM's
// SearchInNeighbors): the same scene point created twice (tracking missed a match) splits the
// observations that local BA and tracking rely on, so each point is projected into the other keyframes;
// a matching feature that holds another point merges the two (the better observed one survives), a free
// matching feature becomes a new observation.

#include <limits>
#include <set>

#include "fleetslam/slam/local_mapping.hpp"
#include "fleetslam/slam/map_projection.hpp"
#include "fleetslam/slam/matcher.hpp"

namespace fleetslam::slam {
namespace {

constexpr double kChi2Mono = 5.991;
constexpr double kChi2Stereo = 7.815;

// The feature of `kf` that best matches point p projected at `proj` (reprojection and descriptor), or -1.
int best_feature(const Keyframe& kf, const MapPoint& p, const ProjectedPoint& proj, const LocalMappingConfig& config) {
  const Frame& f = kf.frame;
  const double radius = config.fuse_radius_factor * f.pyramid.scale[static_cast<std::size_t>(proj.level)];
  int best = -1, best_distance = std::numeric_limits<int>::max();
  for (int i : f.grid.features_in_area(proj.uv.x(), proj.uv.y(), radius, proj.level - 1, proj.level)) {
    const auto k = static_cast<std::size_t>(i);
    double e2 = (proj.uv - f.uv[k]).squaredNorm();
    double chi2 = kChi2Mono;
    if (f.has_right(k) && proj.u_right) {
      e2 += (*proj.u_right - f.u_right[k]) * (*proj.u_right - f.u_right[k]);
      chi2 = kChi2Stereo;
    }
    if (e2 * f.pyramid.inv_sigma2[static_cast<std::size_t>(f.level[k])] > chi2) continue;
    const int distance = hamming_distance(p.descriptor.data(), f.descriptors.ptr<std::uint8_t>(i));
    if (distance < best_distance) best = i, best_distance = distance;
  }
  return best_distance <= config.fuse_max_distance ? best : -1;
}

int fuse_into(KeyframeId target, const std::vector<MapPointId>& points, Map& map, const LocalMappingConfig& config) {
  ProjectionSearchConfig visibility;
  visibility.distance_margin = 0.2;
  int fused = 0;
  for (MapPointId listed : points) {
    const MapPointId id = map.resolve(listed);
    const MapPoint* p = map.point(id);
    const Keyframe* kf = map.keyframe(target);
    if (p == nullptr || kf == nullptr || p->observations.count(target) > 0) continue;
    const std::optional<ProjectedPoint> proj = project_map_point(*p, kf->frame, kf->T_cam_world(), visibility);
    if (!proj) continue;
    const int feature = best_feature(*kf, *p, *proj, config);
    if (feature < 0) continue;
    const MapPointId held = kf->frame.map_points[static_cast<std::size_t>(feature)];
    if (held == kNoMapPoint) {
      map.add_observation(id, target, feature);
    } else if (map.point(held)->observations.size() > p->observations.size()) {
      map.replace_map_point(id, held);
    } else {
      map.replace_map_point(held, id);
    }
    ++fused;
  }
  return fused;
}

std::vector<MapPointId> points_of(const Keyframe& kf) {
  std::vector<MapPointId> points;
  for (MapPointId id : kf.frame.map_points) {
    if (id != kNoMapPoint) points.push_back(id);
  }
  return points;
}

}  // namespace

int LocalMapper::fuse(KeyframeId current, Map& map) {
  const Keyframe* kf = map.keyframe(current);
  if (kf == nullptr) return 0;
  // Targets: the best covisible keyframes and, for each, its own best five (ORB-SLAM's two rings).
  std::vector<KeyframeId> targets;
  std::set<KeyframeId> seen{current};
  for (KeyframeId first : kf->best_covisible(config_.fuse_neighbours)) {
    if (seen.insert(first).second) targets.push_back(first);
    for (KeyframeId second : map.keyframe(first)->best_covisible(5)) {
      if (seen.insert(second).second) targets.push_back(second);
    }
  }
  int fused = 0;
  const std::vector<MapPointId> own = points_of(*kf);
  for (KeyframeId target : targets) fused += fuse_into(target, own, map, config_);
  std::vector<MapPointId> theirs;
  std::set<MapPointId> listed;
  for (KeyframeId target : targets) {
    for (MapPointId id : points_of(*map.keyframe(target))) {
      if (listed.insert(id).second) theirs.push_back(id);
    }
  }
  fused += fuse_into(current, theirs, map, config_);
  for (MapPointId id : points_of(*map.keyframe(current))) map.update_point_statistics(id);
  map.update_connections(current, config_.covisibility_min_weight);
  return fused;
}

}  // namespace fleetslam::slam
