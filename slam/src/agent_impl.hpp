#pragma once
// The agent's parts and per-run state (private to the slam library).

#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "fleetslam/slam/agent.hpp"
#include "mapping_worker.hpp"

namespace fleetslam::slam {

// A tracked frame's pose, kept relative to its reference keyframe so that it follows corrections.
struct FrameRecord {
  core::TimeNs t_ns = 0;
  KeyframeId reference = -1;
  Eigen::Isometry3d T_ref_cam = Eigen::Isometry3d::Identity();
};

struct Agent::Impl {
  Impl(const AgentConfig& config, const core::SensorRig& rig, core::Logger logger);

  bool is_rejection(FrameBuildStatus status) const;
  void reject(AgentUpdate& u) const;
  void note_gap(core::TimeNs dt_ns, std::string& notes) const;
  // Tracking, keyframe insertion and (deterministic mode) local mapping; the map lock is held.
  void track_and_map(Frame& frame, AgentUpdate& u);
  void insert_keyframe(Frame& frame, const TrackingResult& tracked, AgentUpdate& u, KeyframeId& reference);
  void report_changes(AgentUpdate& u);
  KeyframeSnapshot snapshot(const Keyframe& kf) const;
  // Pose of cam0 for a pose of the camera the frames live in (the rectified left camera for stereo).
  Eigen::Isometry3d to_cam0(const Eigen::Isometry3d& T_world_cam) const;

  AgentConfig config;
  core::SensorRig rig;
  core::Logger logger;
  FrameBuilder builder;
  Tracker tracker;
  LocalMapper mapper;
  Map map;
  mutable std::mutex map_mutex;
  MappingChanges changes;                    // guarded by map_mutex
  std::vector<FrameRecord> records;          // guarded by map_mutex
  std::vector<KeyframeId> new_keyframes;     // inserted during the current process() call
  std::optional<core::TimeNs> last_t_ns;
  std::unique_ptr<MappingWorker> worker;     // threaded mode only; last, so it stops first
};

}  // namespace fleetslam::slam
