// The confirmation step of loop closing: each covisible neighbour of the current keyframe is refined on
// the loop's points where the correction puts it. The correction moves every neighbour with the current
// keyframe except the component's root, which stays where it is (the old side); the root is looked for
// there, so a camera back at its start does not have its true loop refused because the root was tested
// at a pose shifted by the whole correction.

#include <gtest/gtest.h>

#include <vector>

#include "fleetslam/core/log.hpp"
#include "fleetslam/slam/loop_closing.hpp"
#include "fleetslam/slam/map.hpp"
#include "map_test_util.hpp"

namespace fleetslam::slam {
namespace {

Eigen::Isometry3d at_x(double x) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, 0.0, 0.0);
  return T;
}

TEST(LoopConfirmation, TheRootIsLookedForWhereItStandsAndTheOthersWhereTheCorrectionMovesThem) {
  Map map;
  Frame seen = test::make_frame(100, 1);
  seen.finalize();
  // The root and a later keyframe at the same place, both seeing the loop's points (their features'
  // depth points from there).
  const KeyframeId root = map.add_keyframe(seen, Eigen::Isometry3d::Identity(), 0);
  const KeyframeId later = map.add_keyframe(seen, Eigen::Isometry3d::Identity(), 0);
  ASSERT_TRUE(map.keyframe(root)->root);
  ASSERT_FALSE(map.keyframe(later)->root);
  LoopCloser::Verified loop;
  loop.loop = root;
  for (std::size_t i = 0; i < seen.size(); ++i) {
    const MapPointId id = map.add_map_point(*seen.unproject(i), root, static_cast<int>(i));
    map.add_observation(id, later, static_cast<int>(i));
    map.update_point_statistics(id);
    loop.loop_points.push_back(id);
  }
  // The current keyframe drifted 0.4 m: the correction brings it (and its moving neighbours) back by that.
  const KeyframeId current = map.add_keyframe(test::make_frame(100, 2), at_x(0.4), 0);
  loop.T_world_cam = Eigen::Isometry3d::Identity();
  LoopClosingConfig config;
  const LoopCloser closer(config, core::null_logger());
  EXPECT_EQ(closer.confirmations(*map.keyframe(current), {root}, loop, map), 1) << "the root, where it stands";
  // A moving neighbour is looked for 0.4 m from where it saw the points: no confirmation.
  EXPECT_EQ(closer.confirmations(*map.keyframe(current), {later}, loop, map), 0);
  // Had it drifted with the current keyframe, the correction brings it back onto them.
  map.keyframe(later)->T_world_cam = at_x(0.4);
  EXPECT_EQ(closer.confirmations(*map.keyframe(current), {later}, loop, map), 1);
}

}  // namespace
}  // namespace fleetslam::slam
