#pragma once
// The per-robot SLAM agent: sensor frames in, value updates out (DESIGN.md data flow).
//   FrameBuilder (features, depth) -> Tracker (pose, keyframe decision) -> LocalMapper (map upkeep)
// Deterministic mode (default) runs local mapping inline after each keyframe: the same frames give
// bit-identical results. Threaded mode (`threaded: true`) runs the same mapping steps on one worker
// thread; the map is shared under one mutex (tracking holds it per frame, the worker per step, and local
// BA solves on a copy without it), so results vary from run to run with the scheduling.
//
// Bad input (empty image, an image of the wrong size, a stamp that does not advance) is rejected in the
// update with a reason; a frame without texture or depth goes to tracking and comes back not tracked
// (lost / not initialised) with a reason; nothing throws for bad frames.
// Poses are reported for the rig's cam0 (when the front end rectifies a stereo pair, tracking works in
// the rectified left camera and poses are mapped back). The world frame is cam0 at the first tracked
// frame.

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/core/sensor_frame.hpp"
#include "fleetslam/core/sensor_rig.hpp"
#include "fleetslam/core/trajectory.hpp"
#include "fleetslam/core/point_cloud.hpp"
#include "fleetslam/slam/dense_mapping.hpp"
#include "fleetslam/slam/frame_builder.hpp"
#include "fleetslam/slam/keyframe_policy.hpp"
#include "fleetslam/slam/local_mapping.hpp"
#include "fleetslam/slam/loop_closing.hpp"
#include "fleetslam/slam/map.hpp"
#include "fleetslam/slam/place_recognition.hpp"
#include "fleetslam/slam/tracker.hpp"

namespace fleetslam::slam {

// Which sensors the agent uses: the rig's mode, or RGB-D / stereo explicitly (a stereo rig's images
// may also be run as RGB-D only when frames carry depth).
enum class AgentSensor { kRig, kRgbd, kStereo };

struct AgentConfig {
  AgentSensor sensor = AgentSensor::kRig;
  FrameBuilderConfig frontend;
  TrackingConfig tracking;
  KeyframePolicyConfig keyframes = default_keyframes();
  LocalMappingConfig mapping;
  DenseMappingConfig dense;
  // Vocabulary and BoW of keyframes (loop closing and relocalisation need them; disabled: neither runs).
  PlaceRecognitionConfig place_recognition;
  LoopClosingConfig loop_closing;
  bool threaded = false;
  // A map file (map_io.hpp) the agent starts from instead of an empty map; empty: none.
  std::string load_map;
  // Tracking and relocalisation against the (loaded) map only: no keyframe insertion, no local mapping,
  // no loop closing, no new map component when tracking is lost (it keeps relocalising).
  bool localization_only = false;
  int max_mapping_queue = 3;             // threaded: keyframes waiting beyond this are not inserted
  double dropped_frame_periods = 1.5;    // a gap longer than this many frame periods is reported

  // The paper's exponential policy with Q = 2 (tuned on TUM fr1_rpy: Q = 1 takes a keyframe every
  // ~2 frames there, and keyframes of blurred frames spoil the map; Q = 2 halves them).
  static KeyframePolicyConfig default_keyframes();

  template <class V>
  void visit(V& v) {
    v.choice("sensor", sensor,
             {{"rig", AgentSensor::kRig}, {"rgbd", AgentSensor::kRgbd}, {"stereo", AgentSensor::kStereo}});
    v("frontend", frontend);
    v("matching", tracking.matcher);
    v("optimizer", tracking.pose_optimizer);
    v("keyframes", keyframes);
    v("tracking", tracking);
    v("mapping", mapping);
    v("dense", dense);
    v("place_recognition", place_recognition);
    v("loop_closing", loop_closing);
    v("relocalization", tracking.relocalization);
    v("threaded", threaded);
    v("load_map", load_map);
    v("localization_only", localization_only);
    v("max_mapping_queue", max_mapping_queue, core::Limits<int>{1, 1000});
    v("dropped_frame_periods", dropped_frame_periods, core::Limits<double>{1.0, 1000.0});
  }
};

enum class FrameStatus {
  kTracked,         // pose estimated against the map
  kInitialized,     // started a map component (first keyframe)
  kNotInitialized,  // no map yet and not enough depth to start one
  kLost,            // tracking failed (a later frame starts a new component)
  kRejected,        // bad input, not processed
  kMapChanges,      // no frame: the map changes finish() reports after the last frame
};
// "tracked", "initialized", "not_initialized", "lost", "rejected", "map_changes"
std::string to_string(FrameStatus status);

// A keyframe as the central unit sees it: pose (cam0), its map points, and its dense points.
struct KeyframeSnapshot {
  KeyframeId id = -1;
  core::TimeNs t_ns = 0;
  int component = 0;
  Eigen::Isometry3d T_world_cam = Eigen::Isometry3d::Identity();
  std::vector<MapPointId> point_ids;
  std::vector<Eigen::Vector3d> points_world;
  // The keyframe's whole dense cloud in its cam0 frame, sent when it is new or changed (the keyframe's
  // cloud arrived from the threaded dense worker, or a culled keyframe handed its points to this one);
  // absent when unchanged since the last snapshot that carried it. Receivers replace what they hold.
  std::optional<core::PointCloud> dense_cam;
};

struct AgentTimings {
  double extract_ms = 0.0;     // front end: image conversion, ORB, undistortion, depth
  double match_ms = 0.0;       // frame-to-frame matching
  double pose_ms = 0.0;        // pose-only optimisations
  double local_map_ms = 0.0;   // local map projection search
  double tracking_ms = 0.0;    // extract + everything tracking did (the per-frame tracking cost)
  double mapping_ms = 0.0;     // inline local mapping (deterministic mode, keyframes only)
  double dense_ms = 0.0;       // dense mapping in this call (inline back-projection, insertion)
  double loop_ms = 0.0;        // inline loop closing (deterministic mode, keyframes only; global BA included)
  double total_ms = 0.0;       // the whole process() call
};

struct AgentUpdate {
  int robot_id = 0;
  std::int64_t sequence = 0;
  core::TimeNs t_ns = 0;
  FrameStatus status = FrameStatus::kRejected;
  TrackingState tracking_state = TrackingState::kNotInitialized;
  std::string reason;  // why not tracked / rejected; notes (no depth, dropped frames) otherwise
  std::optional<Eigen::Isometry3d> T_world_cam;  // cam0, when tracked or initialised
  int component = -1;
  int features = 0;
  int features_with_depth = 0;
  int inliers = 0;
  std::vector<KeyframeSnapshot> new_keyframes;
  std::vector<KeyframeSnapshot> changed_keyframes;  // poses moved by local BA since the last update
  std::vector<KeyframeId> removed_keyframes;         // culled since the last update
  std::optional<KeyframeDecision> keyframe_decision;
  // Loops closed since the last update (their moved keyframes are in changed_keyframes).
  std::vector<LoopEvent> loops;
  bool relocalized = false;  // this frame found the map again after tracking was lost
  AgentTimings timings;

  bool has_pose() const { return T_world_cam.has_value(); }
};

struct MapStats {
  std::size_t keyframes = 0;
  std::size_t points = 0;
  int components = 0;
  std::size_t dense_points = 0;
  LoopRejections loop_rejections;  // verified loop candidates refused by the guards
};

class Agent {
 public:
  // Throws InputError for a rig the front end cannot use, a sensor choice the rig does not have, a
  // vocabulary that cannot be loaded (place_recognition.enabled), or a map file (load_map) that cannot.
  explicit Agent(const AgentConfig& config, const core::SensorRig& rig, core::Logger logger);
  ~Agent();
  Agent(Agent&&) noexcept;
  Agent& operator=(Agent&&) noexcept;
  Agent(const Agent&) = delete;
  Agent& operator=(const Agent&) = delete;

  AgentUpdate process(const core::SensorFrame& frame);
  // Threaded mode: waits until local mapping and dense mapping have handled every queued keyframe and
  // inserts the last dense clouds. Returns the map changes not yet reported (the workers' last keyframe
  // moves, culls and dense clouds, which process() would report with the next frame) as an update of
  // status kMapChanges, with the robot id, sequence and time of the last frame given to process(); in
  // inline mode process() has reported everything and the update holds no changes. Send it on like any
  // other update, or the receiver's map misses the last keyframes' clouds.
  AgentUpdate finish();

  // Every tracked frame, cam0, each pose relative to its reference keyframe so it follows the
  // keyframes' corrections (as ORB-SLAM saves trajectories).
  core::Trajectory trajectory() const;
  // The keyframes still in the map, cam0, in time order.
  core::Trajectory keyframe_trajectory() const;
  TrackingState state() const;
  MapStats map_stats() const;
  // The dense map in the world frame (cam0 of the first tracked frame), each keyframe's points moved by
  // its current pose.
  core::PointCloud dense_cloud() const;
  DenseStats dense_stats() const;
  const AgentConfig& config() const;

  // A deep copy of the map as it is now (threaded mode: call finish() first for a settled one).
  Map map_copy() const;
  // Saves the map (map_io.hpp) once the workers are idle; their changes stay for the next update or
  // finish(). Throws InputError naming the file when it cannot be written.
  void save_map(const std::filesystem::path& file);
  // Starts from a saved map: before the first frame only (InvariantError otherwise). Keyframes' BoW vectors
  // are recomputed with this agent's vocabulary (and levels_up); the keyframe database indexes them; the
  // tracker starts lost, so the first frame relocalises, in any of the map's components until it is placed
  // (then in the component it was placed in; the newest keyframe's before that).
  // Throws InputError naming the file for a missing, truncated, corrupted, foreign or wrong-version file.
  void load_map(const std::filesystem::path& file);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fleetslam::slam
