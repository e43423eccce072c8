// Local mapping: keyframe insertion, recent point culling and the inline sequence of all steps.

#include "fleetslam/slam/local_mapping.hpp"

#include <algorithm>
#include <numeric>

#include <spdlog/logger.h>

#include "fleetslam/core/error.hpp"
#include "stopwatch.hpp"

namespace fleetslam::slam {

OptimizerConfig LocalMappingConfig::default_ba() {
  OptimizerConfig c;
  c.rounds = 2;  // ORB-SLAM: optimise, drop chi-square outliers, optimise again
  c.iterations_per_round = 10;
  return c;
}

LocalMapper::LocalMapper(const LocalMappingConfig& config, core::Logger logger)
    : config_(config), logger_(std::move(logger)) {
  FLEETSLAM_CHECK(logger_ != nullptr, "LocalMapper needs a logger (core::null_logger() discards)");
}

namespace {

// Links the keyframe to the points tracking matched (each point once).
void observe_tracked_points(const Frame& frame, KeyframeId id, Map& map) {
  for (std::size_t i = 0; i < frame.size(); ++i) {
    const MapPointId point = frame.map_points[i] == kNoMapPoint ? kNoMapPoint : map.resolve(frame.map_points[i]);
    if (point == kNoMapPoint || frame.outlier[i] || map.point(point)->observations.count(id) > 0) continue;
    map.add_observation(point, id, static_cast<int>(i));
    map.update_point_statistics(point);
  }
}

// Free features with depth, nearest first (ties: lower index), as ORB-SLAM orders them.
std::vector<std::size_t> free_depth_features(const Keyframe& kf) {
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < kf.frame.size(); ++i) {
    if (kf.frame.map_points[i] == kNoMapPoint && kf.frame.has_depth(i)) order.push_back(i);
  }
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return kf.frame.depth_m[a] < kf.frame.depth_m[b]; });
  return order;
}

}  // namespace

KeyframeId LocalMapper::insert_keyframe(const Frame& frame, int component, bool initial, Map& map,
                                        MappingReport* report) {
  FLEETSLAM_CHECK(frame.T_world_cam.has_value(), "insert_keyframe: the frame has no pose");
  const KeyframeId id = map.add_keyframe(frame, *frame.T_world_cam, component);
  observe_tracked_points(frame, id, map);
  const Keyframe& kf = *map.keyframe(id);
  int created = 0;
  for (std::size_t i : free_depth_features(kf)) {
    // Close points are reliable; a few far ones keep the map usable when little is close.
    const bool far = kf.frame.close_depth_m > 0.0 && kf.frame.depth_m[i] > kf.frame.close_depth_m;
    if (!initial && far && created >= config_.min_new_depth_points) break;
    const std::optional<Eigen::Vector3d> p_cam = kf.frame.unproject(i);
    if (!p_cam) continue;
    const MapPointId point = map.add_map_point(kf.T_world_cam * *p_cam, id, static_cast<int>(i));
    if (!initial) recent_points_.push_back(point);
    ++created;
  }
  map.update_connections(id, config_.covisibility_min_weight);
  if (report != nullptr) {
    report->keyframe = id;
    report->new_depth_points = created;
  }
  return id;
}

int LocalMapper::cull_recent_points(KeyframeId current, Map& map) {
  int culled = 0;
  std::vector<MapPointId> kept;
  for (MapPointId id : recent_points_) {
    const MapPoint* p = map.point(id);
    if (p == nullptr) continue;
    const KeyframeId age = current - p->first_keyframe;  // keyframes inserted since it was created
    if (p->found_ratio() < config_.cull_found_ratio ||
        (age >= 2 && map.weighted_observations(*p) <= config_.cull_min_observations)) {
      map.erase_map_point(id);
      ++culled;
    } else if (age < 3) {
      kept.push_back(id);  // still on probation
    }
  }
  recent_points_ = std::move(kept);
  return culled;
}

void LocalMapper::fuse_or_link(KeyframeId current, Map& map, MappingReport& report) {
  if (config_.fuse) {
    report.fused = fuse(current, map);  // ends by updating the keyframe's covisibility
  } else if (report.triangulated > 0) {
    // The new points' observations must reach the covisibility weights the BA window, the keyframe culling
    // and the next triangulation use; fuse() updates them otherwise.
    map.update_connections(current, config_.covisibility_min_weight);
  }
}

void LocalMapper::process(KeyframeId current, Map& map, MappingReport& report) {
  const Stopwatch watch;
  report.keyframe = current;
  report.culled_points = cull_recent_points(current, map);
  if (config_.triangulate) report.triangulated = triangulate(current, map);
  fuse_or_link(current, map, report);
  if (config_.local_ba) {
    if (const std::optional<LocalBaProblem> problem = prepare_local_ba(current, map)) {
      report.ba = apply_local_ba(*problem, solve_local_ba(*problem), map);
    }
  }
  if (config_.cull_keyframes) report.culled_keyframes = cull_keyframes(current, map);
  report.ms = watch.elapsed_ms();
  logger_->debug("keyframe {}: {} depth points, {} culled, {} triangulated, {} fused, BA {} keyframes rms {:.3f} -> "
                 "{:.3f} px ({} outlier observations), {} keyframes culled, {:.1f} ms",
                 current, report.new_depth_points, report.culled_points, report.triangulated, report.fused,
                 report.ba.adjusted.size(), report.ba.initial_rms_px, report.ba.final_rms_px,
                 report.ba.removed_observations, report.culled_keyframes.size(), report.ms);
}

}  // namespace fleetslam::slam
