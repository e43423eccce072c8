#pragma once
// Tracking: the camera pose of every frame against the agent's map (ORB-SLAM's design, written here).
//   not initialised -> the first frame with enough features, enough of them with depth, starts a map
//         (points from depth);
//   ok -> constant-velocity prediction, projection matching against the last frame (cross-validation as
//         the matcher config says; stage 2 uses the current frame's depth points), falling back to the
//         reference keyframe seen from the last pose with a wider radius; pose-only optimisation after each
//         stage; then the local map (keyframes sharing points with the frame and their neighbours)
//         projected with visibility checks, matched on the grid, pose optimised again;
//   too few inliers -> lost; the next recovery_frames frames retry the reference keyframe from the last
//         good pose; after that each frame tries relocalisation (below); when relocalisation has failed
//         for relocalization.new_map_after_s on consecutive frames with enough features (a blank frame
//         restarts the count), the next frame with enough depth starts a new map component at the last
//         known pose.
// Relocalisation (ORB-SLAM's idea, written here): the frame's BoW vector against the keyframe database,
// BoW matches with each candidate's map points, PnP-RANSAC (OpenCV) on the 2D-3D pairs, pose-only
// optimisation, a guided search of the candidate's neighbourhood points by projection, optimisation again;
// then the local map stage as for any frame. A pose the camera could not have reached from its last
// estimate in the time lost is refused (RelocalizationConfig::check_jump) and the next candidate tried.
// With a gyroscope (TrackingInputs::gyro_R_prev_cur) the predicted rotation is the gyro's, less a bias the
// tracker estimates from tracked frame pairs; the translation stays the constant-velocity one. While lost,
// each frame (for gyro.recovery_s) first tries the last local map seen from the gyro-predicted pose, before
// the reference keyframe or relocalisation, and a new map component starts at that predicted pose.
// The keyframe decision is the policy's (keyframe_policy.hpp), fed with the frame's real quantities.
// The tracker reads and updates the map (tracking counters) but inserts nothing: the agent hands the
// frame to local mapping when the result asks for a keyframe.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/slam/frame.hpp"
#include "fleetslam/slam/gyro.hpp"
#include "fleetslam/slam/keyframe_database.hpp"
#include "fleetslam/slam/keyframe_policy.hpp"
#include "fleetslam/slam/map.hpp"
#include "fleetslam/slam/map_projection.hpp"
#include "fleetslam/slam/matcher.hpp"
#include "fleetslam/slam/optimizer.hpp"

namespace fleetslam::slam {

enum class TrackingState { kNotInitialized, kOk, kLost };
std::string to_string(TrackingState state);  // "not_initialized", "ok", "lost"

struct RelocalizationConfig {
  bool enabled = true;
  int max_candidates = 5;            // best BoW candidates tried
  int min_bow_matches = 15;
  int ransac_iterations = 300;
  double ransac_reprojection_px = 4.0;  // RANSAC's hypothesis test; the inliers are then gated by level sigma
  int min_ransac_inliers = 12;
  int min_inliers = 50;              // after optimisation and guided search
  double new_map_after_s = 1.0;      // relocalisation failing this long (frames with features) -> new map
  int search_neighbours = 10;        // candidate's covisible keyframes whose points the guided search uses
  // A relocalised pose must be one the camera could reach from its last estimate in the time it was lost:
  // its centre within max_jump_floor_m + max_jump_m_per_s * lost_s and its rotation within
  // max_jump_floor_deg + max_jump_deg_per_s * lost_s. A wall papered like another elsewhere in the map
  // gives a confident pose in the wrong room; after a long loss anything goes. check_jump false: off.
  // With a gyroscope the rotation through the loss is known (the gyro's prediction from the last tracked
  // frame, bias removed): the relocalised rotation must then lie within max_jump_gyro_floor_deg +
  // max_jump_gyro_deg_per_s * lost_s of that prediction instead.
  bool check_jump = true;
  double max_jump_floor_m = 0.3;
  double max_jump_m_per_s = 1.0;
  double max_jump_floor_deg = 20.0;
  double max_jump_deg_per_s = 60.0;
  double max_jump_gyro_floor_deg = 5.0;
  double max_jump_gyro_deg_per_s = 2.0;
  BowMatchConfig matching;

  template <class V>
  void visit(V& v) {
    v("enabled", enabled);
    v("max_candidates", max_candidates, core::Limits<int>{1, 1000});
    v("min_bow_matches", min_bow_matches, core::Limits<int>{4, 100000});
    v("ransac_iterations", ransac_iterations, core::Limits<int>{1, 100000});
    v("ransac_reprojection_px", ransac_reprojection_px, core::Limits<double>{0.1, 100.0});
    v("min_ransac_inliers", min_ransac_inliers, core::Limits<int>{4, 100000});
    v("min_inliers", min_inliers, core::Limits<int>{4, 100000});
    v("new_map_after_s", new_map_after_s, core::Limits<double>{0.0, 1e6});
    v("search_neighbours", search_neighbours, core::Limits<int>{0, 1000});
    v("check_jump", check_jump);
    v("max_jump_floor_m", max_jump_floor_m, core::Limits<double>{0.0, 1e6});
    v("max_jump_m_per_s", max_jump_m_per_s, core::Limits<double>{0.0, 1e6});
    v("max_jump_floor_deg", max_jump_floor_deg, core::Limits<double>{0.0, 360.0});
    v("max_jump_deg_per_s", max_jump_deg_per_s, core::Limits<double>{0.0, 1e6});
    v("max_jump_gyro_floor_deg", max_jump_gyro_floor_deg, core::Limits<double>{0.0, 360.0});
    v("max_jump_gyro_deg_per_s", max_jump_gyro_deg_per_s, core::Limits<double>{0.0, 1e6});
    v("matching", matching);
  }
};

// Matching and optimisation settings come in apart (the agent's `matching` and `optimizer` sections);
// these are tracking's own.
struct TrackingConfig {
  MatcherConfig matcher = default_matcher();  // motion-model stage against the last frame
  OptimizerConfig pose_optimizer;
  // Reference-keyframe stage: the last pose only (no prediction), so the window is wider.
  double reference_radius_factor = 3.0;
  ProjectionSearchConfig local_map;
  int init_min_features = 500;        // features needed to start a map (ORB-SLAM's N > 500) ...
  int init_min_depth_features = 100;  // ... of which this many with depth (they become its points)
  int min_frame_matches = 20;         // frame-to-frame matches below this: widen, then fall back
  int min_frame_inliers = 10;         // map-point inliers after optimising a frame-to-frame stage
  int min_local_map_inliers = 30;     // inliers after the local map stage; fewer -> lost
  int recovery_frames = 5;            // lost frames that retry the reference keyframe before a new map
  int local_neighbours_per_keyframe = 10;
  int max_local_keyframes = 80;
  // Temporary visual-odometry points: the last frame's close depth features without a map point also
  // guide the frame-to-frame stage and pose optimisation (they never enter the map). ORB-SLAM makes them
  // in localisation-only mode alone; here they are on in SLAM mode too, a deliberate deviation that
  // measured neither clearly better nor worse (one deterministic replay each, ATE RMSE on -> off): TUM
  // fr1_rpy 2.57 -> 2.17 cm, EuRoC micro 0.88 -> 0.85 mm, synthetic office alpha 1.75 -> 1.60 mm and
  // bravo 2.40 -> 1.85 mm, apartment alpha 0.96 -> 1.35 mm, bravo 1.44 -> 2.39 mm, charlie 11.8 -> 9.9 mm.
  bool last_frame_depth_points = true;
  GyroConfig gyro;
  RelocalizationConfig relocalization;  // the agent visits it as its own section

  // Window 10 px at level 0 (ORB-SLAM: 7 px for RGB-D / stereo) and cross-validation off by default
  // (tracker.cpp gives the measurements); matching.cross_validation switches it on.
  static MatcherConfig default_matcher();

  // Without `matcher` and `pose_optimizer` (the agent visits those as its own sections).
  template <class V>
  void visit(V& v) {
    v("reference_radius_factor", reference_radius_factor, core::Limits<double>{1.0, 100.0});
    v("local_map", local_map);
    v("init_min_features", init_min_features, core::Limits<int>{1, 100000});
    v("init_min_depth_features", init_min_depth_features, core::Limits<int>{1, 100000});
    v("min_frame_matches", min_frame_matches, core::Limits<int>{3, 100000});
    v("min_frame_inliers", min_frame_inliers, core::Limits<int>{3, 100000});
    v("min_local_map_inliers", min_local_map_inliers, core::Limits<int>{3, 100000});
    v("recovery_frames", recovery_frames, core::Limits<int>{0, 100000});
    v("local_neighbours_per_keyframe", local_neighbours_per_keyframe, core::Limits<int>{0, 1000});
    v("max_local_keyframes", max_local_keyframes, core::Limits<int>{1, 10000});
    v("last_frame_depth_points", last_frame_depth_points);
    v("gyro", gyro);
  }
};

// What the tracker is told about the rest of the agent for this frame.
struct TrackingInputs {
  bool local_mapping_idle = true;
  int local_mapping_queue = 0;
  double fps = 30.0;
  // Where a new map component starts when nothing better is known (the first one: the world origin).
  Eigen::Isometry3d initial_T_world_cam = Eigen::Isometry3d::Identity();
  // Place recognition for relocalisation (none: a lost tracker only retries and starts new maps).
  const Vocabulary* vocabulary = nullptr;
  const KeyframeDatabase* database = nullptr;
  int bow_levels_up = 2;
  // Localisation only: tracking and relocalisation against the map as it is; no map is ever started
  // (a tracker without one stays not initialised, a lost one keeps relocalising) and no keyframe asked for.
  bool localization_only = false;
  // Rotation of the camera since the previous frame handed to track() (R_prev_cur, camera frame), from the
  // gyroscope with its bias left in; nullopt without one.
  std::optional<Eigen::Matrix3d> gyro_R_prev_cur;
};

struct TrackingTimings {
  double match_ms = 0.0;      // frame-to-frame matching (motion model / reference keyframe)
  double pose_ms = 0.0;       // pose-only optimisations
  double local_map_ms = 0.0;  // local map selection, projection and search
};

struct TrackingResult {
  TrackingState state = TrackingState::kNotInitialized;
  bool initialized = false;  // this frame starts a map component (it becomes its first keyframe)
  std::string stage;         // "init", "motion_model", "reference_keyframe", "gyro_prediction", "relocalization", or empty when not tracked
  bool relocalized = false;  // this frame found the map again by relocalisation
  double lost_s = 0.0;       // when recovered: time since the first lost frame
  std::string reason;        // why the frame is not tracked (empty when tracked)
  std::optional<Eigen::Isometry3d> T_world_cam;
  KeyframeId reference_keyframe = -1;
  int features = 0;
  int frame_matches = 0;   // frame-to-frame stage matches
  int inliers = 0;         // map points tracked after the local map stage
  bool insert_keyframe = false;
  std::optional<KeyframeDecision> decision;
  std::optional<KeyframeContext> context;
  TrackingTimings timings;
};

class Tracker {
 public:
  Tracker(const TrackingConfig& config, const KeyframePolicyConfig& keyframes, core::Logger logger);

  // Tracks `frame` (its map_points, outlier and T_world_cam are set) against `map`.
  TrackingResult track(Frame& frame, Map& map, const TrackingInputs& inputs);
  // The frame just tracked became keyframe `id` (with its points as local mapping created them): it is
  // the new reference, and the next frame matches against its points.
  void keyframe_inserted(KeyframeId id, const Map& map);
  // Before the first frame, with a map loaded into the agent: the tracker starts lost in `component` (the
  // map's newest), so that the first frame goes straight to relocalisation; a map started later comes
  // after it.
  void start_in_map(int component);

  TrackingState state() const { return state_; }
  int component() const { return component_; }
  // The gyroscope bias estimated so far (camera frame, rad/s; zero without a gyroscope).
  const Eigen::Vector3d& gyro_bias_radps() const { return gyro_bias_cam_; }

 private:
  struct Working;  // per-frame scratch (temporary points, counters)

  TrackingResult initialize(Frame& frame, const TrackingInputs& inputs);
  bool track_last_frame(Working& w, Map& map, TrackingResult& result);
  bool track_reference_keyframe(Working& w, Map& map, TrackingResult& result, bool recovering);
  int match_reference_from(Working& w, const Keyframe& ref, const Map& map, const Eigen::Isometry3d& T_cw_prior,
                           TrackingResult& result);
  int match_reference(Working& w, const Keyframe& ref, const Map& map, const Eigen::Isometry3d& T_cw,
                      const MatcherConfig& matcher, TrackingResult& result);
  bool track_local_map(Working& w, Map& map, TrackingResult& result);
  bool track_from_gyro(Working& w, Map& map, TrackingResult& result);
  void accumulate_gyro(core::TimeNs t_ns, const TrackingInputs& inputs);
  bool gyro_prediction_valid() const;
  // While lost with the gyro: the last estimate follows its prediction (a new component starts there).
  void dead_reckon(const Map& map, core::TimeNs t_ns);
  bool relocalize(Working& w, Map& map, const TrackingInputs& inputs, TrackingResult& result);
  int relocalize_with(Working& w, const Keyframe& candidate, const FeatureVector& words, Map& map,
                      TrackingResult& result);
  void lose(Working& w, const Map& map, TrackingResult& result);
  int optimize(Working& w, const Map& map, const Eigen::Isometry3d& T_cam_world_initial, TrackingResult& result);
  void decide_keyframe(Working& w, const Map& map, const TrackingInputs& inputs, TrackingResult& result);
  std::optional<Eigen::Isometry3d> last_frame_pose(const Map& map) const;
  std::optional<Eigen::Isometry3d> predicted_pose(const Map& map, core::TimeNs t_ns) const;
  void remember(const Working& w, const Map& map, bool tracked);

  TrackingConfig config_;
  std::unique_ptr<KeyframePolicy> policy_;
  core::Logger logger_;

  TrackingState state_ = TrackingState::kNotInitialized;
  int component_ = -1;
  int newest_component_ = -1;  // the highest component started or loaded: a new one comes after it
  int lost_frames_ = 0;  // consecutive frames lost (the current one included)
  bool lost_before_first_frame_ = false;  // start_in_map: lost_since_ns_ is the first frame's stamp
  bool in_loaded_map_ = false;            // start_in_map until the first frame is placed in the map
  core::TimeNs lost_since_ns_ = 0;  // first lost frame
  std::optional<core::TimeNs> relocalization_failing_since_ns_;  // first failed try on a frame with features
  // The last tracked frame, its pose held relative to its reference keyframe so that it follows
  // local BA corrections (ORB-SLAM's UpdateLastFrame).
  std::optional<Frame> last_frame_;
  std::vector<std::optional<Eigen::Vector3d>> last_depth_points_;  // camera frame, for free features
  KeyframeId last_reference_ = -1;
  Eigen::Isometry3d T_ref_last_ = Eigen::Isometry3d::Identity();
  std::optional<Eigen::Isometry3d> last_T_world_cam_;  // the last estimate (also after loss)
  // Constant-velocity model: T_cur_last of the last two tracked frames and their time difference.
  std::optional<Eigen::Isometry3d> velocity_;
  core::TimeNs velocity_dt_ns_ = 0;
  // Gyroscope: the rotation since the last tracked frame, bias removed (R_last_cur, camera frame), while
  // every frame since brought one; the steps it holds; the current frame's raw step; the bias estimate.
  std::optional<Eigen::Matrix3d> gyro_R_last_cur_;
  int gyro_steps_ = 0;
  std::optional<Eigen::Matrix3d> gyro_raw_step_;
  std::optional<core::TimeNs> previous_input_t_ns_;
  Eigen::Vector3d gyro_bias_cam_ = Eigen::Vector3d::Zero();
  KeyframeId reference_keyframe_ = -1;
  core::TimeNs last_keyframe_t_ns_ = 0;
  int frames_since_keyframe_ = 0;
  int frames_since_relocalization_ = -1;  // tracked frames since the last relocalisation; -1: none
};

}  // namespace fleetslam::slam
