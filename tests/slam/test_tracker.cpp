// Tracker contract checks that need no scene: a frame the tracker cannot place leaves with no pose.

#include <gtest/gtest.h>

#include "fleetslam/core/log.hpp"
#include "fleetslam/slam/keyframe_policy.hpp"
#include "fleetslam/slam/map.hpp"
#include "fleetslam/slam/tracker.hpp"
#include "map_test_util.hpp"

namespace fleetslam::slam {
namespace {

// Without enough depth no map can start: the frame is lost and carries no pose, whatever it held before
// (earlier stages of a call, a relocalisation candidate or the gyro's guess, may have left one).
TEST(Tracker, AFrameItCannotPlaceCarriesNoPose) {
  Tracker tracker(TrackingConfig{}, KeyframePolicyConfig{}, core::null_logger());
  Map map;
  Frame frame = test::make_frame(600, 3);
  for (double& depth : frame.depth_m) depth = -1.0;
  for (double& u_right : frame.u_right) u_right = -1.0;
  frame.T_world_cam = Eigen::Isometry3d(Eigen::Translation3d(1.0, 2.0, 3.0));
  const TrackingResult result = tracker.track(frame, map, TrackingInputs{});
  EXPECT_FALSE(result.initialized);
  EXPECT_FALSE(result.T_world_cam.has_value());
  EXPECT_FALSE(frame.T_world_cam.has_value());
  EXPECT_NE(result.reason.find("with depth"), std::string::npos) << result.reason;

  // With depth it starts a map at the initial pose.
  Frame good = test::make_frame(600, 3);
  good.t_ns = 1;
  const TrackingResult started = tracker.track(good, map, TrackingInputs{});
  EXPECT_TRUE(started.initialized);
  ASSERT_TRUE(good.T_world_cam.has_value());
  EXPECT_TRUE(good.T_world_cam->isApprox(Eigen::Isometry3d::Identity()));
}

}  // namespace
}  // namespace fleetslam::slam
