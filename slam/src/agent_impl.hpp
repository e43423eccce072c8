#pragma once
// The agent's parts and per-run state (private to the slam library).

#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "fleetslam/slam/agent.hpp"
#include "fleetslam/slam/gyro.hpp"
#include "dense_worker.hpp"
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
  void track_and_map(Frame& frame, const std::optional<Eigen::Matrix3d>& gyro_R_prev_cur, AgentUpdate& u);
  // IMU samples waiting for the next accepted frame, and the gyro rotation since the last accepted one.
  void buffer_imu(const std::vector<core::ImuSample>& samples);
  std::optional<Eigen::Matrix3d> gyro_rotation(core::TimeNs t_ns);
  // Makes the frame a keyframe and maps it (inline mode); false when the busy worker refused it.
  bool insert_keyframe(Frame& frame, const TrackingResult& tracked, AgentUpdate& u, KeyframeId& reference);
  void report_changes(AgentUpdate& u);
  // BoW of a new keyframe; loop closing at a keyframe (deterministic mode: called inline; threaded mode:
  // by the mapping worker without the map lock, which it takes itself) and its database entry.
  void compute_bow(KeyframeId id);
  void close_loop_inline(KeyframeId id);
  void close_loop_threaded(KeyframeId id);
  // Dense clouds of the keyframes inserted in this call (inline, or queued to the dense worker) and
  // those the worker finished; culled keyframes hand their points over in report_changes.
  void update_dense(const core::SensorFrame& sensor);
  void insert_dense(KeyframeId id, const core::PointCloud& cloud_cam);
  KeyframeSnapshot snapshot(const Keyframe& kf, bool with_dense) const;
  // Pose of cam0 for a pose of the camera the frames live in (the rectified left camera for stereo).
  Eigen::Isometry3d to_cam0(const Eigen::Isometry3d& T_world_cam) const;

  AgentConfig config;
  core::SensorRig rig;
  core::Logger logger;
  FrameBuilder builder;
  Tracker tracker;
  LocalMapper mapper;
  DenseMapper dense;
  Map map;
  std::shared_ptr<const Vocabulary> vocabulary;  // null when place recognition is disabled
  KeyframeDatabase database;                     // guarded by map_mutex
  std::optional<LoopCloser> loop_closer;
  std::vector<LoopEvent> loops;                  // closed since the last update; guarded by map_mutex
  mutable std::mutex map_mutex;
  MappingChanges changes;                    // guarded by map_mutex
  std::vector<FrameRecord> records;          // guarded by map_mutex
  std::vector<KeyframeId> new_keyframes;     // inserted during the current process() call
  std::set<KeyframeId> dense_changed;        // dense cloud to send with the next snapshot
  std::optional<core::TimeNs> last_t_ns;      // of the last frame accepted
  int last_robot_id = 0;                     // of the last frame given to process() (finish()'s update)
  std::int64_t last_sequence = 0;
  std::optional<GyroIntegrator> gyro;        // when the rig has a gyroscope and tracking.gyro is on
  std::vector<core::ImuSample> imu_buffer;   // samples after the last accepted frame
  std::unique_ptr<DenseWorker> dense_worker; // threaded mode only; stops before `dense` goes
  std::unique_ptr<MappingWorker> worker;     // threaded mode only; last, so it stops first
};

}  // namespace fleetslam::slam
