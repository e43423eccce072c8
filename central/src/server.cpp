#include "fleetslam/central/server.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <map>
#include <set>

#include <nlohmann/json.hpp>
#include <spdlog/fmt/fmt.h>
#include <spdlog/logger.h>

#include "fleetslam/central/kdtree.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/se3.hpp"
#include "fleetslam/core/time.hpp"

namespace fleetslam::central {

namespace {

bool finite_pose(const Eigen::Isometry3d& T) { return T.matrix().allFinite(); }

bool rigid(const Eigen::Isometry3d& T) {
  const Eigen::Matrix3d R = T.linear();
  return finite_pose(T) && (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < 1e-6 && R.determinant() > 0.0;
}

nlohmann::json pose_json(const Eigen::Isometry3d& T) {
  const Eigen::Quaterniond q(T.rotation());
  return {{"t", {T.translation().x(), T.translation().y(), T.translation().z()}},
          {"q_xyzw", {q.x(), q.y(), q.z(), q.w()}}};
}

nlohmann::json later_components_json(const std::vector<ComponentPlacement>& components) {
  nlohmann::json out = nlohmann::json::array();
  for (const ComponentPlacement& p : components) {
    out.push_back({{"component", p.component}, {"merge_id", p.merge_id}, {"points", p.points}, {"placed", p.placed},
                   {"registered", p.registered}, {"merge_status", p.merge_status},
                   {"T_world_component", pose_json(p.T_world_component)}});
  }
  return out;
}

}  // namespace

const RobotMergeReport* merged_robot(const MergeResult& result, int robot_id) {
  for (const RobotMergeReport& r : result.robots) {
    if (r.robot_id == robot_id) return &r;
  }
  return nullptr;
}

nlohmann::json to_json(const MergeResult& m) {
  nlohmann::json robots = nlohmann::json::array();
  for (const RobotMergeReport& r : m.robots) {
    nlohmann::json overlaps = nlohmann::json::array();
    for (const auto& [other, pairs] : r.overlap_with) overlaps.push_back({{"robot_id", other}, {"pairs", pairs}});
    nlohmann::json entry = {{"robot_id", r.robot_id}, {"points", r.points}, {"non_finite_removed", r.non_finite_removed},
                            {"placed", r.placed}, {"fine_matched", r.fine_matched}, {"status", r.status},
                            {"overlap_points", r.overlap_points}, {"overlap_mean_distance_m", r.overlap_mean_distance_m},
                            {"overlap_normal_rejected", r.overlap_normal_rejected},
                            {"overlap_with", overlaps}, {"T_world_robot_prior", pose_json(r.T_world_robot_prior)},
                            {"T_world_robot", pose_json(r.T_world_robot)}};
    if (!r.registration.status.empty()) {
      entry["registration"] = {{"status", r.registration.status}, {"converged", r.registration.converged},
                               {"iterations", r.registration.iterations}, {"inlier_ratio", r.registration.inlier_ratio},
                               {"fitness_m2", std::isfinite(r.registration.fitness_m2) ? nlohmann::json(r.registration.fitness_m2) : nlohmann::json(nullptr)},
                               {"information_ratio", r.registration.information_ratio},
                               {"degenerate_directions", r.registration.degenerate_directions},
                               {"source_points", r.registration.source_points}, {"target_points", r.registration.target_points},
                               {"refinement_rounds", r.refinement_rounds}, {"hypothesis", r.hypothesis},
                               {"consistency_wide", r.consistency_wide}, {"consistency_local", r.consistency_local}};
    }
    robots.push_back(entry);
  }
  return {{"points_before_sampling", m.points_before_sampling}, {"points_after_sampling", m.points_after_sampling},
          {"points_after_filter", m.points_after_filter},
          {"timings_ms", {{"coarse", m.timings.coarse_ms}, {"registration", m.timings.registration_ms},
                          {"sampling", m.timings.sampling_ms}, {"filter", m.timings.filter_ms}, {"total", m.timings.total_ms}}},
          {"robots", robots}};
}

std::string to_string(IntegrateStatus status) {
  switch (status) {
    case IntegrateStatus::kAccepted: return "accepted";
    case IntegrateStatus::kUnknownRobot: return "unknown_robot";
    case IntegrateStatus::kOutOfOrder: return "out_of_order";
    case IntegrateStatus::kInvalid: return "invalid";
  }
  return "unknown";
}

Server::Server(const ServerConfig& config, core::Logger logger)
    : config_((core::check_config(config, "central"), config)),
      logger_(std::move(logger)),
      merger_(config.merge, logger_),
      fusion_(config.fusion) {
  FLEETSLAM_CHECK(logger_ != nullptr, "Server needs a logger (core::null_logger() discards)");
}

void Server::add_robot(const RobotSpec& spec) {
  const std::string where = "robot " + std::to_string(spec.robot_id);
  if (robots_.count(spec.robot_id) > 0) throw InputError(where, "registered twice");
  if (!rigid(spec.T_world_robot)) throw InputError(where, "the prior T_world_robot is not a rigid transform");
  const RobotBody& body = spec.body;
  if (!(std::isfinite(body.radius_m) && body.radius_m >= 0.0)) throw InputError(where, "the body's radius is not a finite non-negative number");
  if (body.radius_m > 0.0 && !(std::isfinite(body.z_min_m) && std::isfinite(body.z_max_m) && body.z_min_m <= body.z_max_m)) {
    throw InputError(where, "the body's height range is not finite and ordered (z_min_m <= z_max_m)");
  }
  if (!rigid(body.T_cam_body)) throw InputError(where, "the body's pose in the camera (T_cam_body) is not a rigid transform");
  RobotState state;
  state.spec = spec;
  if (state.spec.name.empty()) state.spec.name = "robot" + std::to_string(spec.robot_id);
  robots_.emplace(spec.robot_id, std::move(state));
}

Server::RobotState& Server::state(int robot_id) {
  auto it = robots_.find(robot_id);
  if (it == robots_.end()) throw InputError("robot " + std::to_string(robot_id), "not registered");
  return it->second;
}

const Server::RobotState& Server::state(int robot_id) const {
  auto it = robots_.find(robot_id);
  if (it == robots_.end()) throw InputError("robot " + std::to_string(robot_id), "not registered");
  return it->second;
}

std::vector<int> Server::robot_ids() const {
  std::vector<int> ids;
  for (const auto& entry : robots_) ids.push_back(entry.first);
  return ids;
}

const RobotSpec& Server::spec(int robot_id) const { return state(robot_id).spec; }
const RobotCounters& Server::counters(int robot_id) const { return state(robot_id).counters; }

void Server::take_keyframe(RobotState& robot, const slam::KeyframeSnapshot& kf) {
  if (!finite_pose(kf.T_world_cam)) {
    logger_->warn("{}: keyframe {} has a non-finite pose; ignored", robot.spec.name, kf.id);
    return;
  }
  if (robot.component < 0) robot.component = kf.component;  // the map of the first keyframe kept
  if (kf.component != robot.component && robot.keyframes.count(kf.id) == 0) ++robot.counters.other_component_keyframes;
  ServerKeyframe& entry = robot.keyframes[kf.id];
  entry.t_ns = kf.t_ns;
  entry.component = kf.component;
  entry.T_robot_cam = kf.T_world_cam;
  if (kf.dense_cam) {
    entry.dense_cam = *kf.dense_cam;
    entry.on_teammate.clear();
    const std::size_t dropped = core::remove_non_finite(entry.dense_cam);
    if (dropped > 0) {
      robot.counters.nan_points += dropped;
      logger_->warn("{}: keyframe {}: {} dense points with NaN dropped", robot.spec.name, kf.id, dropped);
    }
  }
  slam::KeyframeId& newest = robot.newest.emplace(kf.component, kf.id).first->second;
  newest = std::max(newest, kf.id);
}

IntegrateStatus Server::integrate(const slam::AgentUpdate& u) {
  auto it = robots_.find(u.robot_id);
  if (it == robots_.end()) {
    logger_->warn("update {} from robot {} that is not registered; ignored", u.sequence, u.robot_id);
    return IntegrateStatus::kUnknownRobot;
  }
  RobotState& robot = it->second;
  // The map changes an agent reports after its last frame (Agent::finish) carry that frame's sequence.
  const bool map_changes = u.status == slam::FrameStatus::kMapChanges;
  if (map_changes ? u.sequence < robot.last_sequence : u.sequence <= robot.last_sequence) {
    ++robot.counters.rejected;
    logger_->warn("{}: update {} does not advance past {} (duplicate or out of order); ignored", robot.spec.name,
                  u.sequence, robot.last_sequence);
    return IntegrateStatus::kOutOfOrder;
  }
  // The agent sends each keyframe change once: an update whose frame pose is not finite still delivers
  // them (dropping them lost dense clouds for good, and kept culled keyframes whose points had moved on).
  const bool bad_pose = u.T_world_cam && !finite_pose(*u.T_world_cam);
  if (!map_changes) robot.last_sequence = u.sequence;
  for (const slam::KeyframeSnapshot& kf : u.new_keyframes) take_keyframe(robot, kf);
  for (const slam::KeyframeSnapshot& kf : u.changed_keyframes) take_keyframe(robot, kf);
  for (slam::KeyframeId id : u.removed_keyframes) retire_keyframe(robot, id);
  if (bad_pose) {
    ++robot.counters.rejected;
    logger_->warn("{}: update {} carries a non-finite pose; its frame is ignored", robot.spec.name, u.sequence);
    return IntegrateStatus::kInvalid;
  }
  if (!map_changes) ++robot.counters.updates;
  if (u.status == slam::FrameStatus::kLost) ++robot.counters.lost;
  const auto newest = robot.newest.find(u.component);
  if (u.T_world_cam && newest != robot.newest.end()) {
    const std::optional<Eigen::Isometry3d> T_robot_ref = keyframe_pose(robot, newest->second);
    if (T_robot_ref) {
      robot.frames.push_back(FrameEntry{u.t_ns, u.component, newest->second, T_robot_ref->inverse() * *u.T_world_cam});
      ++robot.counters.tracked;
    }
  }
  return IntegrateStatus::kAccepted;
}

// A culled keyframe's frames move to its heir, the surviving keyframe of its component nearest in time
// (the older on ties), re-expressed at the current poses, so that later corrections of the map (local BA,
// loop closing) move them as they move the agent's own estimate of them. Without an heir the frames keep
// the removed keyframe's last pose.
void Server::retire_keyframe(RobotState& robot, slam::KeyframeId id) {
  const auto kf = robot.keyframes.find(id);
  if (kf == robot.keyframes.end()) return;
  const ServerKeyframe removed = std::move(kf->second);
  robot.keyframes.erase(kf);
  const ServerKeyframe* heir = nullptr;
  slam::KeyframeId heir_id = -1;
  for (const auto& [other_id, other] : robot.keyframes) {
    if (other.component != removed.component) continue;
    const auto gap = [&](const ServerKeyframe& k) { return std::abs(k.t_ns - removed.t_ns); };
    if (heir == nullptr || gap(other) < gap(*heir)) heir = &other, heir_id = other_id;
  }
  if (heir == nullptr) {
    robot.retired[id] = removed.T_robot_cam;
    return;
  }
  const Eigen::Isometry3d T_heir_removed = heir->T_robot_cam.inverse() * removed.T_robot_cam;
  for (FrameEntry& f : robot.frames) {
    if (f.reference != id) continue;
    f.reference = heir_id;
    f.T_ref_cam = T_heir_removed * f.T_ref_cam;
  }
  // Frames to come refer to the component's newest keyframe still held.
  if (const auto newest = robot.newest.find(removed.component); newest != robot.newest.end() && newest->second == id) {
    newest->second = heir_id;
    for (const auto& [other_id, other] : robot.keyframes) {
      if (other.component == removed.component) newest->second = std::max(newest->second, other_id);
    }
  }
}

std::size_t Server::integrate_all(Link& link) {
  std::size_t accepted = 0;
  for (const slam::AgentUpdate& u : link.receive()) accepted += integrate(u) == IntegrateStatus::kAccepted ? 1 : 0;
  return accepted;
}

std::optional<Eigen::Isometry3d> Server::keyframe_pose(const RobotState& robot, slam::KeyframeId id) const {
  if (auto kf = robot.keyframes.find(id); kf != robot.keyframes.end()) return kf->second.T_robot_cam;
  if (auto old = robot.retired.find(id); old != robot.retired.end()) return old->second;
  return std::nullopt;
}

core::PointCloud Server::robot_cloud(int robot_id, std::optional<int> component) const {
  const RobotState& robot = state(robot_id);
  const auto wanted = [&](const ServerKeyframe& kf) { return !component || kf.component == *component; };
  core::PointCloud cloud;
  std::size_t total = 0;
  for (const auto& entry : robot.keyframes) total += wanted(entry.second) ? entry.second.dense_cam.size() : 0;
  cloud.reserve(total);
  for (const auto& entry : robot.keyframes) {
    const ServerKeyframe& kf = entry.second;
    if (!wanted(kf)) continue;
    if (kf.on_teammate.size() != kf.dense_cam.size()) {
      cloud.append(core::transformed(kf.dense_cam, kf.T_robot_cam));
      continue;
    }
    core::PointCloud kept;
    kept.reserve(kf.dense_cam.size(), kf.dense_cam.has_colors());
    for (std::size_t i = 0; i < kf.dense_cam.size(); ++i) {
      if (!kf.on_teammate[i]) kept.push_back_from(kf.dense_cam, i);
    }
    transform_in_place(kept, kf.T_robot_cam);
    cloud.append(kept);
  }
  return cloud;
}

core::Trajectory Server::robot_trajectory(int robot_id, std::optional<int> component) const {
  const RobotState& robot = state(robot_id);
  core::Trajectory out;
  out.reserve(robot.frames.size());
  for (const FrameEntry& f : robot.frames) {
    if (component && f.component != *component) continue;
    const std::optional<Eigen::Isometry3d> T_robot_ref = keyframe_pose(robot, f.reference);
    if (T_robot_ref) out.push_back(core::StampedPose{f.t_ns, *T_robot_ref * f.T_ref_cam});
  }
  return out;
}

core::Trajectory Server::robot_keyframes(int robot_id, std::optional<int> component) const {
  const RobotState& robot = state(robot_id);
  core::Trajectory out;
  for (const auto& entry : robot.keyframes) {
    if (component && entry.second.component != *component) continue;
    out.push_back(core::StampedPose{entry.second.t_ns, entry.second.T_robot_cam});
  }
  std::sort(out.begin(), out.end(), [](const core::StampedPose& a, const core::StampedPose& b) { return a.t_ns < b.t_ns; });
  return out;
}

std::vector<const ServerKeyframe*> Server::robot_keyframe_clouds(int robot_id) const {
  const RobotState& robot = state(robot_id);
  std::vector<const ServerKeyframe*> out;
  out.reserve(robot.keyframes.size());
  for (const auto& entry : robot.keyframes) out.push_back(&entry.second);
  std::stable_sort(out.begin(), out.end(), [](const ServerKeyframe* a, const ServerKeyframe* b) { return a->t_ns < b->t_ns; });
  return out;
}

const RobotFusionReport* Server::last_report(int robot_id) const {
  if (!last_merge_) return nullptr;
  for (const RobotFusionReport& r : last_merge_->robots) {
    if (r.robot_id == robot_id) return &r;
  }
  return nullptr;
}

std::set<int> Server::components(const RobotState& robot) {
  std::set<int> out;
  for (const auto& entry : robot.keyframes) out.insert(entry.second.component);
  return out;
}

core::Trajectory Server::world_trajectory(int robot_id) const {
  if (const RobotFusionReport* r = last_report(robot_id)) return r->fused.frames_world;
  core::Trajectory out = robot_trajectory(robot_id);
  const Eigen::Isometry3d& prior = state(robot_id).spec.T_world_robot;
  for (core::StampedPose& p : out) p.T_world_body = prior * p.T_world_body;
  return out;
}

const ComponentPlacement* RobotFusionReport::later_component(int c) const {
  for (const ComponentPlacement& p : later_components) {
    if (p.component == c) return &p;
  }
  return nullptr;
}

Eigen::Isometry3d RobotFusionReport::T_world(int c) const {
  // A component newer than the merge continues the newest one before it.
  const ComponentPlacement* best = nullptr;
  for (const ComponentPlacement& p : later_components) {
    if (p.component <= c && (best == nullptr || p.component > best->component)) best = &p;
  }
  return best != nullptr ? best->T_world_component : T_world_robot;
}

std::optional<Eigen::Isometry3d> Server::last_placement(int robot_id, int component) const {
  const RobotFusionReport* r = last_report(robot_id);
  if (r == nullptr) return std::nullopt;
  if (component == r->component) return r->T_world_robot;
  if (const ComponentPlacement* p = r->later_component(component)) return p->T_world_component;
  return std::nullopt;
}

std::optional<Eigen::Isometry3d> Server::registered_placement(int robot_id, int component) const {
  const RobotFusionReport* r = last_report(robot_id);
  if (r == nullptr) return std::nullopt;
  if (component == r->component) {
    if (r->registered || r->merge_status == "reference") return r->T_world_robot;
    return std::nullopt;
  }
  const ComponentPlacement* p = r->later_component(component);
  if (p != nullptr && p->placed && p->registered) return p->T_world_component;
  return std::nullopt;
}

void Server::mask_teammates() {
  for (auto& [id, robot] : robots_) {
    for (auto& entry : robot.keyframes) entry.second.on_teammate.clear();
  }
  if (!config_.mask_teammates) return;
  // Each robot with a body: its body's pose in the world at every frame whose map component registration
  // placed, in time order.
  struct BodyTrack {
    int robot_id = 0;
    const RobotBody* body = nullptr;
    std::vector<core::StampedPose> T_world_body;
  };
  std::vector<BodyTrack> tracks;
  for (const auto& [id, robot] : robots_) {
    if (!(robot.spec.body.radius_m > 0.0)) continue;
    BodyTrack track{id, &robot.spec.body, {}};
    std::map<int, std::optional<Eigen::Isometry3d>> placements;
    for (const FrameEntry& f : robot.frames) {
      auto placed = placements.find(f.component);
      if (placed == placements.end()) placed = placements.emplace(f.component, registered_placement(id, f.component)).first;
      const std::optional<Eigen::Isometry3d> T_robot_ref = keyframe_pose(robot, f.reference);
      if (!placed->second || !T_robot_ref) continue;
      track.T_world_body.push_back({f.t_ns, *placed->second * *T_robot_ref * f.T_ref_cam * robot.spec.body.T_cam_body});
    }
    std::stable_sort(track.T_world_body.begin(), track.T_world_body.end(),
                     [](const core::StampedPose& a, const core::StampedPose& b) { return a.t_ns < b.t_ns; });
    if (!track.T_world_body.empty()) tracks.push_back(std::move(track));
  }
  const core::TimeNs max_gap_ns = core::seconds_to_ns(config_.teammate_max_gap_s);
  // The body's pose at t: interpolated between the frames around it, when they are close enough in time.
  const auto body_at = [max_gap_ns](const BodyTrack& track, core::TimeNs t_ns) -> std::optional<Eigen::Isometry3d> {
    const std::vector<core::StampedPose>& poses = track.T_world_body;
    const auto after = std::lower_bound(poses.begin(), poses.end(), t_ns,
                                        [](const core::StampedPose& p, core::TimeNs t) { return p.t_ns < t; });
    if (after != poses.end() && after->t_ns == t_ns) return after->T_world_body;
    if (after == poses.end() || after == poses.begin()) return std::nullopt;
    const auto before = std::prev(after);
    if (after->t_ns - before->t_ns > max_gap_ns) return std::nullopt;
    const double s = static_cast<double>(t_ns - before->t_ns) / static_cast<double>(after->t_ns - before->t_ns);
    return core::interpolate(before->T_world_body, after->T_world_body, s);
  };
  const double margin = config_.teammate_margin_m;
  for (auto& [id, robot] : robots_) {
    std::size_t masked = 0;
    for (auto& entry : robot.keyframes) {
      ServerKeyframe& kf = entry.second;
      if (kf.dense_cam.empty()) continue;
      const std::optional<Eigen::Isometry3d> T_world_robot = registered_placement(id, kf.component);
      if (!T_world_robot) continue;
      const Eigen::Isometry3d T_world_cam = *T_world_robot * kf.T_robot_cam;
      for (const BodyTrack& track : tracks) {
        if (track.robot_id == id) continue;
        const std::optional<Eigen::Isometry3d> T_world_body = body_at(track, kf.t_ns);
        if (!T_world_body) continue;
        const Eigen::Isometry3f T_body_cam = (T_world_body->inverse() * T_world_cam).cast<float>();
        const float radius = static_cast<float>(track.body->radius_m + margin);
        const float z_min = static_cast<float>(track.body->z_min_m);  // not below: the floor it stands on stays
        const float z_max = static_cast<float>(track.body->z_max_m + margin);
        for (std::size_t i = 0; i < kf.dense_cam.size(); ++i) {
          const Eigen::Vector3f p = T_body_cam * kf.dense_cam.points[i];
          if (p.z() < z_min || p.z() > z_max || p.head<2>().squaredNorm() > radius * radius) continue;
          if (kf.on_teammate.empty()) kf.on_teammate.assign(kf.dense_cam.size(), false);
          masked += kf.on_teammate[i] ? 0 : 1;
          kf.on_teammate[i] = true;
        }
      }
    }
    if (masked > 0) logger_->debug("{}: {} dense points on other robots left out", robot.spec.name, masked);
  }
}

Eigen::Isometry3d Server::T_world_component(int robot_id, int component) const {
  const RobotState& robot = state(robot_id);
  const RobotFusionReport* r = last_report(robot_id);
  return r != nullptr ? r->T_world(component) : robot.spec.T_world_robot;
}

core::PointCloud Server::world_cloud(int robot_id) const {
  const RobotState& robot = state(robot_id);
  const RobotFusionReport* fused = last_report(robot_id);
  core::PointCloud cloud;
  for (int c : components(robot)) {
    if (c != robot.component) {
      const ComponentPlacement* p = fused != nullptr ? fused->later_component(c) : nullptr;
      if (p == nullptr || !p->placed) continue;  // left out of the map
    }
    cloud.append(core::transformed(robot_cloud(robot_id, c), T_world_component(robot_id, c)));
  }
  return cloud;
}

const ServerMergeReport& Server::merge() {
  mask_teammates();
  ServerMergeReport report;
  std::vector<RobotCloud> inputs;
  for (const auto& [id, robot] : robots_) {
    RobotCloud input;
    input.robot_id = id;
    input.cloud_robot = robot_cloud(id, robot.component);
    input.T_world_robot_prior = robot.spec.T_world_robot;
    inputs.push_back(std::move(input));
  }
  // Later components after every robot's first one, with merge ids after the robots' ids. Their prior:
  // the transform of the component each continues (the one before it): the agent starts a component where
  // it believed the camera to be in the previous one (T_after_robot identity). Until that one is placed in
  // this merge, the last merge's placement of it stands in.
  struct LaterUnit {
    int robot_id;
    int component;
    int merge_id;
  };
  std::vector<LaterUnit> later;
  int next_id = robots_.empty() ? 0 : robots_.rbegin()->first + 1;
  for (const auto& [id, robot] : robots_) {
    Eigen::Isometry3d previous = T_world_component(id, robot.component);
    int previous_id = id;
    for (int c : components(robot)) {
      if (c == robot.component) continue;
      RobotCloud input;
      input.robot_id = next_id;
      input.cloud_robot = robot_cloud(id, c);
      input.T_world_robot_prior = previous;
      input.keep_prior_without_overlap = false;
      input.after_id = previous_id;  // matched after the component it continues
      input.T_after_robot = Eigen::Isometry3d::Identity();
      previous_id = next_id;
      logger_->info("merge: robot {} is {}'s map component {}", next_id, robot.spec.name, c);
      later.push_back({id, c, next_id++});
      inputs.push_back(std::move(input));
      // The next component continues this one: where the last merge put it, else where this one starts.
      previous = last_placement(id, c).value_or(previous);
    }
  }
  report.merge = merger_.merge(inputs);

  for (const auto& [id, robot] : robots_) {
    RobotFusionReport r;
    r.robot_id = id;
    r.name = robot.spec.name;
    r.component = robot.component;
    const central::RobotMergeReport* info = merged_robot(report.merge, id);
    r.T_world_robot = info != nullptr ? info->T_world_robot : robot.spec.T_world_robot;
    r.registered = info != nullptr && info->fine_matched;
    r.overlap_points = info != nullptr ? info->overlap_points : 0;
    r.merge_status = info != nullptr ? info->status : "not merged";
    // A component the merge did not place continues the one before it as this merge placed that one (its
    // prior was the last merge's placement, a merge behind: the trajectory jumped by this merge's correction
    // where the component began).
    Eigen::Isometry3d continued = r.T_world_robot;
    for (const LaterUnit& unit : later) {
      if (unit.robot_id != id) continue;
      ComponentPlacement p;
      p.component = unit.component;
      p.merge_id = unit.merge_id;
      const central::RobotMergeReport* part = merged_robot(report.merge, unit.merge_id);
      p.points = part != nullptr ? part->points : 0;
      p.placed = part != nullptr && part->placed;
      p.registered = part != nullptr && part->fine_matched;
      p.merge_status = part != nullptr ? part->status : "not merged";
      p.T_world_component = p.placed ? part->T_world_robot : continued;
      continued = p.T_world_component;
      r.later_components.push_back(p);
    }
    const core::Trajectory keyframes = robot_keyframes(id, robot.component);
    std::optional<InterRobotConstraint> constraint;
    if (r.registered) {
      // Anchors: keyframes whose points (placed by the refined transform) lie on the rest of the map.
      core::PointCloud others;
      for (const auto& [other_id, other] : robots_) {
        if (other_id == id) continue;
        const central::RobotMergeReport* other_info = merged_robot(report.merge, other_id);
        const Eigen::Isometry3d T = other_info != nullptr ? other_info->T_world_robot : other.spec.T_world_robot;
        others.append(core::transformed(robot_cloud(other_id, other.component), T));
      }
      // Exact distances: the 27 voxels around a point reached 2 * sqrt(3) radii (17 cm at 5 cm).
      const KdTree others_tree(others.points);
      const auto near_others = [&](const Eigen::Vector3f& p) {
        return others_tree.nearest(p, static_cast<float>(config_.anchor_radius_m)).found();
      };
      std::vector<const ServerKeyframe*> ordered;
      for (const auto& entry : robot.keyframes) {
        if (entry.second.component == robot.component) ordered.push_back(&entry.second);
      }
      std::sort(ordered.begin(), ordered.end(), [](const ServerKeyframe* a, const ServerKeyframe* b) { return a->t_ns < b->t_ns; });
      for (std::size_t k = 0; k < ordered.size(); ++k) {
        const ServerKeyframe& kf = *ordered[k];
        const bool masked = kf.on_teammate.size() == kf.dense_cam.size();
        const Eigen::Isometry3f T_world_cam = (r.T_world_robot * kf.T_robot_cam).cast<float>();
        std::size_t near = 0;
        std::size_t scene = 0;  // points not on other robots
        for (std::size_t i = 0; i < kf.dense_cam.size(); ++i) {
          if (masked && kf.on_teammate[i]) continue;
          ++scene;
          near += near_others(T_world_cam * kf.dense_cam.points[i]) ? 1 : 0;
        }
        if (scene == 0) continue;
        if (static_cast<double>(near) >= config_.anchor_min_overlap_share * static_cast<double>(scene)) {
          r.anchors.push_back(k);
        }
      }
      constraint = InterRobotConstraint{r.T_world_robot, r.anchors};
    }
    r.fused = fusion_.fuse(keyframes, robot_trajectory(id, robot.component), robot.spec.T_world_robot, constraint);
    // Later components: placed rigidly by their own transform (or the robot's while not placed).
    for (const ComponentPlacement& p : r.later_components) {
      for (const core::StampedPose& kf : robot_keyframes(id, p.component)) {
        r.fused.keyframes_world.push_back({kf.t_ns, p.T_world_component * kf.T_world_body});
      }
      for (const core::StampedPose& f : robot_trajectory(id, p.component)) {
        r.fused.frames_world.push_back({f.t_ns, p.T_world_component * f.T_world_body});
      }
    }
    const auto by_time = [](const core::StampedPose& a, const core::StampedPose& b) { return a.t_ns < b.t_ns; };
    std::stable_sort(r.fused.keyframes_world.begin(), r.fused.keyframes_world.end(), by_time);
    std::stable_sort(r.fused.frames_world.begin(), r.fused.frames_world.end(), by_time);
    r.points = 0;
    for (const auto& entry : robot.keyframes) {
      const ServerKeyframe& kf = entry.second;
      r.points += kf.dense_cam.size();
      r.teammate_points += static_cast<std::size_t>(std::count(kf.on_teammate.begin(), kf.on_teammate.end(), true));
    }
    std::size_t placed_later = 0;
    for (const ComponentPlacement& p : r.later_components) placed_later += p.placed ? 1 : 0;
    logger_->info("{}: {} dense points ({} on other robots left out), {} in the overlap, {} anchor keyframes{}{}", r.name,
                  r.points, r.teammate_points, r.overlap_points, r.anchors.size(), r.registered ? "" : " (coarse placement by the prior)",
                  r.later_components.empty() ? std::string()
                                             : fmt::format("; later map components: {} of {} placed", placed_later,
                                                           r.later_components.size()));
    report.robots.push_back(std::move(r));
  }
  last_merge_ = std::move(report);
  return *last_merge_;
}

void Server::write_outputs(const std::filesystem::path& dir) {
  if (!last_merge_) merge();
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw InputError(dir.string(), "cannot create the output folder: " + ec.message());
  const ServerMergeReport& report = *last_merge_;
  core::write_ply((dir / "merged_map.ply").string(), report.merge.cloud_world);
  nlohmann::json robots = nlohmann::json::array();
  for (const RobotFusionReport& r : report.robots) {
    const fs::path robot_dir = dir / r.name;
    core::write_ply((robot_dir / "map.ply").string(), world_cloud(r.robot_id));
    core::write_trajectory(robot_dir / "trajectory.txt", r.fused.frames_world, core::TrajectoryFormat::kTum);
    core::write_trajectory(robot_dir / "trajectory_robot.txt", robot_trajectory(r.robot_id), core::TrajectoryFormat::kTum);
    const RobotCounters& c = counters(r.robot_id);
    robots.push_back({{"robot_id", r.robot_id}, {"name", r.name}, {"points", r.points},
                      {"teammate_points", r.teammate_points}, {"overlap_points", r.overlap_points}, {"registered", r.registered}, {"merge_status", r.merge_status},
                      {"anchor_keyframes", r.anchors.size()}, {"prior_T_world_robot", pose_json(spec(r.robot_id).T_world_robot)},
                      {"T_world_robot", pose_json(r.T_world_robot)}, {"pose_graph_solved", r.fused.pose_graph_solved},
                      {"updates", c.updates}, {"rejected_updates", c.rejected}, {"tracked", c.tracked}, {"lost", c.lost},
                      {"other_component_keyframes", c.other_component_keyframes}, {"nan_points", c.nan_points},
                      {"component", r.component}, {"later_components", later_components_json(r.later_components)}});
  }
  const nlohmann::json merge_json = to_json(report.merge);
  const nlohmann::json out = {{"robots", robots}, {"merge", merge_json}};
  std::ofstream file(dir / "merge.json");
  file << out.dump(2) << "\n";
  if (!file) throw InputError((dir / "merge.json").string(), "cannot write");
}

}  // namespace fleetslam::central
