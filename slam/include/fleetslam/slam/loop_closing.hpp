#pragma once
// Loop closing for RGB-D and stereo agents (ORB-SLAM's design, written here; poses are SE(3): depth
// fixes the scale).
//   detect   the keyframe's BoW vector against the keyframe database: candidates score at least the
//            lowest score among its covisible neighbours, are not connected to it, belong to its map
//            component, and their covisibility groups stay consistent over `consistency` consecutive
//            keyframes (ORB-SLAM's consistent groups);
//   verify   BoW matches between map points of the candidate and of the keyframe, RANSAC over the 3D-3D
//            pairs (Umeyama/Horn on 3 pairs, inliers by reprojection in both keyframes), then the
//            candidate's neighbourhood points projected into the keyframe at the corrected pose and the
//            pose refined on them (pose-only optimisation);
//   guard    two checks against false loops (repeated textures in different rooms look alike to BoW and
//            even to a 3D-3D RANSAC over a flat poster): the correction must be a drift the agent could
//            have accumulated over the path it travelled since the loop keyframe (a bound that grows with
//            that path), and the correction must hold for the keyframe's covisible neighbours too (loop
//            points projected into each at its corrected pose, pose refined, inliers counted), as
//            ORB-SLAM3 confirms a place in the covisible keyframes before it closes a loop;
//   correct  the keyframe and its covisible neighbours move rigidly to the corrected pose with their
//            points; the loop points are fused into them (duplicates replaced); new covisibility links
//            across the loop are the loop edges;
//   essential graph  a Ceres pose graph over the component: spanning tree, strong covisibility and loop
//            edges, the component's root fixed; every point follows its reference keyframe;
//   global BA  all keyframes and points of the component (prepare / solve / apply, so that the agent's
//            threaded mode solves without holding the map lock).
// Deterministic: RANSAC draws from a generator seeded with (seed, keyframe id).

#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/core/time.hpp"
#include "fleetslam/slam/keyframe_database.hpp"
#include "fleetslam/slam/local_mapping.hpp"
#include "fleetslam/slam/map.hpp"
#include "fleetslam/slam/map_projection.hpp"
#include "fleetslam/slam/matcher.hpp"
#include "fleetslam/slam/optimizer.hpp"

namespace fleetslam::slam {

struct LoopClosingConfig {
  bool enabled = true;
  int min_keyframes = 10;          // keyframes in the component before detection starts
  int keyframes_after_loop = 10;   // keyframes after a closed loop before the next detection
  int consistency = 3;             // consecutive keyframes whose candidate groups overlap
  int group_neighbours = 10;       // a candidate's covisibility group: itself and this many neighbours
  double group_score_ratio = 0.75; // groups scoring below this share of the best are dropped
  int min_bow_matches = 20;        // BoW matches between candidate and keyframe points
  int ransac_iterations = 300;
  double ransac_chi2 = 9.21;       // reprojection chi2 (2 dof, 99 %) in both keyframes
  int min_ransac_inliers = 20;
  int min_loop_inliers = 40;       // inliers of the refined pose against the candidate's neighbourhood
  // Drift bound: a correction of more than floor + per-metre * (path travelled since the loop keyframe)
  // is refused as implausible (< 0 turns a bound off).
  double max_correction_floor_m = 0.1;
  double max_correction_per_m = 0.1;      // translation drift per metre travelled
  double max_correction_floor_deg = 5.0;
  double max_correction_deg_per_m = 2.0;  // rotation drift per metre travelled
  // Confirmation: of the keyframe's best `confirm_neighbours` covisible keyframes, at least
  // min(confirmations, their number) must find min_confirm_inliers loop points at their corrected pose.
  int confirm_neighbours = 3;
  int confirmations = 2;            // 0 turns the check off
  int min_confirm_inliers = 30;
  int strong_covisibility = 100;   // shared points for a covisibility edge of the essential graph
  int pose_graph_iterations = 20;
  bool global_ba = true;
  int global_ba_iterations = 20;    // per pass of bundle_adjust (robust, then plain)
  std::int64_t seed = 0;
  BowMatchConfig matching;
  ProjectionSearchConfig search;   // guided matching and fusion
  // Not read from this section: the agent sets them from its own (tracking's `optimizer`, mapping's `ba`
  // and covisibility_min_weight), so that loops verify poses, adjust the map (chi-square thresholds,
  // threads; global_ba_iterations replaces its count) and link keyframes as the rest
  // of the agent does.
  OptimizerConfig pose_optimizer;
  OptimizerConfig bundle_adjustment;
  int covisibility_min_weight = 15;

  template <class V>
  void visit(V& v) {
    v("enabled", enabled);
    v("min_keyframes", min_keyframes, core::Limits<int>{1, 100000});
    v("keyframes_after_loop", keyframes_after_loop, core::Limits<int>{0, 100000});
    v("consistency", consistency, core::Limits<int>{1, 100});
    v("group_neighbours", group_neighbours, core::Limits<int>{0, 1000});
    v("group_score_ratio", group_score_ratio, core::Limits<double>{0.0, 1.0});
    v("min_bow_matches", min_bow_matches, core::Limits<int>{3, 100000});
    v("ransac_iterations", ransac_iterations, core::Limits<int>{1, 100000});
    v("ransac_chi2", ransac_chi2, core::Limits<double>{0.1, 1000.0});
    v("min_ransac_inliers", min_ransac_inliers, core::Limits<int>{3, 100000});
    v("min_loop_inliers", min_loop_inliers, core::Limits<int>{3, 100000});
    v("max_correction_floor_m", max_correction_floor_m);
    v("max_correction_per_m", max_correction_per_m);
    v("max_correction_floor_deg", max_correction_floor_deg);
    v("max_correction_deg_per_m", max_correction_deg_per_m);
    v("confirm_neighbours", confirm_neighbours, core::Limits<int>{0, 100});
    v("confirmations", confirmations, core::Limits<int>{0, 100});
    v("min_confirm_inliers", min_confirm_inliers, core::Limits<int>{3, 100000});
    v("strong_covisibility", strong_covisibility, core::Limits<int>{1, 100000});
    v("pose_graph_iterations", pose_graph_iterations, core::Limits<int>{1, 1000});
    v("global_ba", global_ba);
    v("global_ba_iterations", global_ba_iterations, core::Limits<int>{1, 1000});
    v("seed", seed, core::Limits<std::int64_t>{0});
    v("matching", matching);
    v("search", search);
  }
};

// A closed loop, as the agent reports it.
struct LoopEvent {
  KeyframeId current = -1;    // the keyframe that closed the loop
  KeyframeId loop = -1;       // the old keyframe it was matched with
  core::TimeNs t_ns = 0;      // of the current keyframe
  double score = 0.0;         // BoW score of the pair
  // The current keyframe's correction in the world frame: T_world_cam(after) = correction * T_world_cam(before).
  Eigen::Isometry3d correction = Eigen::Isometry3d::Identity();
  int bow_matches = 0;
  int ransac_inliers = 0;
  int inliers = 0;            // of the refined pose
  int fused_points = 0;
  int moved_keyframes = 0;    // by the correction and the essential graph
  bool global_ba = false;     // a global BA followed (ok)
  double path_m = 0.0;        // travelled between the loop keyframe and the current one
  double camera_shift_m = 0.0;  // how far the correction moves the current keyframe's camera centre
  int confirmations = 0;      // covisible neighbours that confirmed the correction
};

// Why verified loop candidates were refused (counts over the agent's run).
struct LoopRejections {
  int implausible_correction = 0;  // beyond the drift bound
  int unconfirmed = 0;             // too few neighbours confirmed it
};

// A global BA over one component, with the map ids behind its indices.
struct GlobalBaProblem {
  core::PinholeCamera camera;
  double bf = 0.0;
  BaProblem problem;
  std::vector<KeyframeId> keyframe_ids;
  std::vector<MapPointId> point_ids;
  std::vector<std::pair<KeyframeId, int>> observation_of;
};

class LoopCloser {
 public:
  LoopCloser(const LoopClosingConfig& config, core::Logger logger);

  // Detects, verifies and corrects a loop at keyframe `current` (its BoW set; not yet in `database`:
  // the caller adds it afterwards). Keyframes it moved are added to `moved`. Returns the loop when one
  // was closed; the global BA is left to the caller (prepare / solve / apply below).
  std::optional<LoopEvent> detect_and_correct(KeyframeId current, Map& map, const KeyframeDatabase& database,
                                              std::set<KeyframeId>& moved);

  std::optional<GlobalBaProblem> prepare_global_ba(int component, const Map& map) const;
  BaResult solve_global_ba(const GlobalBaProblem& problem) const;
  // Writes back what still exists; moved keyframes are added to `moved`. Keyframes of the component
  // that the problem did not hold (threaded mode: inserted during the solve) move with the correction of
  // their best covisible solved keyframe (else the newest solved one before them), and points the
  // problem did not hold with their anchor keyframe's. Returns result.ok (nothing changes otherwise).
  bool apply_global_ba(const GlobalBaProblem& problem, const BaResult& result, Map& map,
                       std::set<KeyframeId>& moved) const;

  const LoopClosingConfig& config() const { return config_; }
  const LoopRejections& rejections() const { return rejections_; }

  // A loop that passed verification (public for tests, as is the step below).
  struct Verified {
    KeyframeId loop = -1;
    double score = 0.0;
    Eigen::Isometry3d T_world_cam = Eigen::Isometry3d::Identity();  // the current keyframe, corrected
    int bow_matches = 0;
    int ransac_inliers = 0;
    int inliers = 0;
    std::vector<MapPointId> loop_points;  // the candidate's neighbourhood points
  };
  // How many of `neighbours` find min_confirm_inliers loop points where the correction puts them: moved
  // with the current keyframe, except the component's root, which the correction leaves where it is.
  int confirmations(const Keyframe& current, const std::vector<KeyframeId>& neighbours, const Verified& loop,
                    const Map& map) const;

 private:
  struct Candidate {
    KeyframeId id = -1;
    double score = 0.0;
  };
  struct Group {
    std::set<KeyframeId> keyframes;
    int consistency = 0;
  };
  struct Plausibility {
    bool ok = true;
    double path_m = 0.0;
    double translation_m = 0.0;
    double rotation_deg = 0.0;
    double bound_m = 0.0;
    double bound_deg = 0.0;
  };

  std::vector<Candidate> detect(const Keyframe& current, const Map& map, const KeyframeDatabase& database);
  std::optional<Verified> verify(const Keyframe& current, const Candidate& candidate, const Map& map);
  // The drift bound for moving `current` to T_world_cam_corrected by a loop with keyframe `loop`.
  Plausibility plausible(const Keyframe& current, const Eigen::Isometry3d& T_world_cam_corrected, KeyframeId loop,
                         const Map& map) const;
  void refuse_implausible(KeyframeId current, const Verified& loop, const Plausibility& plausibility);
  void correct(KeyframeId current, const Verified& loop, Map& map, LoopEvent& event, std::set<KeyframeId>& moved) const;

  LoopClosingConfig config_;
  core::Logger logger_;
  std::vector<Group> groups_;   // consistent groups of the previous keyframe
  KeyframeId last_loop_ = -1;   // keyframe of the last closed loop
  LoopRejections rejections_;
};

// The essential graph: a Ceres pose graph over `T_world_cam` (by keyframe id), the edges' relative
// measurements T_i_j given per pair (i, j), `fixed` held constant. Returns false when the solve fails.
struct PoseGraphEdge {
  KeyframeId i = -1;
  KeyframeId j = -1;
  Eigen::Isometry3d T_i_j = Eigen::Isometry3d::Identity();
};
bool optimize_pose_graph(std::map<KeyframeId, Eigen::Isometry3d>& T_world_cam, const std::vector<PoseGraphEdge>& edges,
                         const std::set<KeyframeId>& fixed, int iterations);

// The essential graph of a loop correction over the keyframes of `before` (their poses before it;
// `corrected`: after the loop group moved rigidly), each pair of keyframes at most once: spanning-tree
// edges (parent, child), earlier loops' edges (Keyframe::loop_edges) and covisibility links of weight >=
// strong_covisibility at their uncorrected relative poses, and loop links (links of a `group` keyframe that it did not have in `old_connections`)
// at their corrected ones: those of weight >= strong_covisibility, and `loop_pair` (the current and the
// loop keyframe) whatever its weight (a link of a few fused points would weigh as much as a strong one),
// and even without a link: ORB-SLAM adds that edge only when the fusion linked the two, and a verified loop
// whose inliers lie on the loop keyframe's neighbours then has no edge that holds the correction. A tree
// edge that is also a strong link counts once, as in ORB-SLAM.
std::vector<PoseGraphEdge> essential_graph_edges(const Map& map, const std::map<KeyframeId, Eigen::Isometry3d>& before,
                                                 const std::map<KeyframeId, Eigen::Isometry3d>& corrected,
                                                 const std::set<KeyframeId>& group,
                                                 const std::map<KeyframeId, std::set<KeyframeId>>& old_connections,
                                                 int strong_covisibility,
                                                 std::pair<KeyframeId, KeyframeId> loop_pair = {-1, -1});

}  // namespace fleetslam::slam
