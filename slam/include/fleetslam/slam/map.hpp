#pragma once
// The map of one agent, owned by value: keyframes (a copy of the frame's features with the map point
// of each feature), map points (position, representative descriptor, observations, viewing normal and
// scale-invariance distance range, tracking counters), the covisibility graph (weight = map points two
// keyframes share) and the spanning tree (each keyframe's parent is its strongest covisible keyframe at
// insertion). Ids come from counters inside the map, so two agents in one process share nothing.
//
// Invariant kept by every mutating call: feature i of keyframe k holds map point p if and only if
// p's observations hold (k -> i). Culled keyframes leave a (parent, T_parent_kf) record so that poses
// expressed relative to them (the frame trajectory) keep following their parent after corrections.
// Not thread-safe: the agent serialises access (one mutex in threaded mode).

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <unordered_map>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "fleetslam/core/time.hpp"
#include "fleetslam/slam/frame.hpp"
#include "fleetslam/slam/vocabulary.hpp"

namespace fleetslam::slam {

using Descriptor = std::array<std::uint8_t, 32>;
class Map;

// Row `row` of an N x 32 CV_8UC1 descriptor matrix.
Descriptor descriptor_row(const cv::Mat& descriptors, int row);

struct MapPoint {
  MapPointId id = kNoMapPoint;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // world frame
  Descriptor descriptor{};                             // the observation closest to all others (median)
  std::map<KeyframeId, int> observations;              // keyframe -> feature index (ordered: deterministic)
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();   // mean viewing direction (point - camera), unit
  double min_distance_m = 0.0;                         // range in which ORB's scale pyramid can see it
  double max_distance_m = 0.0;
  KeyframeId reference_keyframe = -1;                  // the keyframe that created it (its distance range)
  KeyframeId first_keyframe = -1;
  int visible = 1;  // frames whose frustum contained it
  int found = 1;    // frames that matched it as an inlier

  double found_ratio() const { return visible > 0 ? static_cast<double>(found) / visible : 0.0; }
  // Pyramid level at which a camera at distance_m should see it (ORB-SLAM's PredictScale).
  int predict_level(double distance_m, const ScalePyramid& pyramid) const;
};

struct Keyframe {
  KeyframeId id = -1;
  core::TimeNs t_ns = 0;
  int component = 0;  // map generation: a re-initialisation after tracking loss starts a new one
  bool root = false;  // first keyframe of its component: fixed gauge, never culled, no parent
  bool connected = false;  // update_connections found an older neighbour once (the parent is chosen then)
  Eigen::Isometry3d T_world_cam = Eigen::Isometry3d::Identity();
  Frame frame;        // features; frame.map_points holds the map point of each feature
  BowVector bow;               // bag of words of frame.descriptors (empty without a vocabulary)
  FeatureVector bow_features;  // its direct index (features grouped by vocabulary node)

  std::map<KeyframeId, int> connections;               // covisibility weights (shared map points)
  std::vector<std::pair<KeyframeId, int>> neighbours;  // the same, strongest first (ties: older first)
  KeyframeId parent = -1;                              // spanning tree (-1 for a component's root)
  std::set<KeyframeId> children;
  // Keyframes a loop closure joined this one to (both ways): every later essential graph keeps the loop's
  // constraint, and neither keyframe is culled (ORB-SLAM's loop edges).
  std::set<KeyframeId> loop_edges;

  Eigen::Isometry3d T_cam_world() const { return T_world_cam.inverse(); }
  Eigen::Vector3d center() const { return T_world_cam.translation(); }
  // Up to n strongest neighbours (all for n < 0).
  std::vector<KeyframeId> best_covisible(int n) const;
  // Neighbours with at least min_weight shared points.
  std::vector<KeyframeId> covisible_with_weight(int min_weight) const;
  // Map points held by features (not necessarily distinct ids); min_observations filters on points.
  int tracked_points(int min_observations, const Map& map) const;
  // Median depth of its map points in its own camera (1 when it has none).
  double median_depth(const Map& map) const;
};

// What a culled keyframe leaves behind so that poses relative to it stay valid.
struct CulledKeyframe {
  KeyframeId parent = -1;
  Eigen::Isometry3d T_parent_kf = Eigen::Isometry3d::Identity();
};

class Map {
 public:
  // Copies the frame's features; its associations are cleared (add_observation sets them). The first
  // keyframe of a component is its root.
  KeyframeId add_keyframe(const Frame& frame, const Eigen::Isometry3d& T_world_cam, int component);
  // A new point observed by feature `feature` of keyframe `kf` (statistics computed from it).
  MapPointId add_map_point(const Eigen::Vector3d& position_world, KeyframeId kf, int feature);

  // Links point and feature both ways. The feature must be free and the point not yet seen by kf.
  void add_observation(MapPointId point, KeyframeId kf, int feature);
  // Unlinks them; a point left without observations is erased.
  void erase_observation(MapPointId point, KeyframeId kf);
  // Removes a point and every link to it.
  void erase_map_point(MapPointId point);
  // Moves every observation of `old_point` onto `by` (where kf does not see `by` already), adds the
  // counters, erases `old_point` and remembers the replacement for resolve().
  void replace_map_point(MapPointId old_point, MapPointId by);
  // Culls a keyframe: unlinks its points, re-parents its children, updates its neighbours' weights.
  // A component's root (no parent) and a keyframe with loop edges are never culled; returns false then.
  bool erase_keyframe(KeyframeId kf);
  // Records a loop closure between two keyframes (Keyframe::loop_edges, both ways); false when either is
  // unknown or they are the same.
  bool add_loop_edge(KeyframeId a, KeyframeId b);

  // Recomputes kf's covisibility weights from its points and mirrors them into the neighbours; sets
  // the parent (the strongest older neighbour) the first time there is one. Links below min_weight are kept only for the
  // strongest neighbour (ORB-SLAM's rule, so that no keyframe ends up unconnected).
  void update_connections(KeyframeId kf, int min_weight = 15);
  // Representative descriptor, normal and distance range from the current observations.
  void update_point_statistics(MapPointId point);

  const Keyframe* keyframe(KeyframeId id) const;
  Keyframe* keyframe(KeyframeId id);
  const MapPoint* point(MapPointId id) const;
  MapPoint* point(MapPointId id);
  // ORB-SLAM's observation count of a point: an observation by a feature with depth (a stereo
  // observation) counts 2, one without counts 1.
  int weighted_observations(const MapPoint& p) const;
  // The live point that `id` became (itself, its replacement chain), or kNoMapPoint when it is gone.
  MapPointId resolve(MapPointId id) const;
  // World pose of a keyframe, following culled keyframes' parents; nullopt for unknown ids.
  std::optional<Eigen::Isometry3d> keyframe_pose(KeyframeId id) const;
  // The live keyframe a (possibly culled) keyframe hands its relative poses to, with T_live_kf.
  std::optional<std::pair<KeyframeId, Eigen::Isometry3d>> live_keyframe(KeyframeId id) const;

  const std::map<KeyframeId, Keyframe>& keyframes() const { return keyframes_; }
  std::size_t keyframe_count() const { return keyframes_.size(); }
  std::size_t point_count() const { return points_.size(); }
  // Point ids in ascending order (deterministic iteration for outputs and tests).
  std::vector<MapPointId> point_ids() const;
  bool is_culled(KeyframeId id) const { return culled_.count(id) > 0; }

 private:
  friend struct MapAccess;  // map_io.cpp: saves and restores every member, compares maps

  void unlink_feature(KeyframeId kf, int feature);
  void set_neighbours(Keyframe& keyframe);
  void adopt_children(Keyframe& culled);

  KeyframeId next_keyframe_id_ = 0;
  MapPointId next_point_id_ = 0;
  std::map<KeyframeId, Keyframe> keyframes_;
  std::unordered_map<MapPointId, MapPoint> points_;
  std::unordered_map<MapPointId, MapPointId> replaced_by_;
  std::unordered_map<KeyframeId, CulledKeyframe> culled_;
  std::set<int> components_;
};

}  // namespace fleetslam::slam
