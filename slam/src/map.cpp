// Map storage: keyframes, map points and the two-way links between points and features.

#include "fleetslam/slam/map.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "fleetslam/core/error.hpp"

namespace fleetslam::slam {

Descriptor descriptor_row(const cv::Mat& descriptors, int row) {
  FLEETSLAM_CHECK(descriptors.type() == CV_8UC1 && descriptors.cols == 32, "descriptors must be N x 32 CV_8UC1");
  FLEETSLAM_CHECK(row >= 0 && row < descriptors.rows, "descriptor row out of range");
  Descriptor d;
  const std::uint8_t* p = descriptors.ptr<std::uint8_t>(row);
  std::copy(p, p + d.size(), d.begin());
  return d;
}

int MapPoint::predict_level(double distance_m, const ScalePyramid& pyramid) const {
  if (!(distance_m > 0.0) || pyramid.levels <= 1) return 0;
  const double ratio = max_distance_m / distance_m;
  const int level = static_cast<int>(std::ceil(std::log(ratio) / std::log(pyramid.scale_factor)));
  return std::clamp(level, 0, pyramid.levels - 1);
}

std::vector<KeyframeId> Keyframe::best_covisible(int n) const {
  std::vector<KeyframeId> ids;
  for (const auto& [neighbour, weight] : neighbours) {
    if (n >= 0 && static_cast<int>(ids.size()) >= n) break;
    ids.push_back(neighbour);
  }
  return ids;
}

std::vector<KeyframeId> Keyframe::covisible_with_weight(int min_weight) const {
  std::vector<KeyframeId> ids;
  for (const auto& [neighbour, weight] : neighbours) {
    if (weight < min_weight) break;  // neighbours are sorted by weight
    ids.push_back(neighbour);
  }
  return ids;
}

int Keyframe::tracked_points(int min_observations, const Map& map) const {
  int count = 0;
  for (MapPointId point_id : frame.map_points) {
    if (point_id == kNoMapPoint) continue;
    const MapPoint* p = map.point(point_id);
    if (p != nullptr && static_cast<int>(p->observations.size()) >= min_observations) ++count;
  }
  return count;
}

double Keyframe::median_depth(const Map& map) const {
  const Eigen::Isometry3d T_cw = T_cam_world();
  std::vector<double> depths;
  for (MapPointId point_id : frame.map_points) {
    if (point_id == kNoMapPoint) continue;
    if (const MapPoint* p = map.point(point_id)) depths.push_back((T_cw * p->position).z());
  }
  if (depths.empty()) return 1.0;
  const auto mid = depths.begin() + static_cast<std::ptrdiff_t>(depths.size() / 2);
  std::nth_element(depths.begin(), mid, depths.end());
  return *mid;
}

KeyframeId Map::add_keyframe(const Frame& frame, const Eigen::Isometry3d& T_world_cam, int component) {
  Keyframe kf;
  kf.id = next_keyframe_id_++;
  kf.t_ns = frame.t_ns;
  kf.component = component;
  kf.root = components_.insert(component).second;
  kf.T_world_cam = T_world_cam;
  kf.frame = frame;
  kf.frame.descriptors = frame.descriptors.clone();  // the map owns its copy (value semantics)
  kf.frame.map_points.assign(frame.size(), kNoMapPoint);
  kf.frame.outlier.assign(frame.size(), false);
  kf.frame.T_world_cam.reset();  // the keyframe's pose is T_world_cam above, one source of truth
  const KeyframeId id = kf.id;
  keyframes_.emplace(id, std::move(kf));
  return id;
}

MapPointId Map::add_map_point(const Eigen::Vector3d& position_world, KeyframeId kf, int feature) {
  FLEETSLAM_CHECK(keyframe(kf) != nullptr, "add_map_point: unknown keyframe " + std::to_string(kf));
  MapPoint p;
  p.id = next_point_id_++;
  p.position = position_world;
  p.reference_keyframe = kf;
  p.first_keyframe = kf;
  const MapPointId id = p.id;
  points_.emplace(id, std::move(p));
  add_observation(id, kf, feature);
  update_point_statistics(id);
  return id;
}

void Map::add_observation(MapPointId point_id, KeyframeId kf_id, int feature) {
  MapPoint* p = point(point_id);
  Keyframe* kf = keyframe(kf_id);
  FLEETSLAM_CHECK(p != nullptr && kf != nullptr, "add_observation: unknown point or keyframe");
  FLEETSLAM_CHECK(feature >= 0 && static_cast<std::size_t>(feature) < kf->frame.size(), "feature out of range");
  FLEETSLAM_CHECK(kf->frame.map_points[static_cast<std::size_t>(feature)] == kNoMapPoint, "feature already linked");
  FLEETSLAM_CHECK(p->observations.count(kf_id) == 0, "point already observed by the keyframe");
  kf->frame.map_points[static_cast<std::size_t>(feature)] = point_id;
  p->observations.emplace(kf_id, feature);
}

void Map::unlink_feature(KeyframeId kf_id, int feature) {
  if (Keyframe* kf = keyframe(kf_id)) kf->frame.map_points[static_cast<std::size_t>(feature)] = kNoMapPoint;
}

void Map::erase_observation(MapPointId point_id, KeyframeId kf_id) {
  MapPoint* p = point(point_id);
  if (p == nullptr) return;
  const auto it = p->observations.find(kf_id);
  if (it == p->observations.end()) return;
  unlink_feature(kf_id, it->second);
  p->observations.erase(it);
  if (p->observations.empty()) {
    points_.erase(point_id);
    return;
  }
  if (p->reference_keyframe == kf_id) p->reference_keyframe = p->observations.begin()->first;
}

void Map::erase_map_point(MapPointId point_id) {
  const MapPoint* p = point(point_id);
  if (p == nullptr) return;
  for (const auto& [kf_id, feature] : p->observations) unlink_feature(kf_id, feature);
  points_.erase(point_id);
}

void Map::replace_map_point(MapPointId old_id, MapPointId by_id) {
  if (old_id == by_id) return;
  MapPoint* old_point = point(old_id);
  MapPoint* by = point(by_id);
  FLEETSLAM_CHECK(old_point != nullptr && by != nullptr, "replace_map_point: unknown point");
  for (const auto& [kf_id, feature] : old_point->observations) {
    Keyframe* kf = keyframe(kf_id);
    if (kf == nullptr) continue;
    if (by->observations.count(kf_id) == 0) {
      kf->frame.map_points[static_cast<std::size_t>(feature)] = by_id;
      by->observations.emplace(kf_id, feature);
    } else {
      kf->frame.map_points[static_cast<std::size_t>(feature)] = kNoMapPoint;
    }
  }
  by->visible += old_point->visible;
  by->found += old_point->found;
  points_.erase(old_id);
  replaced_by_[old_id] = by_id;
  update_point_statistics(by_id);
}

const Keyframe* Map::keyframe(KeyframeId id) const {
  const auto it = keyframes_.find(id);
  return it == keyframes_.end() ? nullptr : &it->second;
}

Keyframe* Map::keyframe(KeyframeId id) {
  const auto it = keyframes_.find(id);
  return it == keyframes_.end() ? nullptr : &it->second;
}

const MapPoint* Map::point(MapPointId id) const {
  const auto it = points_.find(id);
  return it == points_.end() ? nullptr : &it->second;
}

MapPoint* Map::point(MapPointId id) {
  const auto it = points_.find(id);
  return it == points_.end() ? nullptr : &it->second;
}

int Map::weighted_observations(const MapPoint& p) const {
  int weight = 0;
  for (const auto& [kf_id, feature] : p.observations) {
    const Keyframe* kf = keyframe(kf_id);
    weight += kf != nullptr && kf->frame.has_depth(static_cast<std::size_t>(feature)) ? 2 : 1;
  }
  return weight;
}

MapPointId Map::resolve(MapPointId id) const {
  // Replacement chains are short (a point is fused a few times at most); the bound guards cycles.
  for (int hops = 0; hops < 64 && id != kNoMapPoint; ++hops) {
    if (points_.count(id) > 0) return id;
    const auto it = replaced_by_.find(id);
    if (it == replaced_by_.end()) return kNoMapPoint;
    id = it->second;
  }
  return kNoMapPoint;
}

std::vector<MapPointId> Map::point_ids() const {
  std::vector<MapPointId> ids;
  ids.reserve(points_.size());
  for (const auto& entry : points_) ids.push_back(entry.first);
  std::sort(ids.begin(), ids.end());
  return ids;
}

std::optional<std::pair<KeyframeId, Eigen::Isometry3d>> Map::live_keyframe(KeyframeId id) const {
  Eigen::Isometry3d T_live_kf = Eigen::Isometry3d::Identity();
  for (std::size_t hops = 0; hops <= culled_.size(); ++hops) {
    if (keyframes_.count(id) > 0) return std::make_pair(id, T_live_kf);
    const auto it = culled_.find(id);
    if (it == culled_.end()) return std::nullopt;
    T_live_kf = it->second.T_parent_kf * T_live_kf;
    id = it->second.parent;
  }
  return std::nullopt;
}

std::optional<Eigen::Isometry3d> Map::keyframe_pose(KeyframeId id) const {
  const auto live = live_keyframe(id);
  if (!live) return std::nullopt;
  return keyframes_.at(live->first).T_world_cam * live->second;
}

}  // namespace fleetslam::slam
