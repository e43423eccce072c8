// The local map stage of tracking and the keyframe decision.

#include <algorithm>
#include <map>
#include <set>

#include <spdlog/logger.h>

#include "fleetslam/core/se3.hpp"
#include "fleetslam/slam/tracker.hpp"
#include "stopwatch.hpp"
#include "tracker_working.hpp"

namespace fleetslam::slam {
namespace {

// Keyframes that see the frame's points, strongest first (ties: older first).
std::vector<std::pair<KeyframeId, int>> observing_keyframes(const Frame& frame, const Map& map) {
  std::map<KeyframeId, int> counts;
  for (std::size_t i = 0; i < frame.size(); ++i) {
    if (frame.map_points[i] == kNoMapPoint || frame.outlier[i]) continue;
    if (const MapPoint* p = map.point(frame.map_points[i])) {
      for (const auto& observation : p->observations) ++counts[observation.first];
    }
  }
  std::vector<std::pair<KeyframeId, int>> sorted(counts.begin(), counts.end());
  std::stable_sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
  return sorted;
}

// ORB-SLAM's local keyframes: those sharing points with the frame, then their best covisible
// neighbours, children and parent, up to a bound.
std::vector<KeyframeId> local_keyframes(const std::vector<std::pair<KeyframeId, int>>& observing, const Map& map,
                                        int neighbours_per_keyframe, int max_keyframes) {
  std::vector<KeyframeId> local;
  std::set<KeyframeId> seen;
  const auto add = [&](KeyframeId id) {
    if (static_cast<int>(local.size()) < max_keyframes && map.keyframe(id) != nullptr && seen.insert(id).second) {
      local.push_back(id);
    }
  };
  for (const auto& entry : observing) add(entry.first);
  const std::size_t first_ring = local.size();
  for (std::size_t k = 0; k < first_ring; ++k) {
    const Keyframe& kf = *map.keyframe(local[k]);
    for (KeyframeId id : kf.best_covisible(neighbours_per_keyframe)) add(id);
    for (KeyframeId id : kf.children) add(id);
    if (kf.parent >= 0) add(kf.parent);
  }
  return local;
}

// The points of `local` keyframes not in `considered` (which collects them) that are visible from
// T_cw, each counted as visible in the map when `count_visible` (the local map stage's statistics).
std::vector<ProjectedPoint> project_keyframe_points(const std::vector<KeyframeId>& local, Map& map, const Frame& f,
                                                    const Eigen::Isometry3d& T_cw, const ProjectionSearchConfig& config,
                                                    std::set<MapPointId>& considered, bool count_visible) {
  std::vector<ProjectedPoint> projected;
  for (KeyframeId kf_id : local) {
    for (MapPointId id : map.keyframe(kf_id)->frame.map_points) {
      if (id == kNoMapPoint || !considered.insert(id).second) continue;
      MapPoint* p = map.point(id);
      if (p == nullptr) continue;
      if (auto visible = project_map_point(*p, f, T_cw, config)) {
        if (count_visible) ++p->visible;
        projected.push_back(*visible);
      }
    }
  }
  return projected;
}

}  // namespace

bool Tracker::track_local_map(Working& w, Map& map, TrackingResult& result) {
  const Stopwatch watch;
  Frame& f = w.frame;
  const auto observing = observing_keyframes(f, map);
  if (observing.empty()) {
    result.reason = "no map point tracked";
    return false;
  }
  reference_keyframe_ = observing.front().first;
  std::set<MapPointId> in_frame;
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (f.map_points[i] == kNoMapPoint) continue;
    if (MapPoint* p = map.point(f.map_points[i])) {
      ++p->visible;
      in_frame.insert(p->id);
    }
  }
  const Eigen::Isometry3d T_cw = f.T_world_cam->inverse();
  std::set<MapPointId> considered = in_frame;
  const std::vector<KeyframeId> local =
      local_keyframes(observing, map, config_.local_neighbours_per_keyframe, config_.max_local_keyframes);
  const std::vector<ProjectedPoint> projected =
      project_keyframe_points(local, map, f, T_cw, config_.local_map, considered, true);
  const int found = search_by_projection(f, projected, map, config_.local_map);
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (f.map_points[i] != kNoMapPoint) w.temporary[i].reset();  // a map point beats a temporary one
  }
  result.timings.local_map_ms += watch.elapsed_ms();

  const int inliers = optimize(w, map, T_cw, result);
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (f.map_points[i] == kNoMapPoint || f.outlier[i]) continue;
    if (MapPoint* p = map.point(f.map_points[i])) ++p->found;
  }
  result.inliers = inliers;
  logger_->debug("t={} local map: {} keyframes, {} points, {} visible, {} matched + {} from the frame stage, {} inliers",
                 core::format_seconds(f.t_ns, 6), local.size(), considered.size() - in_frame.size(), projected.size(),
                 found, in_frame.size(), inliers);
  if (inliers < config_.min_local_map_inliers) {
    result.reason = std::to_string(inliers) + " inliers after local map tracking, " +
                    std::to_string(config_.min_local_map_inliers) + " needed";
    return false;
  }
  return true;
}

// Recovery with the gyro: the local map of the last tracked frame, projected from the predicted pose with a
// wider window (the translation is a guess), then pose optimisation; the regular local map stage follows.
bool Tracker::track_from_gyro(Working& w, Map& map, TrackingResult& result) {
  const std::optional<Eigen::Isometry3d> T_cw = predicted_pose(map, w.frame.t_ns);
  if (!T_cw || !last_frame_) return false;
  const Stopwatch watch;
  Frame& f = w.frame;
  std::vector<KeyframeId> local = local_keyframes(observing_keyframes(*last_frame_, map), map,
                                                  config_.local_neighbours_per_keyframe, config_.max_local_keyframes);
  if (local.empty()) {
    if (const auto live = map.live_keyframe(reference_keyframe_)) local.push_back(live->first);
  }
  ProjectionSearchConfig wide = config_.local_map;
  wide.radius_factor *= config_.gyro.recovery_radius_factor;
  std::set<MapPointId> considered;
  const std::vector<ProjectedPoint> projected = project_keyframe_points(local, map, f, *T_cw, wide, considered, false);
  const int found = search_by_projection(f, projected, map, wide);
  result.timings.local_map_ms += watch.elapsed_ms();
  result.frame_matches = found;
  result.stage = "gyro_prediction";
  if (found < config_.min_frame_matches) {
    result.reason = std::to_string(found) + " matches from the gyro-predicted pose";
    return false;
  }
  const int inliers = optimize(w, map, *T_cw, result);
  w.drop_outliers();
  logger_->debug("t={} gyro prediction: {} keyframes, {} visible points, {} matches, {} inliers",
                 core::format_seconds(f.t_ns, 6), local.size(), projected.size(), found, inliers);
  if (inliers < config_.min_frame_inliers) {
    result.reason = std::to_string(inliers) + " inliers from the gyro-predicted pose";
    return false;
  }
  return true;
}

void Tracker::decide_keyframe(Working& w, const Map& map, const TrackingInputs& inputs, TrackingResult& result) {
  const Frame& f = w.frame;
  const auto live = map.live_keyframe(reference_keyframe_);
  if (!live) return;
  const Keyframe& ref = *map.keyframe(live->first);
  KeyframeContext c;
  c.t_ns = f.t_ns;
  c.last_keyframe_t_ns = last_keyframe_t_ns_;
  c.frames_since_last_keyframe = frames_since_keyframe_;
  c.frames_since_relocalization = frames_since_relocalization_;
  for (const auto& entry : map.keyframes()) c.keyframes_in_map += entry.second.component == component_ ? 1 : 0;
  c.tracked_inliers = result.inliers;

  std::set<MapPointId> tracked;
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (f.map_points[i] != kNoMapPoint && !f.outlier[i]) tracked.insert(f.map_points[i]);
  }
  const int min_observations = c.keyframes_in_map <= 2 ? 2 : 3;
  for (MapPointId id : ref.frame.map_points) {
    const MapPoint* p = id == kNoMapPoint ? nullptr : map.point(id);
    if (p == nullptr) continue;
    c.reference_points_weighted += map.weighted_observations(*p) >= min_observations ? 1 : 0;
    if (static_cast<int>(p->observations.size()) < min_observations) continue;
    ++c.reference_points;
    c.tracked_reference_points += tracked.count(id) > 0 ? 1 : 0;
  }
  const Eigen::Isometry3d T_ref_cur = ref.T_cam_world() * *f.T_world_cam;
  c.translation_since_reference_m = T_ref_cur.translation().norm();
  c.rotation_since_reference_rad = core::rotation_angle_rad(T_ref_cur.linear());
  c.reference_median_depth_m = ref.median_depth(map);
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (!f.has_depth(i) || (f.close_depth_m > 0.0 && f.depth_m[i] > f.close_depth_m)) continue;
    const bool is_tracked = f.map_points[i] != kNoMapPoint && !f.outlier[i];
    (is_tracked ? c.close_tracked : c.close_untracked) += 1;
  }
  c.has_depth = f.bf > 0.0;
  c.local_mapping_idle = inputs.local_mapping_idle;
  c.local_mapping_queue = inputs.local_mapping_queue;
  c.fps = inputs.fps;

  KeyframeDecision d = policy_->decide(c);
  std::string factors;
  for (const auto& [name, value] : d.factors) factors += " " + name + "=" + std::to_string(value);
  logger_->debug("t={} keyframe {} ({}):{}", core::format_seconds(f.t_ns, 6), d.insert ? "yes" : "no", d.reason,
                 factors);
  result.insert_keyframe = d.insert;
  result.context = c;
  result.decision = std::move(d);
}

}  // namespace fleetslam::slam
