#pragma once
// The central unit (PAPER.md §4, DESIGN.md data flow): agents' updates in, one world map out.
//   integrate(update)  keeps each robot's state: its frames (each relative to the keyframe that was
//                      newest when it arrived, so keyframe corrections move it), its keyframes' poses
//                      and dense clouds (relative to the keyframe), in the robot's own frame (its agent's
//                      world: the first camera pose);
//   merge()            the robots' dense clouds into the world frame by their initial-pose priors
//                      (coarse), refined by registration where they overlap (fine), merged, uniformly
//                      sampled and Gaussian-filtered (MapMerger); then each robot's trajectory fused into
//                      the world frame (TrajectoryFusion), with the keyframes in the overlap as anchors.
// Later map components: when an agent loses track and starts a new map component, that component is
// continuous with the robot's frame only as far as its dead reckoning goes (the last pose, or the gyro's
// prediction). Each later component is a submap: after all robots' first components it is registered
// against the merged map like a robot whose prior is the transform of the component it continues (the
// one before it), and joins the map (its keyframes and frames placed by its own transform) only when it
// overlaps enough; until then its frames follow that prior and its cloud stays out of the merged map.
// The server never includes the simulator: simulated and real robots look the same to it.
//
// An agent's map changes after its last frame (Agent::finish, status kMapChanges) carry that frame's
// sequence: accepted without advancing it, and not counted as a frame's update.
// Bad input is logged and counted, never thrown: an update from a robot not registered, one whose
// sequence does not advance (duplicate or out of order), a pose or cloud with NaN (the NaN points are
// dropped; an update whose frame pose is not finite still delivers its keyframe changes). Robots that never overlap keep the coarse result; later components that never overlap stay
// out of the merged map. Not thread-safe: one thread integrates and merges (agents may send from their own
// threads through the Link).

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "fleetslam/central/link.hpp"
#include "fleetslam/central/map_merger.hpp"
#include "fleetslam/central/trajectory_fusion.hpp"
#include "fleetslam/core/config.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/core/point_cloud.hpp"
#include "fleetslam/core/trajectory.hpp"
#include "fleetslam/slam/agent.hpp"

namespace fleetslam::central {

struct ServerConfig {
  MapMergerConfig merge;
  TrajectoryFusionConfig fusion;
  // A keyframe anchors its robot's trajectory to the refined transform when at least this share of its
  // dense points lies within anchor_radius_m of another robot's map (both placed by the merge).
  double anchor_min_overlap_share = 0.2;
  double anchor_radius_m = 0.05;
  // Teammates are no map: each keyframe's points that lie in another robot's body where that robot was at
  // the keyframe's time (its body cylinder grown by teammate_margin_m, the estimates' error, sideways and
  // upwards; not below it, where the floor is) are left out of the maps. Both robots must be placed by
  // fine registration (or be the reference): priors say too little of where one robot stands in the
  // other's map. The placements are the last merge's (the first merge masks nothing). The other robot's
  // pose is interpolated between its frames no more than teammate_max_gap_s apart.
  bool mask_teammates = true;
  double teammate_margin_m = 0.05;
  double teammate_max_gap_s = 0.2;

  template <class V>
  void visit(V& v) {
    v("merge", merge);
    v("fusion", fusion);
    v("anchor_min_overlap_share", anchor_min_overlap_share, core::Limits<double>{0.0, 1.0});
    v("anchor_radius_m", anchor_radius_m, core::Limits<double>{1e-4, 10.0});
    v("mask_teammates", mask_teammates);
    v("teammate_margin_m", teammate_margin_m, core::Limits<double>{0.0, 10.0});
    v("teammate_max_gap_s", teammate_max_gap_s, core::Limits<double>{0.0, 100.0});
  }
};

// The space a robot's body takes, for telling it apart from the scene in other robots' clouds: a
// cylinder about the body frame's z axis. radius_m 0: unknown (never masked).
struct RobotBody {
  Eigen::Isometry3d T_cam_body = Eigen::Isometry3d::Identity();  // the body frame in the camera's
  double radius_m = 0.0;
  double z_min_m = 0.0;  // along body z
  double z_max_m = 0.0;
};

// A robot as the server knows it before any update: its id (AgentUpdate::robot_id), a name for files
// and logs, the prior T_world_robot: the pose of the robot's frame (its first camera) in the world, and
// its body.
struct RobotSpec {
  int robot_id = 0;
  std::string name;
  Eigen::Isometry3d T_world_robot = Eigen::Isometry3d::Identity();
  RobotBody body;
};

enum class IntegrateStatus { kAccepted, kUnknownRobot, kOutOfOrder, kInvalid };
std::string to_string(IntegrateStatus status);  // "accepted", "unknown_robot", "out_of_order", "invalid"

struct RobotCounters {
  std::size_t updates = 0;      // accepted
  std::size_t rejected = 0;     // out of order / duplicate / invalid
  std::size_t tracked = 0;      // accepted updates with a pose
  std::size_t lost = 0;
  std::size_t other_component_keyframes = 0;  // keyframes of later map components (submaps)
  std::size_t nan_points = 0;   // dense points dropped for NaN / inf
};

struct ServerKeyframe {
  core::TimeNs t_ns = 0;
  int component = 0;  // the agent's map component
  Eigen::Isometry3d T_robot_cam = Eigen::Isometry3d::Identity();
  core::PointCloud dense_cam;        // as the agent sent it
  std::vector<bool> on_teammate;     // per point of dense_cam, by the last merge (empty: none)
};

// A later map component of a robot (see the file comment) after a merge.
struct ComponentPlacement {
  int component = 0;
  int merge_id = 0;                // its id in MergeResult::robots (after the robots' ids)
  std::size_t points = 0;
  bool placed = false;             // in the merged map
  bool registered = false;         // fine matching placed it (RobotMergeReport::fine_matched)
  std::string merge_status;
  Eigen::Isometry3d T_world_component = Eigen::Isometry3d::Identity();  // placed: its own; else its prior
};

struct RobotFusionReport {
  int robot_id = 0;
  std::string name;
  std::size_t points = 0;          // dense points in the robot's map
  std::size_t teammate_points = 0; // of them, left out as points on other robots
  std::size_t overlap_points = 0;  // in the overlap with the map it was registered against
  bool registered = false;         // fine matching placed it: refined its prior, or confirmed it (fine_matched)
  std::string merge_status;        // the merger's word on it ("reference", "fine matched", "no overlap: prior kept", ...)
  std::vector<std::size_t> anchors;  // keyframes (indices in time order) in the overlap
  Eigen::Isometry3d T_world_robot = Eigen::Isometry3d::Identity();  // refined (or the prior)
  int component = 0;                        // the first map component, which T_world_robot places
  std::vector<ComponentPlacement> later_components;
  FusedTrajectory fused;  // frames_world: the first component fused, later ones placed rigidly, in time order

  // Where the robot's map component `component` lies in the world: the robot's transform for the first
  // component; a later one's own placement, or its prior while not placed; one newer than the merge
  // continues the newest component before it.
  Eigen::Isometry3d T_world(int component) const;
  const ComponentPlacement* later_component(int component) const;  // nullptr when not a later one
};

struct ServerMergeReport {
  MergeResult merge;
  std::vector<RobotFusionReport> robots;
};

// The merger's report on one robot (nullptr when it was not in the merge).
const RobotMergeReport* merged_robot(const MergeResult& result, int robot_id);
// Counts, timings, per-robot transforms and registration results, as written to merge.json.
nlohmann::json to_json(const MergeResult& result);

class Server {
 public:
  Server(const ServerConfig& config, core::Logger logger);

  // Registers a robot. Throws InputError for an id registered twice or a non-rigid prior.
  void add_robot(const RobotSpec& spec);
  IntegrateStatus integrate(const slam::AgentUpdate& update);
  // Integrates everything waiting on the link; returns how many updates were accepted.
  std::size_t integrate_all(Link& link);

  // Merges the current maps and fuses the trajectories (see the file comment).
  const ServerMergeReport& merge();
  const std::optional<ServerMergeReport>& last_merge() const { return last_merge_; }

  std::vector<int> robot_ids() const;
  const RobotSpec& spec(int robot_id) const;
  const RobotCounters& counters(int robot_id) const;
  // The robot's dense map in its own frame (each keyframe's cloud moved by its latest pose, its points
  // on other robots left out); with a component, that component's part only.
  core::PointCloud robot_cloud(int robot_id, std::optional<int> component = std::nullopt) const;
  // Every accepted tracked frame in the robot's frame, following its keyframes' latest poses.
  core::Trajectory robot_trajectory(int robot_id, std::optional<int> component = std::nullopt) const;
  // Keyframes in time order, robot frame.
  core::Trajectory robot_keyframes(int robot_id, std::optional<int> component = std::nullopt) const;
  // The robot's dense map in the world: each component by its placement, components left out excluded.
  core::PointCloud world_cloud(int robot_id) const;
  // Where the robot's map component lies in the world as the last merge has it (before: the prior).
  Eigen::Isometry3d T_world_component(int robot_id, int component) const;
  // The same keyframes with their dense clouds (camera frame, as sent, with the points on other robots
  // marked): where each cloud was seen from, for free-space carving. Views into the server's own
  // keyframes (no copy of the clouds), valid until its next integrate() or merge().
  std::vector<const ServerKeyframe*> robot_keyframe_clouds(int robot_id) const;
  // After merge(): the robot's frames in the world frame (before: placed by the prior).
  core::Trajectory world_trajectory(int robot_id) const;

  // merged_map.ply, <name>/map.ply (world frame), <name>/trajectory.txt (world, TUM),
  // <name>/trajectory_robot.txt (robot frame), merge.json (counts, transforms, timings). Merges first
  // when merge() has not run.
  void write_outputs(const std::filesystem::path& dir);

  const ServerConfig& config() const { return config_; }

 private:
  struct FrameEntry {
    core::TimeNs t_ns = 0;
    int component = 0;
    slam::KeyframeId reference = -1;
    Eigen::Isometry3d T_ref_cam = Eigen::Isometry3d::Identity();
  };
  struct RobotState {
    RobotSpec spec;
    RobotCounters counters;
    std::int64_t last_sequence = -1;
    int component = -1;  // the map component the prior places (the first one seen)
    std::map<slam::KeyframeId, ServerKeyframe> keyframes;
    // Removed keyframes' last poses, for frames that had no heir to move to (see retire_keyframe).
    std::map<slam::KeyframeId, Eigen::Isometry3d> retired;
    std::map<int, slam::KeyframeId> newest;  // per component
    std::vector<FrameEntry> frames;
  };

  RobotState& state(int robot_id);
  const RobotState& state(int robot_id) const;
  void take_keyframe(RobotState& robot, const slam::KeyframeSnapshot& kf);
  void retire_keyframe(RobotState& robot, slam::KeyframeId id);
  std::optional<Eigen::Isometry3d> keyframe_pose(const RobotState& robot, slam::KeyframeId id) const;
  // The component's transform in the last merge (nullopt: no merge yet, or the component was not in it).
  std::optional<Eigen::Isometry3d> last_placement(int robot_id, int component) const;
  // The same, only where fine registration placed it (or it is the reference).
  std::optional<Eigen::Isometry3d> registered_placement(int robot_id, int component) const;
  // Marks each keyframe's points on other robots (ServerConfig::mask_teammates), by the last merge's
  // placements.
  void mask_teammates();
  const RobotFusionReport* last_report(int robot_id) const;  // nullptr before the first merge
  static std::set<int> components(const RobotState& robot);  // of the keyframes held

  ServerConfig config_;
  core::Logger logger_;
  MapMerger merger_;
  TrajectoryFusion fusion_;
  std::map<int, RobotState> robots_;
  std::optional<ServerMergeReport> last_merge_;
};

}  // namespace fleetslam::central
