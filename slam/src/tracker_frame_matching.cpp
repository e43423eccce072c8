// Frame-to-frame stages of tracking (last frame with the motion model, reference keyframe) and the
// pose-only optimisation they share with the local map stage.

#include <vector>

#include <spdlog/logger.h>

#include "fleetslam/slam/tracker.hpp"
#include "frame_observation.hpp"
#include "stopwatch.hpp"
#include "tracker_working.hpp"

namespace fleetslam::slam {
namespace {

// The 3D points of B's features in B's camera frame: live map points, else (optionally) extra points.
struct SourcePoints {
  FeaturePoints points;
  std::vector<MapPointId> map_point;  // per feature, kNoMapPoint for extra points
};

SourcePoints source_points(const Frame& b, const Eigen::Isometry3d& T_b_world, const Map& map,
                           const std::vector<std::optional<Eigen::Vector3d>>* extra) {
  SourcePoints s{FeaturePoints(b.size()), std::vector<MapPointId>(b.size(), kNoMapPoint)};
  for (std::size_t j = 0; j < b.size(); ++j) {
    const MapPointId id = b.map_points[j] == kNoMapPoint ? kNoMapPoint : map.resolve(b.map_points[j]);
    if (id != kNoMapPoint) {
      s.points[j] = T_b_world * map.point(id)->position;
      s.map_point[j] = id;
    } else if (extra != nullptr && j < extra->size()) {
      s.points[j] = (*extra)[j];
    }
  }
  return s;
}

// Runs the projection matcher, once more with a doubled radius when it finds too few (ORB-SLAM).
MatchResult match_with_retry(const Frame& a, const Frame& b, const FeaturePoints& p_b, const Eigen::Isometry3d& T_a_b,
                             MatcherConfig config, int min_matches) {
  const FeaturePoints p_a = points_from_depth(a);
  MatchResult m = match_by_projection(a, p_a, b, p_b, T_a_b, config);
  if (static_cast<int>(m.matches.size()) >= min_matches) return m;
  config.radius_px *= 2.0;
  return match_by_projection(a, p_a, b, p_b, T_a_b, config);
}

}  // namespace

int Tracker::optimize(Working& w, const Map& map, const Eigen::Isometry3d& T_cam_world_initial,
                      TrackingResult& result) {
  const Stopwatch watch;
  Frame& f = w.frame;
  std::vector<PoseObservation> observations;
  std::vector<std::size_t> feature_of;
  for (std::size_t i = 0; i < f.size(); ++i) {
    const MapPoint* p = f.map_points[i] == kNoMapPoint ? nullptr : map.point(f.map_points[i]);
    if (p == nullptr && !w.temporary[i]) continue;
    PoseObservation o;
    o.p_world = p != nullptr ? p->position : *w.temporary[i];
    o.obs = observation_of(f, i);
    observations.push_back(o);
    feature_of.push_back(i);
  }
  const PoseResult r = optimize_pose(f.camera, f.bf, observations, T_cam_world_initial, config_.pose_optimizer);
  result.timings.pose_ms += watch.elapsed_ms();
  f.outlier.assign(f.size(), false);
  if (!r.ok) {
    f.T_world_cam = T_cam_world_initial.inverse();
    return 0;
  }
  f.T_world_cam = r.T_cam_world.inverse();
  int map_inliers = 0;
  w.temporary_inliers = 0;
  for (std::size_t k = 0; k < feature_of.size(); ++k) {
    const std::size_t i = feature_of[k];
    f.outlier[i] = r.outlier[k];
    if (r.outlier[k]) continue;
    (f.map_points[i] != kNoMapPoint ? map_inliers : w.temporary_inliers) += 1;
  }
  return map_inliers;
}

bool Tracker::track_last_frame(Working& w, Map& map, TrackingResult& result) {
  const std::optional<Eigen::Isometry3d> T_cw = predicted_pose(map, w.frame.t_ns);
  const std::optional<Eigen::Isometry3d> T_wl = last_frame_pose(map);
  if (!T_cw || !T_wl) return false;
  const Stopwatch watch;
  const SourcePoints last = source_points(*last_frame_, T_wl->inverse(), map,
                                          config_.last_frame_depth_points ? &last_depth_points_ : nullptr);
  const MatchResult m = match_with_retry(w.frame, *last_frame_, last.points, *T_cw * *T_wl, config_.matcher,
                                         config_.min_frame_matches);
  result.timings.match_ms += watch.elapsed_ms();
  result.frame_matches = static_cast<int>(m.matches.size());
  if (result.frame_matches < config_.min_frame_matches) return false;
  for (const Match& match : m.matches) {
    const auto a = static_cast<std::size_t>(match.a), b = static_cast<std::size_t>(match.b);
    if (last.map_point[b] != kNoMapPoint) {
      w.frame.map_points[a] = last.map_point[b];
    } else {
      w.temporary[a] = *T_wl * *last.points[b];
    }
  }
  const int inliers = optimize(w, map, *T_cw, result);
  w.drop_outliers();
  result.stage = "motion_model";
  logger_->debug("t={} motion model: {} matches ({} rejected by cross-check), {} map + {} temporary inliers",
                 core::format_seconds(w.frame.t_ns, 6), m.matches.size(), m.rejected_by_cross_check, inliers,
                 w.temporary_inliers);
  // Temporary points fix the pose as well as map points do; the local map stage decides on the map.
  return inliers + w.temporary_inliers >= config_.min_frame_inliers;
}

// Matches the frame with the reference keyframe's points seen from `T_cw` and optimises the pose;
// returns the map-point inliers (outliers dropped).
int Tracker::match_reference(Working& w, const Keyframe& ref, const Map& map, const Eigen::Isometry3d& T_cw,
                             const MatcherConfig& matcher, TrackingResult& result) {
  const Stopwatch watch;
  const SourcePoints points = source_points(ref.frame, ref.T_cam_world(), map, nullptr);
  const MatchResult m =
      match_with_retry(w.frame, ref.frame, points.points, T_cw * ref.T_world_cam, matcher, config_.min_frame_matches);
  result.timings.match_ms += watch.elapsed_ms();
  result.frame_matches = static_cast<int>(m.matches.size());
  if (result.frame_matches < config_.min_frame_matches) return 0;
  for (const Match& match : m.matches) {
    w.frame.map_points[static_cast<std::size_t>(match.a)] = points.map_point[static_cast<std::size_t>(match.b)];
  }
  const int inliers = optimize(w, map, T_cw, result);
  w.drop_outliers();
  return inliers;
}

// Without a usable prediction the prior may be far off: a wide window without the cross-check (whose
// second stage would reject every match that the pose error displaces by more than r2) gives a first
// pose; the regular matcher then runs from that pose.
int Tracker::match_reference_from(Working& w, const Keyframe& ref, const Map& map, const Eigen::Isometry3d& T_cw_prior,
                                  TrackingResult& result) {
  MatcherConfig wide = config_.matcher;
  wide.radius_px *= config_.reference_radius_factor;
  wide.cross_validation = false;
  const int coarse = match_reference(w, ref, map, T_cw_prior, wide, result);
  if (coarse < config_.min_frame_inliers) return coarse;
  const Eigen::Isometry3d T_cw = w.frame.T_world_cam->inverse();
  w.clear_matches();
  const int inliers = match_reference(w, ref, map, T_cw, config_.matcher, result);
  logger_->debug("t={} reference keyframe {}: {} inliers from the prior, {} from the refined pose",
                 core::format_seconds(w.frame.t_ns, 6), ref.id, coarse, inliers);
  return inliers;
}

// Priors: the last good pose; while recovering from a loss also the constant-velocity guess first (the
// camera usually keeps turning through a blurred stretch).
bool Tracker::track_reference_keyframe(Working& w, Map& map, TrackingResult& result, bool recovering) {
  const auto live = map.live_keyframe(reference_keyframe_);
  const std::optional<Eigen::Isometry3d> T_wl = last_frame_pose(map);
  if (!live || !T_wl) {
    result.reason = "no reference keyframe";
    return false;
  }
  const Keyframe& ref = *map.keyframe(live->first);
  std::vector<Eigen::Isometry3d> priors;
  if (recovering) {
    if (const std::optional<Eigen::Isometry3d> T_cw = predicted_pose(map, w.frame.t_ns)) priors.push_back(*T_cw);
  }
  priors.push_back(T_wl->inverse());
  int inliers = 0;
  for (const Eigen::Isometry3d& prior : priors) {
    w.clear_matches();
    inliers = match_reference_from(w, ref, map, prior, result);
    if (inliers >= config_.min_frame_inliers) break;
  }
  result.stage = "reference_keyframe";
  if (inliers < config_.min_frame_inliers) {
    result.reason = std::to_string(inliers) + " inliers against the reference keyframe";
    return false;
  }
  return true;
}

}  // namespace fleetslam::slam
