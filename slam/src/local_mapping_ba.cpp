// Local bundle adjustment (prepare / solve / apply) and redundant keyframe culling.

#include <algorithm>
#include <map>
#include <set>

#include "fleetslam/slam/local_mapping.hpp"
#include "frame_observation.hpp"

namespace fleetslam::slam {
namespace {

// Current keyframe and its strongest covisible neighbours.
std::vector<KeyframeId> local_window(const Keyframe& current, int max_keyframes) {
  std::vector<KeyframeId> window{current.id};
  for (KeyframeId id : current.best_covisible(max_keyframes - 1)) window.push_back(id);
  return window;
}

}  // namespace

std::optional<LocalBaProblem> LocalMapper::prepare_local_ba(KeyframeId current, const Map& map) const {
  const Keyframe* kf = map.keyframe(current);
  if (kf == nullptr) return std::nullopt;
  LocalBaProblem lp;
  lp.keyframe = current;
  lp.camera = kf->frame.camera;
  lp.bf = kf->frame.bf;
  std::map<KeyframeId, int> index;  // keyframe id -> problem index
  const auto add_keyframe = [&](KeyframeId id, bool fixed) {
    const Keyframe& k = *map.keyframe(id);
    index.emplace(id, static_cast<int>(lp.keyframe_ids.size()));
    lp.keyframe_ids.push_back(id);
    lp.problem.keyframes.push_back(BaKeyframe{k.T_cam_world(), fixed || k.root});
  };
  for (KeyframeId id : local_window(*kf, config_.max_ba_keyframes)) add_keyframe(id, false);
  std::set<MapPointId> seen;
  for (std::size_t k = 0; k < lp.keyframe_ids.size(); ++k) {
    for (MapPointId id : map.keyframe(lp.keyframe_ids[k])->frame.map_points) {
      if (id != kNoMapPoint && seen.insert(id).second) lp.point_ids.push_back(id);
    }
  }
  // Keyframes outside the window that observe local points anchor them (held fixed).
  for (std::size_t j = 0; j < lp.point_ids.size(); ++j) {
    const MapPoint& p = *map.point(lp.point_ids[j]);
    lp.problem.points_world.push_back(p.position);
    for (const auto& [kf_id, feature] : p.observations) {
      if (index.count(kf_id) == 0) add_keyframe(kf_id, true);
      const Frame& f = map.keyframe(kf_id)->frame;
      lp.problem.observations.push_back(
          BaObservation{index.at(kf_id), static_cast<int>(j), observation_of(f, static_cast<std::size_t>(feature))});
      lp.observation_of.emplace_back(kf_id, feature);
    }
  }
  const bool any_fixed = std::any_of(lp.problem.keyframes.begin(), lp.problem.keyframes.end(),
                                     [](const BaKeyframe& k) { return k.fixed; });
  // A young component has no outside anchor yet: its oldest keyframe fixes the gauge.
  if (!any_fixed) {
    const auto oldest = std::min_element(lp.keyframe_ids.begin(), lp.keyframe_ids.end());
    lp.problem.keyframes[static_cast<std::size_t>(oldest - lp.keyframe_ids.begin())].fixed = true;
  }
  const bool any_free = std::any_of(lp.problem.keyframes.begin(), lp.problem.keyframes.end(),
                                    [](const BaKeyframe& k) { return !k.fixed; });
  if (!any_free || lp.problem.observations.empty()) return std::nullopt;
  return lp;
}

BaResult LocalMapper::solve_local_ba(const LocalBaProblem& problem) const {
  return bundle_adjust(problem.camera, problem.bf, problem.problem, config_.ba);
}

LocalBaOutcome LocalMapper::apply_local_ba(const LocalBaProblem& lp, const BaResult& result, Map& map) const {
  LocalBaOutcome outcome;
  outcome.ok = result.ok;
  outcome.initial_rms_px = result.initial_rms_px;
  outcome.final_rms_px = result.final_rms_px;
  if (!result.ok) return outcome;
  // In threaded mode tracking may have changed the map meanwhile: write back only what still exists,
  // and drop an outlier observation only if the same feature still holds the same point.
  for (std::size_t k = 0; k < lp.keyframe_ids.size(); ++k) {
    Keyframe* kf = map.keyframe(lp.keyframe_ids[k]);
    if (kf == nullptr || lp.problem.keyframes[k].fixed) continue;
    kf->T_world_cam = result.T_cam_world[k].inverse();
    outcome.adjusted.push_back(kf->id);
  }
  for (std::size_t j = 0; j < lp.point_ids.size(); ++j) {
    if (MapPoint* p = map.point(lp.point_ids[j])) p->position = result.points_world[j];
  }
  for (std::size_t o = 0; o < lp.observation_of.size(); ++o) {
    if (!result.outlier[o]) continue;
    const MapPointId point = lp.point_ids[static_cast<std::size_t>(lp.problem.observations[o].point)];
    const auto& [kf_id, feature] = lp.observation_of[o];
    const Keyframe* kf = map.keyframe(kf_id);
    if (kf == nullptr || kf->frame.map_points[static_cast<std::size_t>(feature)] != point) continue;
    map.erase_observation(point, kf_id);
    ++outcome.removed_observations;
  }
  for (MapPointId id : lp.point_ids) map.update_point_statistics(id);
  return outcome;
}

namespace {

// Share of a keyframe's (close) points that enough other keyframes see at the same or a finer scale.
bool is_redundant(const Keyframe& kf, const Map& map, const LocalMappingConfig& config) {
  int points = 0, redundant = 0;
  for (std::size_t i = 0; i < kf.frame.size(); ++i) {
    const MapPoint* p = kf.frame.map_points[i] == kNoMapPoint ? nullptr : map.point(kf.frame.map_points[i]);
    if (p == nullptr) continue;
    // Depth sensors: only close points count (far ones are weak constraints anyway); close_depth_m 0: all are.
    if (kf.frame.bf > 0.0 && (!kf.frame.has_depth(i) ||
                              (kf.frame.close_depth_m > 0.0 && kf.frame.depth_m[i] > kf.frame.close_depth_m))) {
      continue;
    }
    ++points;
    if (static_cast<int>(p->observations.size()) <= config.redundant_observers) continue;
    int observers = 0;
    for (const auto& [other_id, feature] : p->observations) {
      if (other_id == kf.id) continue;
      const Keyframe* other = map.keyframe(other_id);
      if (other != nullptr && other->frame.level[static_cast<std::size_t>(feature)] <= kf.frame.level[i] + 1) {
        ++observers;
      }
    }
    if (observers >= config.redundant_observers) ++redundant;
  }
  return points > 0 && redundant > config.redundant_ratio * points;
}

}  // namespace

std::vector<KeyframeId> LocalMapper::cull_keyframes(KeyframeId current, Map& map) const {
  std::vector<KeyframeId> culled;
  const Keyframe* kf = map.keyframe(current);
  if (kf == nullptr) return culled;
  for (KeyframeId id : kf->best_covisible(-1)) {
    // Keyframes newer than `current` wait in the threaded mapper's queue: their own pass (points,
    // fusion, BA, the place-recognition database) comes first.
    if (id > current) continue;
    const Keyframe* candidate = map.keyframe(id);
    if (candidate == nullptr || candidate->root || !is_redundant(*candidate, map, config_)) continue;
    if (map.erase_keyframe(id)) culled.push_back(id);
  }
  return culled;
}

}  // namespace fleetslam::slam
