#pragma once
// Local mapping (ORB-SLAM's design, written here), as step functions on the map so that the agent can
// run them inline after each keyframe (deterministic mode) or on a worker thread (threaded mode):
//   insert_keyframe   the tracked frame enters the map: observations of its tracked points, new points
//                     from its close depth features not yet matched, covisibility links and parent;
//   cull_recent_points  recently created points that tracking rarely finds, or that too few keyframes
//                     observe after a few keyframes, are removed;
//   triangulate       features without a point matched with covisible keyframes along the epipolar line
//                     (brute force over their free features: no bag of words yet) become points;
//   fuse              the keyframe's points projected into its neighbours and theirs into it: duplicates
//                     merge, missing observations are added;
//   local BA          current keyframe + covisible neighbours optimised with their points; keyframes
//                     outside that set observing those points are held fixed; outlier observations go;
//   cull_keyframes    a neighbour whose (close) points are 90 % seen by >= 3 other keyframes at the same or
//                     a finer scale is redundant and removed (never one newer than the current keyframe:
//                     in threaded mode it still waits for its own pass).
// Local BA splits into prepare (reads the map) / solve (no map) / apply (writes the map, skipping what
// changed meanwhile), so the threaded mode can solve without holding the map lock.

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/slam/frame.hpp"
#include "fleetslam/slam/map.hpp"
#include "fleetslam/slam/optimizer.hpp"

namespace fleetslam::slam {

struct LocalMappingConfig {
  int min_new_depth_points = 100;     // new depth points per keyframe: all close ones, at least this many
  int covisibility_min_weight = 15;   // shared points for a covisibility link
  double cull_found_ratio = 0.25;     // recent points found in fewer of the frames that saw them: culled
  int cull_min_observations = 3;      // weighted (a depth observation counts 2), checked 2 keyframes later
  bool triangulate = true;
  int triangulation_neighbours = 10;
  int triangulation_max_distance = 50;  // TH_LOW
  double triangulation_nn_ratio = 0.8;
  double min_parallax_cos = 0.9998;     // rays closer than ~1.1 degree give no depth
  bool fuse = true;
  int fuse_neighbours = 10;             // first ring; each adds its 5 best (second ring)
  double fuse_radius_factor = 3.0;
  int fuse_max_distance = 50;           // TH_LOW
  bool local_ba = true;
  int max_ba_keyframes = 30;            // current + strongest covisible neighbours
  OptimizerConfig ba = default_ba();
  bool cull_keyframes = true;
  double redundant_ratio = 0.9;
  int redundant_observers = 3;

  static OptimizerConfig default_ba();

  template <class V>
  void visit(V& v) {
    v("min_new_depth_points", min_new_depth_points, core::Limits<int>{0, 100000});
    v("covisibility_min_weight", covisibility_min_weight, core::Limits<int>{1, 100000});
    v("cull_found_ratio", cull_found_ratio, core::Limits<double>{0.0, 1.0});
    v("cull_min_observations", cull_min_observations, core::Limits<int>{0, 1000});
    v("triangulate", triangulate);
    v("triangulation_neighbours", triangulation_neighbours, core::Limits<int>{0, 1000});
    v("triangulation_max_distance", triangulation_max_distance, core::Limits<int>{0, 256});
    v("triangulation_nn_ratio", triangulation_nn_ratio, core::Limits<double>{0.1, 1.0});
    v("min_parallax_cos", min_parallax_cos, core::Limits<double>{0.0, 1.0});
    v("fuse", fuse);
    v("fuse_neighbours", fuse_neighbours, core::Limits<int>{0, 1000});
    v("fuse_radius_factor", fuse_radius_factor, core::Limits<double>{0.1, 100.0});
    v("fuse_max_distance", fuse_max_distance, core::Limits<int>{0, 256});
    v("local_ba", local_ba);
    v("max_ba_keyframes", max_ba_keyframes, core::Limits<int>{2, 10000});
    v("ba", ba);
    v("cull_keyframes", cull_keyframes);
    v("redundant_ratio", redundant_ratio, core::Limits<double>{0.0, 1.0});
    v("redundant_observers", redundant_observers, core::Limits<int>{1, 1000});
  }
};

// A local BA problem with the map ids behind its indices.
struct LocalBaProblem {
  KeyframeId keyframe = -1;  // the keyframe it was built for
  core::PinholeCamera camera;
  double bf = 0.0;
  BaProblem problem;
  std::vector<KeyframeId> keyframe_ids;                    // per problem keyframe
  std::vector<MapPointId> point_ids;                       // per problem point
  std::vector<std::pair<KeyframeId, int>> observation_of;  // per problem observation: keyframe, feature
};

struct LocalBaOutcome {
  std::vector<KeyframeId> adjusted;  // keyframes whose pose was written back
  int removed_observations = 0;
  double initial_rms_px = 0.0;
  double final_rms_px = 0.0;
  bool ok = false;
};

// What one keyframe's mapping did (for logs and the agent's update).
struct MappingReport {
  KeyframeId keyframe = -1;
  int new_depth_points = 0;
  int culled_points = 0;
  int triangulated = 0;
  int fused = 0;
  LocalBaOutcome ba;
  std::vector<KeyframeId> culled_keyframes;
  double ms = 0.0;
};

class LocalMapper {
 public:
  LocalMapper(const LocalMappingConfig& config, core::Logger logger);

  // The tracked frame (pose set, outliers removed) becomes a keyframe of `component`. `initial`: the
  // first keyframe of a component, which takes a point for every feature with depth.
  KeyframeId insert_keyframe(const Frame& frame, int component, bool initial, Map& map, MappingReport* report);
  int cull_recent_points(KeyframeId current, Map& map);
  int triangulate(KeyframeId current, Map& map);
  int fuse(KeyframeId current, Map& map);
  // The step after triangulation, for the inline and the threaded path alike: fuse (when configured; it
  // ends by updating the keyframe's covisibility), or else the covisibility update the new points need.
  void fuse_or_link(KeyframeId current, Map& map, MappingReport& report);
  std::optional<LocalBaProblem> prepare_local_ba(KeyframeId current, const Map& map) const;
  BaResult solve_local_ba(const LocalBaProblem& problem) const;
  LocalBaOutcome apply_local_ba(const LocalBaProblem& problem, const BaResult& result, Map& map) const;
  std::vector<KeyframeId> cull_keyframes(KeyframeId current, Map& map) const;

  // Everything after insertion, in order, on the calling thread (deterministic mode).
  void process(KeyframeId current, Map& map, MappingReport& report);

  const LocalMappingConfig& config() const { return config_; }

 private:
  LocalMappingConfig config_;
  core::Logger logger_;
  std::vector<MapPointId> recent_points_;  // created by the last few keyframes, still on probation
};

}  // namespace fleetslam::slam
