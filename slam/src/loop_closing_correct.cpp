// Loop correction: the keyframe's neighbourhood moved to the corrected pose, loop fusion, the essential
// graph and the global BA.

#include <algorithm>
#include <iterator>
#include <map>
#include <set>

#include <ceres/ceres.h>
#include <spdlog/logger.h>

#include "fleetslam/slam/loop_closing.hpp"
#include "frame_observation.hpp"

namespace fleetslam::slam {
namespace {

// Relative pose error of an essential-graph edge: T_i_j measured against T_world_i^-1 T_world_j; residual
// (translation error, twice the vector part of the rotation error quaternion).
struct RelativePoseError {
  Eigen::Quaterniond q_i_j;
  Eigen::Vector3d t_i_j;

  template <class T>
  bool operator()(const T* q_i, const T* t_i, const T* q_j, const T* t_j, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> Qi(q_i), Qj(q_j);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> Ti(t_i), Tj(t_j);
    const Eigen::Quaternion<T> qi_inv = Qi.conjugate();
    const Eigen::Quaternion<T> q_est = qi_inv * Qj;
    const Eigen::Matrix<T, 3, 1> t_est = qi_inv * (Tj - Ti);
    const Eigen::Quaternion<T> dq = q_i_j.template cast<T>().conjugate() * q_est;
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residual);
    r.template head<3>() = t_est - t_i_j.template cast<T>();
    r.template tail<3>() = T(2.0) * dq.vec();
    return true;
  }
};

// The keyframe a point's position is held relative to: its reference keyframe, or its first observer.
KeyframeId anchor_of(const MapPoint& p, const Map& map) {
  if (map.keyframe(p.reference_keyframe) != nullptr) return p.reference_keyframe;
  return p.observations.empty() ? -1 : p.observations.begin()->first;
}

// Loop points projected into keyframe kf (at its corrected pose) and fused with its features: a feature
// holding another point hands it over to the loop point, a free feature observes the loop point.
int fuse_loop_points(KeyframeId kf_id, const std::vector<MapPointId>& loop_points, Map& map,
                     const ProjectionSearchConfig& search, int max_distance) {
  int fused = 0;
  for (MapPointId original : loop_points) {
    const MapPointId id = map.resolve(original);
    const Keyframe& kf = *map.keyframe(kf_id);
    const MapPoint* p = id == kNoMapPoint ? nullptr : map.point(id);
    if (p == nullptr || p->observations.count(kf_id) > 0) continue;
    const std::optional<ProjectedPoint> proj = project_map_point(*p, kf.frame, kf.T_cam_world(), search);
    if (!proj) continue;
    const Frame& f = kf.frame;
    const double radius = search.radius_factor * f.pyramid.scale[static_cast<std::size_t>(proj->level)];
    const std::vector<int> near = f.grid.features_in_area(proj->uv.x(), proj->uv.y(), radius,
                                                         std::max(0, proj->level - 1), proj->level + 1);
    int best = -1, best_distance = max_distance + 1;
    for (int i : near) {
      const int d = hamming_distance(p->descriptor.data(), f.descriptors.ptr<std::uint8_t>(i));
      if (d < best_distance) best = i, best_distance = d;
    }
    if (best < 0) continue;
    const MapPointId existing = f.map_points[static_cast<std::size_t>(best)];
    if (existing == id) continue;
    if (existing != kNoMapPoint && map.point(existing) != nullptr) {
      map.replace_map_point(existing, id);
    } else {
      map.add_observation(id, kf_id, best);
    }
    ++fused;
  }
  return fused;
}

}  // namespace

bool optimize_pose_graph(std::map<KeyframeId, Eigen::Isometry3d>& T_world_cam, const std::vector<PoseGraphEdge>& edges,
                         const std::set<KeyframeId>& fixed, int iterations) {
  std::map<KeyframeId, std::array<double, 4>> q;  // x y z w (Eigen's storage order)
  std::map<KeyframeId, std::array<double, 3>> t;
  for (const auto& [id, T] : T_world_cam) {
    const Eigen::Quaterniond r(T.linear());
    q[id] = {r.x(), r.y(), r.z(), r.w()};
    t[id] = {T.translation().x(), T.translation().y(), T.translation().z()};
  }
  ceres::Problem problem;
  for (const PoseGraphEdge& e : edges) {
    if (q.count(e.i) == 0 || q.count(e.j) == 0 || e.i == e.j) continue;
    auto* cost = new ceres::AutoDiffCostFunction<RelativePoseError, 6, 4, 3, 4, 3>(
        new RelativePoseError{Eigen::Quaterniond(e.T_i_j.linear()), e.T_i_j.translation()});
    problem.AddResidualBlock(cost, nullptr, q[e.i].data(), t[e.i].data(), q[e.j].data(), t[e.j].data());
  }
  for (auto& [id, qa] : q) {
    if (!problem.HasParameterBlock(qa.data())) continue;
    problem.SetManifold(qa.data(), new ceres::EigenQuaternionManifold);
    if (fixed.count(id) > 0) {
      problem.SetParameterBlockConstant(qa.data());
      problem.SetParameterBlockConstant(t[id].data());
    }
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.max_num_iterations = iterations;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  if (!summary.IsSolutionUsable()) return false;
  for (auto& [id, T] : T_world_cam) {
    const auto& qa = q[id];
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = Eigen::Quaterniond(qa[3], qa[0], qa[1], qa[2]).normalized().toRotationMatrix();
    pose.translation() = Eigen::Vector3d(t[id][0], t[id][1], t[id][2]);
    T = pose;
  }
  return true;
}

std::vector<PoseGraphEdge> essential_graph_edges(const Map& map, const std::map<KeyframeId, Eigen::Isometry3d>& before,
                                                 const std::map<KeyframeId, Eigen::Isometry3d>& corrected,
                                                 const std::set<KeyframeId>& group,
                                                 const std::map<KeyframeId, std::set<KeyframeId>>& old_connections,
                                                 int strong_covisibility, std::pair<KeyframeId, KeyframeId> loop_pair) {
  std::vector<PoseGraphEdge> edges;
  std::set<std::pair<KeyframeId, KeyframeId>> linked;  // (smaller id, larger id) of every edge so far
  const auto add = [&](KeyframeId i, KeyframeId j, const Eigen::Isometry3d& T_i_j) {
    if (linked.emplace(std::min(i, j), std::max(i, j)).second) edges.push_back({i, j, T_i_j});
  };
  const auto was_connected = [&](KeyframeId i, KeyframeId j) {
    const auto it = old_connections.find(i);
    return it != old_connections.end() && it->second.count(j) > 0;
  };
  const auto old_relative = [&](KeyframeId i, KeyframeId j) { return before.at(i).inverse() * before.at(j); };
  for (const auto& [id, T] : before) {
    const Keyframe* kf = map.keyframe(id);
    if (kf == nullptr) continue;
    if (kf->parent >= 0 && before.count(kf->parent) > 0) add(kf->parent, id, old_relative(kf->parent, id));
  }
  for (const auto& [id, T] : before) {  // earlier loops' constraints, whatever their covisibility now
    const Keyframe* kf = map.keyframe(id);
    if (kf == nullptr) continue;
    for (KeyframeId other : kf->loop_edges) {
      if (other > id && before.count(other) > 0) add(id, other, old_relative(id, other));
    }
  }
  for (const auto& [id, T] : before) {
    const Keyframe* kf = map.keyframe(id);
    if (kf == nullptr) continue;
    for (const auto& [other, weight] : kf->connections) {
      if (other <= id || before.count(other) == 0) continue;
      const bool in_group = group.count(id) > 0 || group.count(other) > 0;
      const bool was_linked = !in_group || (group.count(id) > 0 ? was_connected(id, other) : was_connected(other, id));
      const bool is_loop_pair = std::minmax(id, other) == std::minmax(loop_pair.first, loop_pair.second);
      if (!was_linked) {
        if (weight >= strong_covisibility || is_loop_pair) add(id, other, corrected.at(id).inverse() * corrected.at(other));
      } else if (weight >= strong_covisibility) {
        add(id, other, old_relative(id, other));
      }
    }
  }
  // The verified loop itself, even when the fusion left the two keyframes no covisibility link (a loop
  // whose inliers lie on the loop keyframe's neighbours): without it nothing in the graph holds the
  // correction, and the optimum is the drifted poses.
  const auto [current, loop] = loop_pair;
  if (current != loop && before.count(current) > 0 && before.count(loop) > 0) {
    add(current, loop, corrected.at(current).inverse() * corrected.at(loop));
  }
  return edges;
}

void LoopCloser::correct(KeyframeId current_id, const Verified& loop, Map& map, LoopEvent& event,
                         std::set<KeyframeId>& moved) const {
  const int component = map.keyframe(current_id)->component;
  std::map<KeyframeId, Eigen::Isometry3d> before;  // every keyframe of the component, uncorrected
  std::set<KeyframeId> fixed;
  for (const auto& [id, kf] : map.keyframes()) {
    if (kf.component != component) continue;
    before[id] = kf.T_world_cam;
    if (kf.root) fixed.insert(id);
  }
  // 1. The keyframe and its covisible neighbours move rigidly with it, their points too. The component's
  // root does not (the world is its camera; the pose graph and global BA then hold it fixed): a current
  // keyframe that sees the start again is covisible with it, and moving it shifted the whole world by the
  // correction. Nor do the points it observes, which are the old side's.
  const Eigen::Isometry3d correction = event.correction;
  std::set<KeyframeId> group{current_id};
  for (const auto& entry : map.keyframe(current_id)->connections) {
    if (before.count(entry.first) > 0 && fixed.count(entry.first) == 0) group.insert(entry.first);
  }
  const auto seen_by_fixed = [&](const MapPoint& point) {
    return std::any_of(point.observations.begin(), point.observations.end(),
                       [&](const auto& observation) { return fixed.count(observation.first) > 0; });
  };
  std::map<KeyframeId, std::set<KeyframeId>> old_connections;
  std::map<MapPointId, KeyframeId> moved_points;  // moved with this group keyframe: it anchors them below
  for (KeyframeId id : group) {
    Keyframe& kf = *map.keyframe(id);
    for (const auto& entry : kf.connections) old_connections[id].insert(entry.first);
    for (MapPointId p : kf.frame.map_points) {
      if (p == kNoMapPoint || map.point(p) == nullptr || seen_by_fixed(*map.point(p)) || !moved_points.emplace(p, id).second) {
        continue;
      }
      map.point(p)->position = correction * map.point(p)->position;
    }
    kf.T_world_cam = correction * kf.T_world_cam;
  }
  for (const auto& entry : moved_points) {
    if (map.point(entry.first) != nullptr) map.update_point_statistics(entry.first);
  }
  // 2. Loop fusion: duplicated points replaced by the loop side's.
  for (KeyframeId id : group) {
    event.fused_points += fuse_loop_points(id, loop.loop_points, map, config_.search, config_.matching.max_distance);
  }
  for (MapPointId id : loop.loop_points) {
    if (map.point(id) != nullptr) map.update_point_statistics(id);
  }
  for (KeyframeId id : group) map.update_connections(id, config_.covisibility_min_weight);
  // 3. The essential graph: spanning tree and strong covisibility edges keep their uncorrected relative
  // poses; loop edges (links new since the fusion) take the corrected ones.
  std::map<KeyframeId, Eigen::Isometry3d> poses;
  for (const auto& [id, T] : before) poses[id] = map.keyframe(id)->T_world_cam;
  const std::vector<PoseGraphEdge> edges =
      essential_graph_edges(map, before, poses, group, old_connections, config_.strong_covisibility, {current_id, loop.loop});
  std::map<KeyframeId, Eigen::Isometry3d> optimized = poses;
  map.add_loop_edge(current_id, loop.loop);  // the later graphs' constraint (after this one's edges)
  if (fixed.empty()) fixed.insert(loop.loop);
  if (!optimize_pose_graph(optimized, edges, fixed, config_.pose_graph_iterations)) optimized = poses;
  // 4. Points follow their anchor keyframe from its pose before the graph to its pose after it.
  for (MapPointId id : map.point_ids()) {
    MapPoint& p = *map.point(id);
    const auto by_group = moved_points.find(id);
    const auto anchor = optimized.find(by_group != moved_points.end() ? by_group->second : anchor_of(p, map));
    if (anchor == optimized.end()) continue;
    p.position = anchor->second * (poses[anchor->first].inverse() * p.position);
  }
  for (const auto& [id, T] : optimized) {
    map.keyframe(id)->T_world_cam = T;
    moved.insert(id);
  }
  for (MapPointId id : map.point_ids()) map.update_point_statistics(id);
  event.moved_keyframes = static_cast<int>(optimized.size());
}

std::optional<GlobalBaProblem> LoopCloser::prepare_global_ba(int component, const Map& map) const {
  GlobalBaProblem gp;
  std::map<KeyframeId, int> index;
  for (const auto& [id, kf] : map.keyframes()) {
    if (kf.component != component) continue;
    if (gp.keyframe_ids.empty()) {
      gp.camera = kf.frame.camera;
      gp.bf = kf.frame.bf;
    }
    index[id] = static_cast<int>(gp.keyframe_ids.size());
    gp.keyframe_ids.push_back(id);
    gp.problem.keyframes.push_back(BaKeyframe{kf.T_cam_world(), kf.root});
  }
  if (gp.keyframe_ids.size() < 2) return std::nullopt;
  if (std::none_of(gp.problem.keyframes.begin(), gp.problem.keyframes.end(), [](const BaKeyframe& k) { return k.fixed; })) {
    gp.problem.keyframes.front().fixed = true;
  }
  for (MapPointId id : map.point_ids()) {
    const MapPoint& p = *map.point(id);
    const int point = static_cast<int>(gp.point_ids.size());
    bool any = false;
    for (const auto& [kf_id, feature] : p.observations) {
      const auto it = index.find(kf_id);
      if (it == index.end()) continue;
      gp.problem.observations.push_back(
          BaObservation{it->second, point, observation_of(map.keyframe(kf_id)->frame, static_cast<std::size_t>(feature))});
      gp.observation_of.emplace_back(kf_id, feature);
      any = true;
    }
    if (!any) continue;
    gp.point_ids.push_back(id);
    gp.problem.points_world.push_back(p.position);
  }
  if (gp.problem.observations.empty()) return std::nullopt;
  return gp;
}

BaResult LoopCloser::solve_global_ba(const GlobalBaProblem& gp) const {
  OptimizerConfig config = config_.bundle_adjustment;
  config.iterations_per_round = config_.global_ba_iterations;
  return bundle_adjust(gp.camera, gp.bf, gp.problem, config);
}

bool LoopCloser::apply_global_ba(const GlobalBaProblem& gp, const BaResult& result, Map& map,
                                 std::set<KeyframeId>& moved) const {
  if (!result.ok) return false;
  // Each solved keyframe's correction in the world frame, T_world_cam(after) = C * T_world_cam(prepared).
  std::map<KeyframeId, Eigen::Isometry3d> correction;
  int component = -1;
  for (std::size_t k = 0; k < gp.keyframe_ids.size(); ++k) {
    Keyframe* kf = map.keyframe(gp.keyframe_ids[k]);
    if (kf == nullptr) continue;
    component = kf->component;
    if (gp.problem.keyframes[k].fixed) {
      correction.emplace(kf->id, Eigen::Isometry3d::Identity());
      continue;
    }
    const Eigen::Isometry3d T_world_cam = result.T_cam_world[k].inverse();
    correction.emplace(kf->id, T_world_cam * gp.problem.keyframes[k].T_cam_world);
    kf->T_world_cam = T_world_cam;
    moved.insert(kf->id);
  }
  // Keyframes of the component that the problem did not hold (threaded mode: inserted while it was
  // solved) follow their best covisible solved keyframe, or else the newest solved one before them, as
  // ORB-SLAM propagates a global BA through the spanning tree.
  std::map<KeyframeId, Eigen::Isometry3d> followed;
  std::vector<KeyframeId> unsolved;
  for (const auto& [id, kf] : map.keyframes()) {
    if (kf.component == component && correction.count(id) == 0) unsolved.push_back(id);
  }
  for (KeyframeId id : unsolved) {
    Keyframe& kf = *map.keyframe(id);
    const Eigen::Isometry3d* C = nullptr;
    for (KeyframeId n : kf.best_covisible(static_cast<int>(kf.connections.size()))) {
      if (const auto it = correction.find(n); it != correction.end()) {
        C = &it->second;
        break;
      }
    }
    if (C == nullptr) {
      auto it = correction.lower_bound(id);
      if (it == correction.begin()) continue;
      C = &std::prev(it)->second;
    }
    kf.T_world_cam = *C * kf.T_world_cam;
    followed.emplace(id, *C);
    moved.insert(id);
  }
  for (std::size_t j = 0; j < gp.point_ids.size(); ++j) {
    if (MapPoint* p = map.point(gp.point_ids[j])) p->position = result.points_world[j];
  }
  // Points the problem did not hold (created meanwhile, also on solved keyframes) follow the keyframe they
  // are anchored to. All are looked at: counts cannot tell, as points are culled meanwhile too.
  const std::set<MapPointId> solved(gp.point_ids.begin(), gp.point_ids.end());
  for (MapPointId id : map.point_ids()) {
    if (solved.count(id) > 0) continue;
    MapPoint& p = *map.point(id);
    const KeyframeId anchor = anchor_of(p, map);
    const auto f = followed.find(anchor);
    const auto c = correction.find(anchor);
    if (f != followed.end()) {
      p.position = f->second * p.position;
    } else if (c != correction.end()) {
      p.position = c->second * p.position;
    }
  }
  for (std::size_t o = 0; o < gp.observation_of.size(); ++o) {
    if (!result.outlier[o]) continue;
    const MapPointId point = gp.point_ids[static_cast<std::size_t>(gp.problem.observations[o].point)];
    const auto& [kf_id, feature] = gp.observation_of[o];
    const Keyframe* kf = map.keyframe(kf_id);
    if (kf == nullptr || kf->frame.map_points[static_cast<std::size_t>(feature)] != point) continue;
    map.erase_observation(point, kf_id);
  }
  for (MapPointId id : gp.point_ids) {
    if (map.point(id) != nullptr) map.update_point_statistics(id);
  }
  return true;
}

}  // namespace fleetslam::slam
