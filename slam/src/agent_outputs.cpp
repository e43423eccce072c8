// What an agent hands out after (or during) a run: trajectories and map statistics.

#include <algorithm>
#include <set>

#include "agent_impl.hpp"

namespace fleetslam::slam {

core::Trajectory Agent::trajectory() const {
  const Impl& s = *impl_;
  const std::lock_guard<std::mutex> lock(s.map_mutex);
  core::Trajectory trajectory;
  trajectory.reserve(s.records.size());
  for (const FrameRecord& r : s.records) {
    const std::optional<Eigen::Isometry3d> T_w_ref = s.map.keyframe_pose(r.reference);
    if (T_w_ref) trajectory.push_back(core::StampedPose{r.t_ns, s.to_cam0(*T_w_ref * r.T_ref_cam)});
  }
  return trajectory;
}

core::Trajectory Agent::keyframe_trajectory() const {
  const Impl& s = *impl_;
  const std::lock_guard<std::mutex> lock(s.map_mutex);
  core::Trajectory trajectory;
  for (const auto& [id, kf] : s.map.keyframes()) trajectory.push_back(core::StampedPose{kf.t_ns, s.to_cam0(kf.T_world_cam)});
  std::stable_sort(trajectory.begin(), trajectory.end(),
                   [](const core::StampedPose& a, const core::StampedPose& b) { return a.t_ns < b.t_ns; });
  return trajectory;
}

MapStats Agent::map_stats() const {
  const Impl& s = *impl_;
  const std::lock_guard<std::mutex> lock(s.map_mutex);
  MapStats stats;
  stats.keyframes = s.map.keyframe_count();
  stats.points = s.map.point_count();
  std::set<int> components;
  for (const auto& entry : s.map.keyframes()) components.insert(entry.second.component);
  stats.components = static_cast<int>(components.size());
  stats.dense_points = s.dense.stats().points;
  if (s.loop_closer) stats.loop_rejections = s.loop_closer->rejections();
  return stats;
}

}  // namespace fleetslam::slam
