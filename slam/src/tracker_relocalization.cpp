// Relocalisation of a lost tracker: BoW candidates, BoW matching, PnP-RANSAC, pose optimisation and a
// guided search by projection.

#include <algorithm>
#include <optional>
#include <set>
#include <string>

#include <opencv2/calib3d.hpp>
#include <spdlog/fmt/fmt.h>
#include <spdlog/logger.h>

#include "fleetslam/slam/tracker.hpp"
#include "stopwatch.hpp"
#include "tracker_working.hpp"

namespace fleetslam::slam {

bool Tracker::relocalize(Working& w, Map& map, const TrackingInputs& inputs, TrackingResult& result) {
  const RelocalizationConfig& c = config_.relocalization;
  if (!c.enabled) {
    result.reason = "relocalisation disabled (relocalization.enabled)";
    return false;
  }
  if (inputs.vocabulary == nullptr || inputs.database == nullptr) {
    result.reason = "relocalisation: no place recognition (place_recognition.enabled)";
    return false;
  }
  if (w.frame.size() < 4) {
    result.reason = "relocalisation: " + std::to_string(w.frame.size()) + " features";
    return false;
  }
  const BowTransform bow = inputs.vocabulary->transform(w.frame.descriptors, inputs.bow_levels_up);
  PlaceQuery query;
  query.max_results = 0;
  int tried = 0;
  int implausible = 0;
  std::string refused;
  for (const PlaceCandidate& candidate : inputs.database->query(bow.bow, query)) {
    const Keyframe* kf = map.keyframe(candidate.id);
    // Lost in a map component, the camera is looked for in it; just loaded, in the whole map (the newest
    // component may be a short one made after a loss, far from where the run starts).
    if (kf == nullptr || (!in_loaded_map_ && kf->component != component_)) continue;
    if (++tried > c.max_candidates) break;
    w.clear_matches();
    const int inliers = relocalize_with(w, *kf, bow.features, map, result);
    if (inliers >= c.min_inliers && c.check_jump && last_T_world_cam_ && w.frame.T_world_cam) {
      // The jump from the last estimate against what the camera could have moved while lost; with the
      // gyro, the rotation against the gyro's prediction for this frame.
      const double lost_s = std::max(0.0, core::ns_to_seconds(w.frame.t_ns - lost_since_ns_));
      const std::optional<Eigen::Isometry3d> T_cw_gyro =
          gyro_prediction_valid() ? predicted_pose(map, w.frame.t_ns) : std::nullopt;
      const Eigen::Isometry3d delta = last_T_world_cam_->inverse() * *w.frame.T_world_cam;
      const double shift_m = delta.translation().norm();
      const Eigen::Matrix3d turn = T_cw_gyro ? Eigen::Matrix3d(T_cw_gyro->linear() * w.frame.T_world_cam->linear())
                                             : Eigen::Matrix3d(delta.linear());
      const double turn_deg = Eigen::AngleAxisd(turn).angle() * 57.29577951308232;
      const double bound_m = c.max_jump_floor_m + c.max_jump_m_per_s * lost_s;
      const double bound_deg = T_cw_gyro ? c.max_jump_gyro_floor_deg + c.max_jump_gyro_deg_per_s * lost_s
                                         : c.max_jump_floor_deg + c.max_jump_deg_per_s * lost_s;
      if (shift_m > bound_m || turn_deg > bound_deg) {
        ++implausible;
        refused = fmt::format("keyframe {} would move the camera {:.2f} m / {:.1f} deg{} after {:.2f} s lost (bound {:.2f} m / {:.1f} deg)",
                              kf->id, shift_m, turn_deg, T_cw_gyro ? " from the gyro's rotation" : "", lost_s, bound_m, bound_deg);
        logger_->debug("t={} relocalisation refused: {}", core::format_seconds(w.frame.t_ns, 6), refused);
        continue;
      }
    }
    if (inliers >= c.min_inliers) {
      reference_keyframe_ = kf->id;
      component_ = kf->component;
      result.stage = "relocalization";
      result.relocalized = true;
      logger_->info("t={} relocalised against keyframe {} (BoW score {:.3f}, {} inliers)",
                    core::format_seconds(w.frame.t_ns, 6), kf->id, candidate.score, inliers);
      return true;
    }
  }
  w.clear_matches();
  result.reason = "relocalisation failed (" + std::to_string(std::min(tried, c.max_candidates)) + " candidates" +
                  (implausible > 0 ? ", " + std::to_string(implausible) + " refused as out of reach: " + refused : std::string()) + ")";
  return false;
}

// Inliers of the frame's pose found with one candidate keyframe (0 when it fails); the frame holds the
// inlier matches and the pose then.
int Tracker::relocalize_with(Working& w, const Keyframe& candidate, const FeatureVector& words, Map& map,
                             TrackingResult& result) {
  const RelocalizationConfig& c = config_.relocalization;
  Frame& f = w.frame;
  std::vector<bool> usable(candidate.frame.size(), false);
  for (std::size_t i = 0; i < usable.size(); ++i) {
    const MapPointId id = candidate.frame.map_points[i];
    usable[i] = id != kNoMapPoint && map.point(id) != nullptr;
  }
  const std::vector<Match> matches =
      search_by_bow(candidate.frame, candidate.bow_features, usable, f, words, {}, c.matching);
  if (static_cast<int>(matches.size()) < c.min_bow_matches) return 0;
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  for (const Match& m : matches) {
    const Eigen::Vector3d& p = map.point(candidate.frame.map_points[static_cast<std::size_t>(m.a)])->position;
    object.emplace_back(p.x(), p.y(), p.z());
    image.emplace_back(f.uv[static_cast<std::size_t>(m.b)].x(), f.uv[static_cast<std::size_t>(m.b)].y());
  }
  const cv::Matx33d K(f.camera.fx(), 0.0, f.camera.cx(), 0.0, f.camera.fy(), f.camera.cy(), 0.0, 0.0, 1.0);
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  const bool found = cv::solvePnPRansac(object, image, K, cv::noArray(), rvec, tvec, false, c.ransac_iterations,
                                        static_cast<float>(c.ransac_reprojection_px), 0.99, inliers, cv::SOLVEPNP_EPNP);
  if (!found || static_cast<int>(inliers.size()) < c.min_ransac_inliers) return 0;
  cv::Matx33d R;
  cv::Rodrigues(rvec, R);
  Eigen::Isometry3d T_cw = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) T_cw.linear()(r, k) = R(r, k);
    T_cw.translation()(r) = tvec.at<double>(r);
  }
  // cv::solvePnPRansac gates every match by one pixel threshold; ORB-SLAM's PnP solver gates each by its
  // level's sigma (chi-square, 2 dof). The inliers are taken again so at the RANSAC pose: 4 px dropped
  // correct matches of coarse levels (at level 7, sigma 3.6 px, half of them) and kept loose ones at level 0.
  std::vector<PoseObservation> pairs(matches.size());
  for (std::size_t k = 0; k < matches.size(); ++k) {
    const auto b = static_cast<std::size_t>(matches[k].b);
    pairs[k].p_world = Eigen::Vector3d(object[k].x, object[k].y, object[k].z);
    pairs[k].obs.uv = f.uv[b];
    pairs[k].obs.inv_sigma2 = f.pyramid.inv_sigma2[static_cast<std::size_t>(f.level[b])];
  }
  inliers = reprojection_inliers(f.camera, pairs, T_cw, config_.pose_optimizer.chi2_mono);
  if (static_cast<int>(inliers.size()) < c.min_ransac_inliers) return 0;
  for (int k : inliers) {
    const Match& m = matches[static_cast<std::size_t>(k)];
    f.map_points[static_cast<std::size_t>(m.b)] = candidate.frame.map_points[static_cast<std::size_t>(m.a)];
  }
  int good = optimize(w, map, T_cw, result);
  w.drop_outliers();
  if (good < c.min_ransac_inliers) return 0;
  if (good >= c.min_inliers) return good;
  // Guided search: the candidate's neighbourhood points projected at the estimated pose.
  const Eigen::Isometry3d T_cw_estimate = f.T_world_cam->inverse();
  std::vector<KeyframeId> keyframes{candidate.id};
  for (KeyframeId id : candidate.best_covisible(c.search_neighbours)) keyframes.push_back(id);
  std::set<MapPointId> seen(f.map_points.begin(), f.map_points.end());
  std::vector<ProjectedPoint> projected;
  for (KeyframeId id : keyframes) {
    for (MapPointId p : map.keyframe(id)->frame.map_points) {
      const MapPoint* point = p == kNoMapPoint ? nullptr : map.point(p);
      if (point == nullptr || !seen.insert(p).second) continue;
      if (auto proj = project_map_point(*point, f, T_cw_estimate, config_.local_map)) projected.push_back(*proj);
    }
  }
  search_by_projection(f, projected, map, config_.local_map);
  good = optimize(w, map, T_cw_estimate, result);
  w.drop_outliers();
  return good;
}

}  // namespace fleetslam::slam
