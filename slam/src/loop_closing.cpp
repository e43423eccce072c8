// Loop detection (BoW candidates, consistent groups) and geometric verification (3D-3D RANSAC, guided
// matching, pose refinement).

#include "fleetslam/slam/loop_closing.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include <Eigen/Geometry>
#include <spdlog/logger.h>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/se3.hpp"
#include "frame_observation.hpp"

namespace fleetslam::slam {

namespace {

int component_size(int component, const Map& map, KeyframeId after = -1) {
  int n = 0;
  for (const auto& [id, kf] : map.keyframes()) n += (kf.component == component && id > after) ? 1 : 0;
  return n;
}

std::vector<bool> features_with_points(const Keyframe& kf, const Map& map) {
  std::vector<bool> usable(kf.frame.size(), false);
  for (std::size_t i = 0; i < kf.frame.size(); ++i) {
    usable[i] = kf.frame.map_points[i] != kNoMapPoint && map.point(kf.frame.map_points[i]) != nullptr;
  }
  return usable;
}

// Weighted squared reprojection error of a world point against feature i of a keyframe; < 0 behind it.
double reprojection_chi2(const Keyframe& kf, std::size_t i, const Eigen::Vector3d& p_world) {
  const Eigen::Vector3d p = kf.T_cam_world() * p_world;
  if (p.z() <= 0.0) return -1.0;
  const core::PinholeCamera& c = kf.frame.camera;
  const Eigen::Vector2d uv(c.fx() * p.x() / p.z() + c.cx(), c.fy() * p.y() / p.z() + c.cy());
  return (uv - kf.frame.uv[i]).squaredNorm() * kf.frame.pyramid.inv_sigma2[static_cast<std::size_t>(kf.frame.level[i])];
}

Eigen::Isometry3d rigid_fit(const Eigen::Matrix3Xd& from, const Eigen::Matrix3Xd& to) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.matrix() = Eigen::umeyama(from, to, false);
  return T;
}

// Guided matching of `points` into frame f (whose map_points may hold seed matches) at T_cam_world, then
// pose-only optimisation on every match.
PoseResult refine_on_points(Frame f, const std::vector<MapPointId>& points, const Eigen::Isometry3d& T_cw,
                            const Map& map, const ProjectionSearchConfig& search, const OptimizerConfig& optimizer) {
  std::vector<ProjectedPoint> projected;
  for (MapPointId id : points) {
    if (auto p = project_map_point(*map.point(id), f, T_cw, search)) projected.push_back(*p);
  }
  search_by_projection(f, projected, map, search);
  std::vector<PoseObservation> observations;
  for (std::size_t i = 0; i < f.size(); ++i) {
    const MapPoint* p = f.map_points[i] == kNoMapPoint ? nullptr : map.point(f.map_points[i]);
    if (p == nullptr) continue;
    PoseObservation o;
    o.p_world = p->position;
    o.obs = observation_of(f, i);
    observations.push_back(o);
  }
  return optimize_pose(f.camera, f.bf, observations, T_cw, optimizer);
}

// Length of the path through the component's keyframes (in id order, so in time) from `from` to `to`.
double path_length_m(const Map& map, int component, KeyframeId from, KeyframeId to) {
  double length = 0.0;
  const Keyframe* previous = nullptr;
  for (const auto& [id, kf] : map.keyframes()) {
    if (kf.component != component || id < from || id > to) continue;
    if (previous != nullptr) length += (kf.center() - previous->center()).norm();
    previous = &kf;
  }
  return length;
}

}  // namespace

LoopCloser::LoopCloser(const LoopClosingConfig& config, core::Logger logger)
    : config_(config), logger_(std::move(logger)) {
  FLEETSLAM_CHECK(logger_ != nullptr, "LoopCloser needs a logger (core::null_logger() discards)");
}

std::vector<LoopCloser::Candidate> LoopCloser::detect(const Keyframe& current, const Map& map,
                                                      const KeyframeDatabase& database) {
  std::vector<Candidate> accepted;
  const bool waiting = last_loop_ >= 0 && component_size(current.component, map, last_loop_) < config_.keyframes_after_loop;
  if (waiting || current.bow.empty() || component_size(current.component, map) < config_.min_keyframes) {
    groups_.clear();
    return accepted;
  }
  // The lowest score among the covisible neighbours: a loop candidate must look at least as similar.
  PlaceQuery query;
  query.max_results = 0;
  query.min_score = 1.0;
  query.exclude.insert(current.id);
  for (const auto& [id, weight] : current.connections) {
    query.exclude.insert(id);
    const Keyframe* n = map.keyframe(id);
    if (n != nullptr && !n->bow.empty()) query.min_score = std::min(query.min_score, bow_score(current.bow, n->bow));
  }
  if (current.connections.empty()) {  // nothing to compare with: consistency does not carry over this keyframe
    groups_.clear();
    return accepted;
  }
  std::map<KeyframeId, double> scores;
  for (const PlaceCandidate& c : database.query(current.bow, query)) {
    const Keyframe* kf = map.keyframe(c.id);
    if (kf != nullptr && kf->component == current.component) scores.emplace(c.id, c.score);
  }
  if (scores.empty()) {
    groups_.clear();
    return accepted;
  }
  // Covisibility groups: accumulated scores, each group represented by its best-scoring candidate.
  std::vector<std::pair<Candidate, double>> groups;
  double best_group = 0.0;
  for (const auto& [id, score] : scores) {
    Candidate best{id, score};
    double accumulated = score;
    for (KeyframeId n : map.keyframe(id)->best_covisible(config_.group_neighbours)) {
      const auto it = scores.find(n);
      if (it == scores.end()) continue;
      accumulated += it->second;
      if (it->second > best.score) best = Candidate{n, it->second};
    }
    groups.emplace_back(best, accumulated);
    best_group = std::max(best_group, accumulated);
  }
  std::set<KeyframeId> represented;
  std::vector<Group> next_groups;
  for (const auto& [candidate, accumulated] : groups) {
    if (accumulated < config_.group_score_ratio * best_group || !represented.insert(candidate.id).second) continue;
    Group group;
    group.keyframes.insert(candidate.id);
    for (const auto& entry : map.keyframe(candidate.id)->connections) group.keyframes.insert(entry.first);
    group.consistency = 1;
    for (const Group& previous : groups_) {
      const bool shared = std::any_of(group.keyframes.begin(), group.keyframes.end(),
                                      [&](KeyframeId id) { return previous.keyframes.count(id) > 0; });
      if (shared) group.consistency = std::max(group.consistency, previous.consistency + 1);
    }
    if (group.consistency >= config_.consistency) accepted.push_back(candidate);
    next_groups.push_back(std::move(group));
  }
  groups_ = std::move(next_groups);
  std::stable_sort(accepted.begin(), accepted.end(), [](const Candidate& a, const Candidate& b) { return a.score > b.score; });
  return accepted;
}

std::optional<LoopCloser::Verified> LoopCloser::verify(const Keyframe& current, const Candidate& candidate,
                                                       const Map& map) {
  const Keyframe& loop = *map.keyframe(candidate.id);
  const std::vector<Match> matches =
      search_by_bow(loop.frame, loop.bow_features, features_with_points(loop, map), current.frame,
                    current.bow_features, features_with_points(current, map), config_.matching);
  Verified v;
  v.loop = candidate.id;
  v.score = candidate.score;
  v.bow_matches = static_cast<int>(matches.size());
  if (v.bow_matches < config_.min_bow_matches) return std::nullopt;
  // 3D-3D pairs: T maps the current keyframe's (drifted) world points onto the loop keyframe's.
  const int n = v.bow_matches;
  Eigen::Matrix3Xd from(3, n), to(3, n);
  for (int k = 0; k < n; ++k) {
    const auto& m = matches[static_cast<std::size_t>(k)];
    to.col(k) = map.point(loop.frame.map_points[static_cast<std::size_t>(m.a)])->position;
    from.col(k) = map.point(current.frame.map_points[static_cast<std::size_t>(m.b)])->position;
  }
  const auto inliers_of = [&](const Eigen::Isometry3d& T) {
    std::vector<int> inliers;
    const Eigen::Isometry3d T_inv = T.inverse();
    for (int k = 0; k < n; ++k) {
      const auto& m = matches[static_cast<std::size_t>(k)];
      const double e_loop = reprojection_chi2(loop, static_cast<std::size_t>(m.a), T * Eigen::Vector3d(from.col(k)));
      const double e_cur = reprojection_chi2(current, static_cast<std::size_t>(m.b), T_inv * Eigen::Vector3d(to.col(k)));
      if (e_loop >= 0.0 && e_loop <= config_.ransac_chi2 && e_cur >= 0.0 && e_cur <= config_.ransac_chi2) {
        inliers.push_back(k);
      }
    }
    return inliers;
  };
  std::mt19937_64 rng(static_cast<std::uint64_t>(config_.seed) * 1000003u + static_cast<std::uint64_t>(current.id));
  std::vector<int> best;
  Eigen::Isometry3d best_T = Eigen::Isometry3d::Identity();
  for (int iteration = 0; iteration < config_.ransac_iterations; ++iteration) {
    int pick[3];
    for (int s = 0; s < 3; ++s) {
      bool fresh = false;
      while (!fresh) {
        pick[s] = static_cast<int>(rng() % static_cast<std::uint64_t>(n));
        fresh = std::none_of(pick, pick + s, [&](int p) { return p == pick[s]; });
      }
    }
    Eigen::Matrix3d a, b;
    for (int s = 0; s < 3; ++s) a.col(s) = from.col(pick[s]), b.col(s) = to.col(pick[s]);
    if ((a.col(1) - a.col(0)).cross(a.col(2) - a.col(0)).norm() < 1e-6) continue;  // collinear
    const Eigen::Isometry3d T = rigid_fit(a, b);
    std::vector<int> inliers = inliers_of(T);
    if (inliers.size() > best.size()) best = std::move(inliers), best_T = T;
  }
  if (static_cast<int>(best.size()) < config_.min_ransac_inliers) return std::nullopt;
  Eigen::Matrix3Xd in_from(3, best.size()), in_to(3, best.size());
  for (std::size_t k = 0; k < best.size(); ++k) in_from.col(static_cast<Eigen::Index>(k)) = from.col(best[k]), in_to.col(static_cast<Eigen::Index>(k)) = to.col(best[k]);
  const Eigen::Isometry3d refined = rigid_fit(in_from, in_to);
  std::vector<int> refined_inliers = inliers_of(refined);
  if (refined_inliers.size() >= best.size()) best = std::move(refined_inliers), best_T = refined;
  v.ransac_inliers = static_cast<int>(best.size());
  // The drift bound, checked on the RANSAC pose before the costlier guided matching (and again on the
  // refined pose by the caller).
  if (const Plausibility early = plausible(current, best_T * current.T_world_cam, loop.id, map); !early.ok) {
    refuse_implausible(current.id, v, early);
    return std::nullopt;
  }

  // Guided matching: the candidate's neighbourhood points projected into the keyframe at the corrected pose.
  std::set<MapPointId> seen;
  std::vector<KeyframeId> neighbourhood{loop.id};
  for (KeyframeId id : loop.best_covisible(config_.group_neighbours)) neighbourhood.push_back(id);
  for (KeyframeId id : neighbourhood) {
    for (MapPointId p : map.keyframe(id)->frame.map_points) {
      if (p != kNoMapPoint && map.point(p) != nullptr && seen.insert(p).second) v.loop_points.push_back(p);
    }
  }
  Frame f = current.frame;
  f.map_points.assign(f.size(), kNoMapPoint);
  for (int k : best) {
    const auto& m = matches[static_cast<std::size_t>(k)];
    f.map_points[static_cast<std::size_t>(m.b)] = loop.frame.map_points[static_cast<std::size_t>(m.a)];
  }
  const PoseResult pose = refine_on_points(std::move(f), v.loop_points, (best_T * current.T_world_cam).inverse(), map,
                                           config_.search, config_.pose_optimizer);
  v.inliers = pose.inliers;
  logger_->debug("loop candidate {} for keyframe {}: score {:.3f}, {} BoW matches, {} RANSAC inliers, {} refined inliers",
                 loop.id, current.id, v.score, v.bow_matches, v.ransac_inliers, v.inliers);
  if (!pose.ok || v.inliers < config_.min_loop_inliers) return std::nullopt;
  v.T_world_cam = pose.T_cam_world.inverse();
  return v;
}

LoopCloser::Plausibility LoopCloser::plausible(const Keyframe& current, const Eigen::Isometry3d& T_world_cam_corrected,
                                               KeyframeId loop, const Map& map) const {
  Plausibility p;
  p.path_m = path_length_m(map, current.component, loop, current.id);
  p.translation_m = (T_world_cam_corrected.translation() - current.T_world_cam.translation()).norm();
  p.rotation_deg = core::rotation_angle_rad(T_world_cam_corrected.linear() * current.T_world_cam.linear().transpose()) *
                   (180.0 / 3.14159265358979323846);
  p.bound_m = config_.max_correction_floor_m + config_.max_correction_per_m * p.path_m;
  p.bound_deg = config_.max_correction_floor_deg + config_.max_correction_deg_per_m * p.path_m;
  const bool translation_ok = config_.max_correction_floor_m < 0.0 || config_.max_correction_per_m < 0.0 ||
                              p.translation_m <= p.bound_m;
  const bool rotation_ok = config_.max_correction_floor_deg < 0.0 || config_.max_correction_deg_per_m < 0.0 ||
                           p.rotation_deg <= p.bound_deg;
  p.ok = translation_ok && rotation_ok;
  return p;
}

void LoopCloser::refuse_implausible(KeyframeId current, const Verified& loop, const Plausibility& p) {
  ++rejections_.implausible_correction;
  logger_->info("loop refused: keyframe {} with {} (score {:.3f}, {} RANSAC inliers) would move it {:.3f} m / {:.1f} deg "
                "after {:.2f} m travelled (bound {:.3f} m / {:.1f} deg)",
                current, loop.loop, loop.score, loop.ransac_inliers, p.translation_m, p.rotation_deg, p.path_m, p.bound_m,
                p.bound_deg);
}

int LoopCloser::confirmations(const Keyframe& current, const std::vector<KeyframeId>& neighbours, const Verified& loop,
                              const Map& map) const {
  const Eigen::Isometry3d correction = loop.T_world_cam * current.T_world_cam.inverse();
  int confirmed = 0;
  for (KeyframeId id : neighbours) {
    const Keyframe* n = map.keyframe(id);
    if (n == nullptr) continue;
    Frame f = n->frame;
    f.map_points.assign(f.size(), kNoMapPoint);
    // correct() moves every covisible neighbour but the root (the old side: the world is its camera).
    const Eigen::Isometry3d T_world_cam = n->root ? n->T_world_cam : correction * n->T_world_cam;
    const PoseResult pose = refine_on_points(std::move(f), loop.loop_points, T_world_cam.inverse(), map, config_.search,
                                             config_.pose_optimizer);
    logger_->debug("loop {} of keyframe {}: neighbour {} finds {} inliers", loop.loop, current.id, id, pose.inliers);
    if (pose.ok && pose.inliers >= config_.min_confirm_inliers) ++confirmed;
  }
  return confirmed;
}

std::optional<LoopEvent> LoopCloser::detect_and_correct(KeyframeId current, Map& map, const KeyframeDatabase& database,
                                                        std::set<KeyframeId>& moved) {
  const Keyframe* kf = map.keyframe(current);
  if (!config_.enabled || kf == nullptr) return std::nullopt;
  for (const Candidate& candidate : detect(*kf, map, database)) {
    const std::optional<Verified> loop = verify(*kf, candidate, map);
    if (!loop) continue;
    const Plausibility plausibility = plausible(*kf, loop->T_world_cam, loop->loop, map);
    if (!plausibility.ok) {
      refuse_implausible(current, *loop, plausibility);
      continue;
    }
    const std::vector<KeyframeId> neighbour_ids = kf->best_covisible(config_.confirm_neighbours);
    const int neighbours = static_cast<int>(neighbour_ids.size());
    const int needed = std::min(config_.confirmations, neighbours);
    const int confirmed = needed > 0 ? confirmations(*kf, neighbour_ids, *loop, map) : 0;
    if (confirmed < needed) {
      ++rejections_.unconfirmed;
      logger_->info("loop refused: keyframe {} with {} (score {:.3f}, {} inliers, correction {:.3f} m / {:.1f} deg) "
                    "confirmed by {} of {} neighbours, {} needed",
                    current, loop->loop, loop->score, loop->inliers, plausibility.translation_m, plausibility.rotation_deg,
                    confirmed, neighbours, needed);
      continue;
    }
    LoopEvent event;
    event.current = current;
    event.loop = loop->loop;
    event.t_ns = kf->t_ns;
    event.score = loop->score;
    event.correction = loop->T_world_cam * kf->T_world_cam.inverse();
    event.bow_matches = loop->bow_matches;
    event.ransac_inliers = loop->ransac_inliers;
    event.inliers = loop->inliers;
    event.path_m = plausibility.path_m;
    event.camera_shift_m = plausibility.translation_m;
    event.confirmations = confirmed;
    correct(current, *loop, map, event, moved);
    last_loop_ = current;
    groups_.clear();
    logger_->info("loop closed: keyframe {} with {} (score {:.3f}, {} inliers, correction {:.3f} m / {:.1f} deg after "
                  "{:.2f} m, {} neighbours confirmed), {} points fused, {} keyframes moved",
                  event.current, event.loop, event.score, event.inliers, plausibility.translation_m,
                  plausibility.rotation_deg, event.path_m, confirmed, event.fused_points, event.moved_keyframes);
    return event;
  }
  return std::nullopt;
}

}  // namespace fleetslam::slam
