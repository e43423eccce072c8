// The map's bookkeeping: two-way links between points and features, covisibility weights and their
// order, the spanning tree through keyframe culling, point replacement, point statistics, and local
// mapping's culling of recent points and redundant keyframes.

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>
#include <vector>

#include "fleetslam/core/log.hpp"
#include "fleetslam/slam/local_mapping.hpp"
#include "fleetslam/slam/loop_closing.hpp"
#include "fleetslam/slam/map.hpp"
#include "fleetslam/slam/map_projection.hpp"
#include "map_test_util.hpp"

namespace fleetslam::slam {
namespace {

using test::make_frame;

Eigen::Isometry3d at_x(double x) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation().x() = x;
  return T;
}

// Every link is two-way: feature -> point implies point -> (keyframe, feature) and back.
void expect_consistent(const Map& map) {
  for (const auto& [kf_id, kf] : map.keyframes()) {
    for (std::size_t i = 0; i < kf.frame.size(); ++i) {
      const MapPointId id = kf.frame.map_points[i];
      if (id == kNoMapPoint) continue;
      const MapPoint* p = map.point(id);
      ASSERT_NE(p, nullptr) << "keyframe " << kf_id << " feature " << i;
      ASSERT_EQ(p->observations.count(kf_id), 1u);
      EXPECT_EQ(p->observations.at(kf_id), static_cast<int>(i));
    }
  }
  for (MapPointId id : map.point_ids()) {
    const MapPoint& p = *map.point(id);
    EXPECT_FALSE(p.observations.empty());
    for (const auto& [kf_id, feature] : p.observations) {
      const Keyframe* kf = map.keyframe(kf_id);
      ASSERT_NE(kf, nullptr);
      EXPECT_EQ(kf->frame.map_points[static_cast<std::size_t>(feature)], id);
    }
  }
}

// n points seen by feature i of every keyframe in `keyframes` (the first creates them).
std::vector<MapPointId> shared_points(Map& map, const std::vector<KeyframeId>& keyframes, int first_feature, int n) {
  std::vector<MapPointId> ids;
  for (int i = first_feature; i < first_feature + n; ++i) {
    const MapPointId id = map.add_map_point(Eigen::Vector3d(0.01 * i, 0.0, 2.0), keyframes.front(), i);
    for (std::size_t k = 1; k < keyframes.size(); ++k) map.add_observation(id, keyframes[k], i);
    ids.push_back(id);
  }
  return ids;
}

TEST(Map, CovisibilityWeightsOrderAndParent) {
  Map map;
  const KeyframeId a = map.add_keyframe(make_frame(100, 1), at_x(0.0), 0);
  const KeyframeId b = map.add_keyframe(make_frame(100, 2), at_x(0.1), 0);
  const KeyframeId c = map.add_keyframe(make_frame(100, 3), at_x(0.2), 0);
  const KeyframeId d = map.add_keyframe(make_frame(100, 4), at_x(0.3), 0);
  shared_points(map, {a, d}, 0, 40);     // a-d: 40
  shared_points(map, {b, d}, 40, 20);    // b-d: 20
  shared_points(map, {c, d}, 60, 5);     // c-d: 5 (below the threshold of 15)
  shared_points(map, {a, b, d}, 65, 10); // a-b-d: +10 to a-d, b-d and a-b
  for (KeyframeId id : {a, b, c}) map.update_connections(id);
  map.update_connections(d);
  expect_consistent(map);

  const Keyframe& kd = *map.keyframe(d);
  ASSERT_EQ(kd.neighbours.size(), 2u);  // c (5) is below 15 and not the strongest
  EXPECT_EQ(kd.neighbours[0], std::make_pair(a, 50));
  EXPECT_EQ(kd.neighbours[1], std::make_pair(b, 30));
  EXPECT_EQ(map.keyframe(a)->connections.at(d), 50);  // mirrored
  EXPECT_EQ(map.keyframe(b)->connections.at(d), 30);
  EXPECT_EQ(kd.best_covisible(1), std::vector<KeyframeId>{a});
  EXPECT_EQ(kd.covisible_with_weight(40), std::vector<KeyframeId>{a});
  EXPECT_EQ(kd.parent, a);  // the strongest neighbour at the first connection
  EXPECT_TRUE(map.keyframe(a)->children.count(d));
  EXPECT_TRUE(map.keyframe(a)->root);
  EXPECT_EQ(map.keyframe(a)->parent, -1);

  // A keyframe whose only links are weak keeps the strongest one.
  const Keyframe& kc = *map.keyframe(c);
  ASSERT_EQ(kc.neighbours.size(), 0u);  // c's connections were computed before d shared points
  map.update_connections(c);
  ASSERT_EQ(map.keyframe(c)->neighbours.size(), 1u);
  EXPECT_EQ(map.keyframe(c)->neighbours[0], std::make_pair(d, 5));
}

TEST(Map, TiesAreOrderedByIdAndWeightsFollowErasure) {
  Map map;
  const KeyframeId a = map.add_keyframe(make_frame(100, 1), at_x(0.0), 0);
  const KeyframeId b = map.add_keyframe(make_frame(100, 2), at_x(0.1), 0);
  const KeyframeId c = map.add_keyframe(make_frame(100, 3), at_x(0.2), 0);
  shared_points(map, {b, a}, 0, 20);
  const std::vector<MapPointId> ac = shared_points(map, {c, a}, 20, 20);
  map.update_connections(a);
  ASSERT_EQ(map.keyframe(a)->neighbours.size(), 2u);
  EXPECT_EQ(map.keyframe(a)->neighbours[0].first, b);  // equal weights: the older keyframe first
  for (int i = 0; i < 10; ++i) map.erase_observation(ac[static_cast<std::size_t>(i)], c);
  map.update_connections(a);
  EXPECT_EQ(map.keyframe(a)->connections.count(c), 0u);  // 10 < 15 and not the strongest
  EXPECT_EQ(map.keyframe(c)->connections.count(a), 0u);  // the mirror went too
  expect_consistent(map);
}

TEST(Map, ErasingObservationsAndPointsKeepsLinksConsistent) {
  Map map;
  const KeyframeId a = map.add_keyframe(make_frame(50, 1), at_x(0.0), 0);
  const KeyframeId b = map.add_keyframe(make_frame(50, 2), at_x(0.1), 0);
  const std::vector<MapPointId> ids = shared_points(map, {a, b}, 0, 10);
  map.erase_observation(ids[0], a);
  EXPECT_EQ(map.keyframe(a)->frame.map_points[0], kNoMapPoint);
  ASSERT_NE(map.point(ids[0]), nullptr);
  EXPECT_EQ(map.point(ids[0])->reference_keyframe, b);  // the reference moves to a remaining observer
  map.erase_observation(ids[0], b);
  EXPECT_EQ(map.point(ids[0]), nullptr);  // no observation left: gone
  map.erase_map_point(ids[1]);
  EXPECT_EQ(map.keyframe(a)->frame.map_points[1], kNoMapPoint);
  EXPECT_EQ(map.keyframe(b)->frame.map_points[1], kNoMapPoint);
  EXPECT_EQ(map.point_count(), 8u);
  expect_consistent(map);
}

TEST(Map, ReplacementMergesObservationsAndResolves) {
  Map map;
  const KeyframeId a = map.add_keyframe(make_frame(50, 1), at_x(0.0), 0);
  const KeyframeId b = map.add_keyframe(make_frame(50, 2), at_x(0.1), 0);
  const KeyframeId c = map.add_keyframe(make_frame(50, 3), at_x(0.2), 0);
  const MapPointId p = map.add_map_point(Eigen::Vector3d(0, 0, 2), a, 0);
  map.add_observation(p, b, 0);
  const MapPointId q = map.add_map_point(Eigen::Vector3d(0, 0, 2), b, 1);  // b sees both (duplicate)
  map.add_observation(q, c, 1);
  map.point(p)->visible = 5, map.point(p)->found = 4;
  map.point(q)->visible = 3, map.point(q)->found = 1;
  map.replace_map_point(q, p);
  EXPECT_EQ(map.point(q), nullptr);
  EXPECT_EQ(map.resolve(q), p);
  EXPECT_EQ(map.resolve(p), p);
  const MapPoint& merged = *map.point(p);
  EXPECT_EQ(merged.observations.size(), 3u);             // a, b (kept its own feature), c
  EXPECT_EQ(merged.observations.at(b), 0);
  EXPECT_EQ(map.keyframe(b)->frame.map_points[1], kNoMapPoint);  // b's duplicate feature is freed
  EXPECT_EQ(map.keyframe(c)->frame.map_points[1], p);
  EXPECT_EQ(merged.visible, 8);
  EXPECT_EQ(merged.found, 5);
  expect_consistent(map);
  map.erase_map_point(p);
  EXPECT_EQ(map.resolve(q), kNoMapPoint);
}

TEST(Map, PointStatisticsDescriptorNormalAndDistanceRange) {
  Map map;
  // Descriptors with 0, 4, 8 and 256 bits set: the one with the least median distance to the others
  // is the 4-bit one (medians 8, 4, 8, 252).
  std::vector<Frame> frames{make_frame(10, 1), make_frame(10, 2), make_frame(10, 3), make_frame(10, 4)};
  frames[0].descriptors.row(0).setTo(0);
  frames[1].descriptors.row(0).setTo(0);
  frames[1].descriptors.at<std::uint8_t>(0, 0) = 0x0F;
  frames[2].descriptors.row(0).setTo(0);
  frames[2].descriptors.at<std::uint8_t>(0, 0) = 0xFF;
  frames[3].descriptors.row(0).setTo(255);
  frames[0].level[0] = 2;
  const double xs[4] = {-1.0, 1.0, -0.5, 0.5};
  std::vector<KeyframeId> ids;
  for (std::size_t k = 0; k < frames.size(); ++k) ids.push_back(map.add_keyframe(frames[k], at_x(xs[k]), 0));
  const MapPointId p = map.add_map_point(Eigen::Vector3d(0, 0, 2), ids[0], 0);
  for (std::size_t k = 1; k < ids.size(); ++k) map.add_observation(p, ids[k], 0);
  map.update_point_statistics(p);
  const MapPoint& mp = *map.point(p);
  EXPECT_EQ(mp.descriptor, descriptor_row(map.keyframe(ids[1])->frame.descriptors, 0));
  EXPECT_NEAR(mp.normal.x(), 0.0, 1e-12);  // symmetric views average to +z
  EXPECT_NEAR(mp.normal.z(), 1.0, 1e-12);
  const double distance = std::sqrt(5.0);  // from the reference keyframe (the first) at x = -1
  const ScalePyramid pyramid = ScalePyramid::make(8, 1.2);
  EXPECT_NEAR(mp.max_distance_m, distance * pyramid.scale[2], 1e-12);
  EXPECT_NEAR(mp.min_distance_m, mp.max_distance_m / pyramid.scale[7], 1e-12);
  EXPECT_EQ(mp.predict_level(mp.max_distance_m, pyramid), 0);
  EXPECT_EQ(mp.predict_level(mp.min_distance_m * 1.0001, pyramid), 7);
}

TEST(Map, CullingAKeyframeReparentsChildrenAndKeepsRelativePoses) {
  Map map;
  const KeyframeId a = map.add_keyframe(make_frame(100, 1), at_x(0.0), 0);
  const KeyframeId b = map.add_keyframe(make_frame(100, 2), at_x(0.1), 0);
  const KeyframeId c = map.add_keyframe(make_frame(100, 3), at_x(0.2), 0);
  shared_points(map, {a, b, c}, 0, 30);
  shared_points(map, {b, c}, 30, 30);
  map.update_connections(b);  // parent a: c shares more (60) but is younger
  map.update_connections(c);  // parent b (60 shared)
  ASSERT_EQ(map.keyframe(b)->parent, a);
  ASSERT_EQ(map.keyframe(c)->parent, b);
  EXPECT_FALSE(map.erase_keyframe(a));  // the root stays
  ASSERT_TRUE(map.erase_keyframe(b));
  EXPECT_EQ(map.keyframe(b), nullptr);
  EXPECT_TRUE(map.is_culled(b));
  EXPECT_EQ(map.keyframe(c)->parent, a);
  EXPECT_TRUE(map.keyframe(a)->children.count(c));
  EXPECT_EQ(map.keyframe(a)->connections.count(b), 0u);
  expect_consistent(map);
  // A pose relative to the culled keyframe follows its parent when the parent moves.
  ASSERT_TRUE(map.keyframe_pose(b).has_value());
  EXPECT_TRUE(map.keyframe_pose(b)->isApprox(at_x(0.1)));
  map.keyframe(a)->T_world_cam = at_x(1.0);
  EXPECT_TRUE(map.keyframe_pose(b)->isApprox(at_x(1.1)));
  const auto live = map.live_keyframe(b);
  ASSERT_TRUE(live.has_value());
  EXPECT_EQ(live->first, a);
}

TEST(Map, IdsComeFromEachMapsOwnCounters) {
  Map one, two;
  EXPECT_EQ(one.add_keyframe(make_frame(5, 1), at_x(0), 0), 0);
  EXPECT_EQ(one.add_keyframe(make_frame(5, 1), at_x(0), 0), 1);
  EXPECT_EQ(two.add_keyframe(make_frame(5, 1), at_x(0), 0), 0);
  EXPECT_EQ(one.add_map_point(Eigen::Vector3d(0, 0, 1), 0, 0), 0);
  EXPECT_EQ(two.add_map_point(Eigen::Vector3d(0, 0, 1), 0, 0), 0);
  // A second component has its own root.
  const KeyframeId other = one.add_keyframe(make_frame(5, 1), at_x(0), 1);
  EXPECT_TRUE(one.keyframe(other)->root);
  EXPECT_FALSE(one.keyframe(1)->root);
}

// A frame that tracked every point of `previous` (same features) with a pose.
Frame tracked_frame(const Map& map, KeyframeId previous, double x, core::TimeNs t_ns) {
  Frame f = map.keyframe(previous)->frame;
  f.t_ns = t_ns;
  f.T_world_cam = at_x(x);
  return f;
}

TEST(LocalMapping, RecentPointsAreCulledByFoundRatioAndObservations) {
  Map map;
  LocalMapper mapper(LocalMappingConfig{}, core::null_logger());
  Frame first = make_frame(60, 1);
  first.T_world_cam = at_x(0.0);
  const KeyframeId k0 = mapper.insert_keyframe(first, 0, true, map, nullptr);
  EXPECT_EQ(map.point_count(), 60u);  // the first keyframe takes every depth feature

  // The second keyframe sees the first 40 points; its other 20 features become new (recent) points.
  Frame second = make_frame(60, 2);
  second.T_world_cam = at_x(0.05);
  for (int i = 0; i < 40; ++i) second.map_points[static_cast<std::size_t>(i)] = map.keyframe(k0)->frame.map_points[static_cast<std::size_t>(i)];
  MappingReport report;
  const KeyframeId k1 = mapper.insert_keyframe(second, 0, false, map, &report);
  EXPECT_EQ(report.new_depth_points, 20);
  EXPECT_EQ(map.point(map.keyframe(k0)->frame.map_points[0])->observations.size(), 2u);
  const MapPointId rarely_found = map.keyframe(k1)->frame.map_points[40];
  map.point(rarely_found)->visible = 10;
  map.point(rarely_found)->found = 2;  // 0.2 < 0.25
  EXPECT_EQ(mapper.cull_recent_points(k1, map), 1);
  EXPECT_EQ(map.point(rarely_found), nullptr);

  // Two keyframes later, recent points seen by one keyframe only (weight 2 <= 3) go; those seen
  // again by the newest keyframe (weight 4) stay.
  Frame third = tracked_frame(map, k1, 0.1, 2);
  for (std::size_t i = 50; i < 60; ++i) third.map_points[i] = kNoMapPoint;  // 50..59 not seen again
  const KeyframeId k2 = mapper.insert_keyframe(third, 0, false, map, nullptr);
  EXPECT_EQ(mapper.cull_recent_points(k2, map), 0);  // one keyframe later: still on probation
  Frame fourth = tracked_frame(map, k2, 0.15, 3);
  const KeyframeId k3 = mapper.insert_keyframe(fourth, 0, false, map, nullptr);
  const std::size_t before = map.point_count();
  EXPECT_EQ(mapper.cull_recent_points(k3, map), 10);  // features 50..59 of k1
  EXPECT_EQ(map.point_count(), before - 10);
  EXPECT_NE(map.point(map.keyframe(k1)->frame.map_points[45]), nullptr);
  expect_consistent(map);
}

// Five keyframes (the root and four more) that all see the same 60 points at 2 m, whose features count
// as close below close_depth_m.
std::vector<KeyframeId> five_keyframes_seeing_everything(Map& map, LocalMapper& mapper, double close_depth_m) {
  Frame first = make_frame(60, 1);
  first.close_depth_m = close_depth_m;
  first.T_world_cam = at_x(0.0);
  KeyframeId last = mapper.insert_keyframe(first, 0, true, map, nullptr);
  std::vector<KeyframeId> ids{last};
  for (int k = 1; k <= 4; ++k) {
    last = mapper.insert_keyframe(tracked_frame(map, last, 0.01 * k, k), 0, false, map, nullptr);
    ids.push_back(last);
  }
  return ids;
}

TEST(LocalMapping, RedundantKeyframesAreCulled) {
  // 3 m: every point is close. 0: no threshold, every depth is close (as in tracking and point creation).
  for (const double close_depth_m : {3.0, 0.0}) {
    Map map;
    LocalMapper mapper(LocalMappingConfig{}, core::null_logger());
    const std::vector<KeyframeId> ids = five_keyframes_seeing_everything(map, mapper, close_depth_m);
    // Neighbours are visited strongest first (all equal: oldest first); the root is never culled. Each
    // culled keyframe removes an observer, and culling stops once a point has fewer than 3 others.
    const std::vector<KeyframeId> culled = mapper.cull_keyframes(ids.back(), map);
    EXPECT_EQ(culled, (std::vector<KeyframeId>{ids[1], ids[2]})) << "close depth " << close_depth_m;
    EXPECT_NE(map.keyframe(ids.front()), nullptr);
    EXPECT_EQ(map.keyframe_count(), 3u);
    expect_consistent(map);
  }
}

TEST(LocalMapping, KeyframesWithOnlyFarPointsAreNotCulled) {
  Map map;
  LocalMapper mapper(LocalMappingConfig{}, core::null_logger());
  const std::vector<KeyframeId> ids = five_keyframes_seeing_everything(map, mapper, 1.0);  // all at 2 m: far
  EXPECT_TRUE(mapper.cull_keyframes(ids.back(), map).empty());
  EXPECT_EQ(map.keyframe_count(), 5u);
}

// In threaded mode keyframes are in the map while they wait for their own mapping pass: processing an
// older keyframe must not cull them.
TEST(LocalMapping, KeyframesNewerThanTheCurrentOneAreNotCulled) {
  Map map;
  LocalMapper mapper(LocalMappingConfig{}, core::null_logger());
  const std::vector<KeyframeId> ids = five_keyframes_seeing_everything(map, mapper, 3.0);
  // ids[3] and ids[4] are as redundant as ids[1], and would be culled next without the rule.
  EXPECT_EQ(mapper.cull_keyframes(ids[2], map), (std::vector<KeyframeId>{ids[1]}));
  EXPECT_NE(map.keyframe(ids[3]), nullptr);
  EXPECT_NE(map.keyframe(ids[4]), nullptr);
  expect_consistent(map);
}

// ORB-SLAM leaves out epipolar pairs within 10 * sqrt(scale) px of the epipole (squared distance below
// 100 * scale). Moving 1 m forward, a point 4 m ahead seen 37.5 px from the epipole (the focus of
// expansion) has 1.4 degrees of parallax and is triangulated.
TEST(LocalMapping, TriangulatesAPointNearButNotAtTheEpipole) {
  Map map;
  LocalMapper mapper(LocalMappingConfig{}, core::null_logger());
  const Eigen::Vector3d p_world(0.3, 0.0, 4.0);
  Frame first = make_frame(60, 1);
  first.T_world_cam = Eigen::Isometry3d::Identity();
  // One feature without depth (beyond the sensor's range), not yet a point: at p_world, 357 px.
  const Eigen::Vector2d uv0 = *first.camera.project(p_world);
  first.keypoints.emplace_back(static_cast<float>(uv0.x()), static_cast<float>(uv0.y()), 31.0f, 0.0f, 0.0f, 0);
  first.uv.push_back(uv0);
  first.level.push_back(0);
  first.depth_m.push_back(-1.0);
  first.u_right.push_back(-1.0);
  cv::Mat descriptor(1, 32, CV_8UC1, cv::Scalar(0x5A));
  first.descriptors.push_back(descriptor);
  first.map_points.push_back(kNoMapPoint);
  first.outlier.push_back(false);
  const KeyframeId k0 = mapper.insert_keyframe(first, 0, true, map, nullptr);
  ASSERT_EQ(map.keyframe(k0)->frame.map_points.back(), kNoMapPoint);

  Frame second = map.keyframe(k0)->frame;  // tracks the 60 points; the free feature moves out from the centre
  second.t_ns = 1;
  second.T_world_cam = Eigen::Isometry3d(Eigen::Translation3d(0.0, 0.0, 1.0));
  const Eigen::Vector2d uv1 = *second.camera.project(p_world - Eigen::Vector3d(0.0, 0.0, 1.0));
  ASSERT_NEAR((uv0 - Eigen::Vector2d(second.camera.cx(), second.camera.cy())).norm(), 37.5, 1e-9);
  second.keypoints.back().pt = cv::Point2f(static_cast<float>(uv1.x()), static_cast<float>(uv1.y()));
  second.uv.back() = uv1;
  const KeyframeId k1 = mapper.insert_keyframe(second, 0, false, map, nullptr);

  EXPECT_EQ(mapper.triangulate(k1, map), 1);
  const MapPoint* p = map.point(map.keyframe(k1)->frame.map_points.back());
  ASSERT_NE(p, nullptr);
  EXPECT_LT((p->position - p_world).norm(), 1e-6);
  EXPECT_EQ(p->observations.count(k0), 1u);
  expect_consistent(map);
}

// A map of one keyframe (60 points) and a frame with two features at uv0 and uv1, both with the
// descriptor of the map point `id` (the second 2 bits off), the given depths and bf; finalize() derives
// the right coordinates from depth.
struct LookAlikes {
  Map map;
  MapPointId id = kNoMapPoint;
  Frame frame;
};

LookAlikes look_alikes(const Eigen::Vector2d& uv0, const Eigen::Vector2d& uv1, double bf, std::vector<double> depth_m) {
  LookAlikes out;
  LocalMapper mapper(LocalMappingConfig{}, core::null_logger());
  Frame first = make_frame(60, 1);
  first.T_world_cam = at_x(0.0);
  const KeyframeId k0 = mapper.insert_keyframe(first, 0, true, out.map, nullptr);
  out.id = out.map.keyframe(k0)->frame.map_points[0];
  const MapPoint& point = *out.map.point(out.id);
  Frame& f = out.frame;
  f.camera = first.camera;
  f.pyramid = first.pyramid;
  f.bf = bf;
  f.descriptors = cv::Mat(2, 32, CV_8UC1);
  for (int i = 0; i < 2; ++i) {
    const Eigen::Vector2d& at = i == 0 ? uv0 : uv1;
    f.keypoints.emplace_back(static_cast<float>(at.x()), static_cast<float>(at.y()), 31.0f, 0.0f, 0.0f, 0);
    f.uv.push_back(at);
    f.level.push_back(0);
    std::copy(point.descriptor.begin(), point.descriptor.end(), f.descriptors.ptr<std::uint8_t>(i));
  }
  f.descriptors.at<std::uint8_t>(1, 0) ^= 0x3;
  f.depth_m = std::move(depth_m);
  f.finalize();
  return out;
}

// A close point near the left edge has a negative (virtual) right coordinate, and depth must still agree:
// of two features where it projects, the one whose depth disagrees loses to the one whose depth agrees,
// though its descriptor is closer. finalize() derives the right coordinates from depth.
TEST(ProjectionSearch, DepthMustAgreeForAPointWithANegativeRightCoordinate) {
  const Eigen::Vector2d uv(10.0, 200.0);
  LookAlikes scene = look_alikes(uv, uv, 40.0, {2.0, 0.5});  // feature 0 is 1.5 m behind the point
  Frame& f = scene.frame;
  const MapPointId id = scene.id;
  ASSERT_DOUBLE_EQ(f.u_right[1], 10.0 - 40.0 / 0.5);

  ProjectedPoint p;
  p.id = id;
  p.uv = uv;
  p.depth_m = 0.5;
  p.u_right = uv.x() - f.bf / p.depth_m;  // -70 px
  p.level = 0;
  EXPECT_EQ(search_by_projection(f, {p}, scene.map, ProjectionSearchConfig{}), 1);
  EXPECT_EQ(f.map_points[0], kNoMapPoint);
  EXPECT_EQ(f.map_points[1], id);
}

// A point the frame already holds (a seed match, as loop verification plants the RANSAC inliers before
// its guided search) is not matched a second time to a look-alike feature beside it.
TEST(ProjectionSearch, APointTheFrameHoldsIsNotMatchedAgain) {
  const Eigen::Vector2d uv(300.0, 200.0);
  // The seeded feature and, 0.8 px away, a decoy 2 bits off; no depth.
  LookAlikes scene = look_alikes(uv, uv + Eigen::Vector2d(0.8, 0.0), 0.0, {-1.0, -1.0});
  Frame& f = scene.frame;
  const MapPointId id = scene.id;
  const Map& map = scene.map;
  f.map_points[0] = id;

  ProjectedPoint p;
  p.id = id;
  p.uv = uv;
  p.level = 0;
  EXPECT_EQ(search_by_projection(f, {p}, map, ProjectionSearchConfig{}), 0);
  EXPECT_EQ(f.map_points[0], id);
  EXPECT_EQ(f.map_points[1], kNoMapPoint);
  // Not held, the point goes to the feature that matches it best.
  f.map_points[0] = kNoMapPoint;
  EXPECT_EQ(search_by_projection(f, {p}, map, ProjectionSearchConfig{}), 1);
  EXPECT_EQ(f.map_points[0], id);
  EXPECT_EQ(f.map_points[1], kNoMapPoint);
}

// The essential graph holds each pair of keyframes once: a spanning-tree edge that is also a strong
// covisibility link is one edge (it was two, which gave the tree twice the weight of the other edges).
TEST(EssentialGraph, EachPairOfKeyframesIsOneEdge) {
  Map map;
  LocalMapper mapper(LocalMappingConfig{}, core::null_logger());
  Frame frame = make_frame(60, 1);
  frame.T_world_cam = at_x(0.0);
  std::vector<KeyframeId> ids{mapper.insert_keyframe(frame, 0, true, map, nullptr)};
  for (int k = 1; k < 3; ++k) {  // the same 60 points from two more places: all three linked with weight 60
    frame = map.keyframe(ids.back())->frame;
    frame.t_ns = k;
    frame.T_world_cam = at_x(0.1 * k);
    ids.push_back(mapper.insert_keyframe(frame, 0, false, map, nullptr));
  }
  std::map<KeyframeId, Eigen::Isometry3d> before;
  for (KeyframeId id : ids) before[id] = map.keyframe(id)->T_world_cam;
  for (KeyframeId id : ids) {
    ASSERT_EQ(map.keyframe(id)->connections.size(), 2u);
    for (const auto& [other, weight] : map.keyframe(id)->connections) EXPECT_EQ(weight, 60);
  }
  ASSERT_EQ(map.keyframe(ids[1])->parent, ids[0]);
  const KeyframeId parent2 = map.keyframe(ids[2])->parent;
  ASSERT_GE(parent2, 0);
  const auto pair_of = [](const PoseGraphEdge& e) { return std::make_pair(std::min(e.i, e.j), std::max(e.i, e.j)); };

  // Every link strong: three pairs, three edges, each at its uncorrected relative pose.
  std::vector<PoseGraphEdge> edges = essential_graph_edges(map, before, before, {}, {}, 50);
  std::set<std::pair<KeyframeId, KeyframeId>> pairs;
  for (const PoseGraphEdge& e : edges) {
    EXPECT_TRUE(pairs.insert(pair_of(e)).second) << e.i << "-" << e.j << " twice";
    EXPECT_TRUE(e.T_i_j.isApprox(before[e.i].inverse() * before[e.j], 1e-12));
  }
  EXPECT_EQ(edges.size(), 3u);

  // None strong, and the third keyframe moved by a loop correction whose link to the keyframe other than
  // its parent is new: the two tree edges, and the loop link at the corrected relative pose.
  std::map<KeyframeId, Eigen::Isometry3d> corrected = before;
  corrected[ids[2]] = at_x(0.25);
  const KeyframeId other = parent2 == ids[0] ? ids[1] : ids[0];
  // A weak new link is no edge unless it joins the current and the loop keyframe (ORB-SLAM's rule).
  edges = essential_graph_edges(map, before, corrected, {ids[2]}, {{ids[2], {parent2}}}, 1000);
  EXPECT_EQ(edges.size(), 2u);
  edges = essential_graph_edges(map, before, corrected, {ids[2]}, {{ids[2], {parent2}}}, 1000, {ids[2], other});
  ASSERT_EQ(edges.size(), 3u);
  int loop_links = 0;
  for (const PoseGraphEdge& e : edges) {
    if (pair_of(e) == std::make_pair(std::min(other, ids[2]), std::max(other, ids[2]))) {
      ++loop_links;
      EXPECT_TRUE(e.T_i_j.isApprox(corrected[e.i].inverse() * corrected[e.j], 1e-12));
    } else {
      EXPECT_TRUE(e.T_i_j.isApprox(before[e.i].inverse() * before[e.j], 1e-12));
    }
  }
  EXPECT_EQ(loop_links, 1);

  // A loop keyframe the fusion left unlinked to the current one (its own points not fused): the loop's
  // edge all the same, at the corrected relative pose.
  Frame apart = make_frame(60, 2);
  apart.t_ns = 10;
  apart.T_world_cam = at_x(3.0);
  const KeyframeId unlinked = mapper.insert_keyframe(apart, 0, false, map, nullptr);
  ASSERT_EQ(map.keyframe(unlinked)->connections.count(ids[2]), 0u);
  std::map<KeyframeId, Eigen::Isometry3d> before4 = before;
  before4[unlinked] = apart.T_world_cam.value();
  std::map<KeyframeId, Eigen::Isometry3d> corrected4 = corrected;
  corrected4[unlinked] = before4[unlinked];
  edges = essential_graph_edges(map, before4, corrected4, {ids[2]}, {{ids[2], {parent2}}}, 1000, {ids[2], unlinked});
  loop_links = 0;
  for (const PoseGraphEdge& e : edges) {
    if (pair_of(e) != std::make_pair(std::min(unlinked, ids[2]), std::max(unlinked, ids[2]))) continue;
    ++loop_links;
    EXPECT_TRUE(e.T_i_j.isApprox(corrected4[e.i].inverse() * corrected4[e.j], 1e-12));
  }
  EXPECT_EQ(loop_links, 1);

  // An earlier loop's edge stays in the graph, at its uncorrected relative pose, weak as its link may be.
  ASSERT_TRUE(map.add_loop_edge(ids[0], ids[2]));
  EXPECT_FALSE(map.add_loop_edge(ids[0], ids[0]));
  EXPECT_FALSE(map.add_loop_edge(ids[0], 999));
  edges = essential_graph_edges(map, before, corrected, {}, {}, 1000);
  int kept = 0;
  for (const PoseGraphEdge& e : edges) {
    if (pair_of(e) == std::make_pair(ids[0], ids[2])) {
      ++kept;
      EXPECT_TRUE(e.T_i_j.isApprox(before[e.i].inverse() * before[e.j], 1e-12));
    }
  }
  EXPECT_EQ(kept, 1);
  EXPECT_EQ(edges.size(), parent2 == ids[0] ? 2u : 3u);
  // Keyframes joined by a loop are never culled.
  EXPECT_FALSE(map.erase_keyframe(ids[2]));
  EXPECT_NE(map.keyframe(ids[2]), nullptr);
}

}  // namespace
}  // namespace fleetslam::slam
