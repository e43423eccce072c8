// The central unit's server on hand-made agent updates: two robots whose keyframes see parts of one
// room, a deliberately wrong prior for the second robot, and bad input (unknown robot, duplicates and
// out-of-order updates, NaN points, keyframes of a restarted map, a robot that never overlaps).

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "fleetslam/central/link.hpp"
#include "fleetslam/central/server.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/core/se3.hpp"
#include "fleetslam/core/time.hpp"

namespace fleetslam::central {
namespace {

namespace fs = std::filesystem;

// Points on the walls, floor and a few boxes of a 6 x 4 x 2.5 m room (world frame), with structure in
// every direction so that registration is well constrained.
core::PointCloud room_world(std::uint32_t seed, double spacing_m) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> jitter(-0.3 * spacing_m, 0.3 * spacing_m);
  core::PointCloud cloud;
  const auto plane = [&](const Eigen::Vector3d& origin, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    const int na = static_cast<int>(a.norm() / spacing_m), nb = static_cast<int>(b.norm() / spacing_m);
    for (int i = 0; i <= na; ++i) {
      for (int j = 0; j <= nb; ++j) {
        const Eigen::Vector3d p = origin + a * (static_cast<double>(i) / na) + b * (static_cast<double>(j) / nb) +
                                  a.normalized() * jitter(rng) + b.normalized() * jitter(rng);
        cloud.push_back(p.cast<float>(), core::PointCloud::Rgb{static_cast<std::uint8_t>(40 * i % 255),
                                                               static_cast<std::uint8_t>(30 * j % 255), 128});
      }
    }
  };
  const Eigen::Vector3d X(6, 0, 0), Y(0, 4, 0), Z(0, 0, 2.5);
  plane({0, 0, 0}, X, Y);  // floor
  plane({0, 0, 0}, X, Z);
  plane({0, 4, 0}, X, Z);
  plane({0, 0, 0}, Y, Z);
  plane({6, 0, 0}, Y, Z);
  for (const Eigen::Vector3d& c : {Eigen::Vector3d(1.0, 1.0, 0), Eigen::Vector3d(2.3, 2.6, 0), Eigen::Vector3d(3.1, 0.7, 0),
                                   Eigen::Vector3d(3.3, 3.0, 0), Eigen::Vector3d(4.6, 1.8, 0)}) {
    const Eigen::Vector3d w(0.6, 0, 0), d(0, 0.5, 0), h(0, 0, 0.7);
    plane(c, w, h);
    plane(c + d, w, h);
    plane(c, d, h);
    plane(c + w, d, h);
    plane(c + h, w, d);
  }
  return cloud;
}

Eigen::Isometry3d pose(const Eigen::Vector3d& t, double yaw_rad) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = t;
  return T;
}

// A keyframe of robot `robot` at world pose T_world_cam seeing the room points within its x range.
slam::KeyframeSnapshot keyframe(slam::KeyframeId id, core::TimeNs t_ns, const Eigen::Isometry3d& T_world_robot,
                                const Eigen::Isometry3d& T_world_cam, const core::PointCloud& room, double x_min, double x_max) {
  slam::KeyframeSnapshot kf;
  kf.id = id;
  kf.t_ns = t_ns;
  kf.T_world_cam = T_world_robot.inverse() * T_world_cam;  // in the robot's frame
  core::PointCloud seen;
  for (std::size_t i = 0; i < room.size(); ++i) {
    const float x = room.points[i].x();
    if (static_cast<double>(x) >= x_min && static_cast<double>(x) <= x_max) seen.push_back(room.points[i], room.colors[i]);
  }
  kf.dense_cam = core::transformed(seen, T_world_cam.inverse());
  return kf;
}

slam::AgentUpdate update(int robot, std::int64_t sequence, core::TimeNs t_ns, const Eigen::Isometry3d& T_robot_cam) {
  slam::AgentUpdate u;
  u.robot_id = robot;
  u.sequence = sequence;
  u.t_ns = t_ns;
  u.status = slam::FrameStatus::kTracked;
  u.T_world_cam = T_robot_cam;
  u.component = 0;
  return u;
}

struct TwoRobots {
  core::PointCloud room = room_world(3, 0.05);
  Eigen::Isometry3d T_world_a = pose({0.5, 0.5, 1.0}, 0.0);
  Eigen::Isometry3d T_world_b = pose({5.5, 3.5, 1.0}, 3.0);  // the truth
  Eigen::Isometry3d prior_b;                                  // off by 10 cm and 5 degrees
  TwoRobots() {
    prior_b = T_world_b;
    prior_b.translation() += Eigen::Vector3d(0.06, -0.08, 0.0);
    prior_b.linear() = Eigen::AngleAxisd(5.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix() * T_world_b.linear();
  }
  // Robot A maps x in [0, 4], robot B x in [2, 6]: they share x in [2, 4].
  void feed(Server& server) const {
    InProcessLink link;
    for (int k = 0; k < 4; ++k) {
      const core::TimeNs t = (k + 1) * 1'000'000'000LL;
      const Eigen::Isometry3d T_world_cam_a = pose({0.5 + 0.8 * k, 0.5, 1.0}, 0.0);
      slam::AgentUpdate ua = update(0, k, t, T_world_a.inverse() * T_world_cam_a);
      ua.new_keyframes.push_back(keyframe(k, t, T_world_a, T_world_cam_a, room, k, k + 1.0));
      link.send(ua);
      const Eigen::Isometry3d T_world_cam_b = pose({5.5 - 0.8 * k, 3.5, 1.0}, 3.0);
      slam::AgentUpdate ub = update(1, k, t, T_world_b.inverse() * T_world_cam_b);
      ub.new_keyframes.push_back(keyframe(k, t, T_world_b, T_world_cam_b, room, 5.0 - k, 6.0 - k));
      link.send(ub);
    }
    EXPECT_EQ(server.integrate_all(link), 8u);
  }
};

double rotation_deg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return core::rotation_angle_rad(a.linear().transpose() * b.linear()) * 180.0 / M_PI;
}

TEST(Server, RefinesAWrongPriorAndFusesTheTrajectory) {
  const TwoRobots s;
  Server server(ServerConfig{}, core::null_logger());
  server.add_robot({0, "a", s.T_world_a, {}});
  server.add_robot({1, "b", s.prior_b, {}});
  s.feed(server);
  const ServerMergeReport& report = server.merge();
  ASSERT_EQ(report.robots.size(), 2u);
  const RobotFusionReport& b = report.robots[1];
  EXPECT_TRUE(b.registered);
  EXPECT_GT(b.overlap_points, 1000u);
  const double t_err = (b.T_world_robot.translation() - s.T_world_b.translation()).norm();
  const double r_err = rotation_deg(b.T_world_robot, s.T_world_b);
  std::printf("robot b: refined to %.4f m / %.3f deg of the truth (prior 0.1 m / 5 deg), status %s\n", t_err, r_err, b.merge_status.c_str());
  EXPECT_LT(t_err, 0.01);
  EXPECT_LT(r_err, 0.5);
  EXPECT_FALSE(b.anchors.empty());
  // Its trajectory in the world frame follows the refined transform.
  const core::Trajectory world = server.world_trajectory(1);
  ASSERT_EQ(world.size(), 4u);
  for (int k = 0; k < 4; ++k) {
    const Eigen::Isometry3d truth = pose({5.5 - 0.8 * k, 3.5, 1.0}, 3.0);
    EXPECT_LT((world[static_cast<std::size_t>(k)].T_world_body.translation() - truth.translation()).norm(), 0.015);
  }
  EXPECT_GT(report.merge.cloud_world.size(), 0u);
}

TEST(Server, BadUpdatesAreCountedNotFatal) {
  const TwoRobots s;
  Server server(ServerConfig{}, core::null_logger());
  server.add_robot({0, "a", s.T_world_a, {}});
  EXPECT_THROW(server.add_robot({0, "again", s.T_world_a, {}}), InputError);
  Eigen::Isometry3d sheared = Eigen::Isometry3d::Identity();
  sheared.linear()(0, 1) = 0.5;
  EXPECT_THROW(server.add_robot({5, "sheared", sheared, {}}), InputError);

  EXPECT_EQ(server.integrate(update(7, 0, 1, Eigen::Isometry3d::Identity())), IntegrateStatus::kUnknownRobot);
  slam::AgentUpdate first = update(0, 3, 1'000, Eigen::Isometry3d::Identity());
  first.new_keyframes.push_back(keyframe(0, 1'000, s.T_world_a, s.T_world_a, s.room, 0.0, 2.0));
  first.new_keyframes.back().dense_cam->points[0] = Eigen::Vector3f(NAN, 0.0f, 1.0f);
  EXPECT_EQ(server.integrate(first), IntegrateStatus::kAccepted);
  EXPECT_EQ(server.integrate(first), IntegrateStatus::kOutOfOrder) << "a duplicate";
  EXPECT_EQ(server.integrate(update(0, 2, 900, Eigen::Isometry3d::Identity())), IntegrateStatus::kOutOfOrder);
  Eigen::Isometry3d nan_pose = Eigen::Isometry3d::Identity();
  nan_pose.translation().x() = NAN;
  // A non-finite frame pose: the frame is ignored, its keyframe changes (sent once) still apply.
  slam::AgentUpdate nan_frame = update(0, 4, 2'000, nan_pose);
  nan_frame.new_keyframes.push_back(keyframe(5, 2'000, s.T_world_a, s.T_world_a, s.room, 2.0, 3.0));
  EXPECT_EQ(server.integrate(nan_frame), IntegrateStatus::kInvalid);
  EXPECT_EQ(server.integrate(nan_frame), IntegrateStatus::kOutOfOrder) << "its sequence was taken";
  // A keyframe of a restarted map (component 1): kept as a submap of its own.
  slam::AgentUpdate restarted = update(0, 5, 3'000, Eigen::Isometry3d::Identity());
  restarted.component = 1;
  restarted.new_keyframes.push_back(keyframe(9, 3'000, s.T_world_a, s.T_world_a, s.room, 0.0, 1.0));
  restarted.new_keyframes.back().component = 1;
  EXPECT_EQ(server.integrate(restarted), IntegrateStatus::kAccepted);

  const RobotCounters& c = server.counters(0);
  EXPECT_EQ(c.updates, 2u);
  EXPECT_EQ(c.rejected, 4u);
  EXPECT_EQ(c.nan_points, 1u);
  EXPECT_EQ(c.other_component_keyframes, 1u);
  EXPECT_EQ(server.robot_keyframes(0).size(), 3u);
  EXPECT_EQ(server.robot_keyframes(0, 0).size(), 2u);
  EXPECT_EQ(server.robot_keyframes(0, 1).size(), 1u);
  const core::PointCloud cloud = server.robot_cloud(0);
  for (const Eigen::Vector3f& p : cloud.points) EXPECT_TRUE(p.allFinite());
  EXPECT_EQ(server.robot_trajectory(0).size(), 2u);
  EXPECT_EQ(server.robot_trajectory(0, 1).size(), 1u);
  EXPECT_THROW(server.robot_cloud(42), InputError);
}

// A first keyframe with a non-finite pose is ignored before it names the robot's map: the map of the first
// keyframe kept (component 1, after a restart) is the robot's first map, not another component.
TEST(Server, AnIgnoredFirstKeyframeDoesNotNameTheRobotsMap) {
  const TwoRobots s;
  Server server(ServerConfig{}, core::null_logger());
  server.add_robot({0, "a", s.T_world_a, {}});
  slam::AgentUpdate first = update(0, 1, 1'000, Eigen::Isometry3d::Identity());
  first.new_keyframes.push_back(keyframe(0, 1'000, s.T_world_a, s.T_world_a, s.room, 0.0, 2.0));
  first.new_keyframes.back().T_world_cam.translation().x() = NAN;
  EXPECT_EQ(server.integrate(first), IntegrateStatus::kAccepted);
  slam::AgentUpdate restarted = update(0, 2, 2'000, Eigen::Isometry3d::Identity());
  restarted.component = 1;
  restarted.new_keyframes.push_back(keyframe(1, 2'000, s.T_world_a, s.T_world_a, s.room, 0.0, 2.0));
  restarted.new_keyframes.back().component = 1;
  EXPECT_EQ(server.integrate(restarted), IntegrateStatus::kAccepted);
  EXPECT_EQ(server.counters(0).other_component_keyframes, 0u);
  EXPECT_EQ(server.robot_keyframes(0).size(), 1u);
  EXPECT_FALSE(server.robot_cloud(0).empty()) << "the robot's first map is component 1";
}

// An agent's changes after its last frame (Agent::finish) carry that frame's sequence: accepted, not
// counted as a frame, and the frames' order is kept.
TEST(Server, MapChangesAfterTheLastFrameAreAccepted) {
  const TwoRobots s;
  Server server(ServerConfig{}, core::null_logger());
  server.add_robot({0, "a", s.T_world_a, {}});
  slam::AgentUpdate frame = update(0, 3, 1'000, Eigen::Isometry3d::Identity());
  frame.new_keyframes.push_back(keyframe(0, 1'000, s.T_world_a, s.T_world_a, s.room, 0.0, 1.0));
  ASSERT_EQ(server.integrate(frame), IntegrateStatus::kAccepted);
  slam::AgentUpdate changes;
  changes.robot_id = 0;
  changes.sequence = 3;
  changes.t_ns = 1'000;
  changes.status = slam::FrameStatus::kMapChanges;
  changes.new_keyframes.push_back(keyframe(1, 1'000, s.T_world_a, s.T_world_a, s.room, 1.0, 2.0));
  EXPECT_EQ(server.integrate(changes), IntegrateStatus::kAccepted);
  changes.sequence = 2;
  EXPECT_EQ(server.integrate(changes), IntegrateStatus::kOutOfOrder);
  EXPECT_EQ(server.integrate(update(0, 3, 1'100, Eigen::Isometry3d::Identity())), IntegrateStatus::kOutOfOrder);
  EXPECT_EQ(server.integrate(update(0, 4, 1'200, Eigen::Isometry3d::Identity())), IntegrateStatus::kAccepted);
  const RobotCounters& c = server.counters(0);
  EXPECT_EQ(c.updates, 2u);
  EXPECT_EQ(c.tracked, 2u);
  EXPECT_EQ(server.robot_keyframes(0).size(), 2u);
}

TEST(Server, KeyframeCorrectionsAndRemovalMoveFramesAndClouds) {
  const TwoRobots s;
  Server server(ServerConfig{}, core::null_logger());
  server.add_robot({0, "a", Eigen::Isometry3d::Identity(), {}});
  slam::AgentUpdate u0 = update(0, 0, 1'000, Eigen::Isometry3d::Identity());
  u0.new_keyframes.push_back(keyframe(0, 1'000, Eigen::Isometry3d::Identity(), Eigen::Isometry3d::Identity(), s.room, 0.0, 1.0));
  server.integrate(u0);
  server.integrate(update(0, 1, 2'000, pose({0.1, 0, 0}, 0.0)));
  // Local BA moves keyframe 0 by 5 cm: the frame after it moves too, and so does its cloud.
  slam::AgentUpdate u2 = update(0, 2, 3'000, pose({0.25, 0, 0}, 0.0));
  slam::KeyframeSnapshot moved = keyframe(0, 1'000, Eigen::Isometry3d::Identity(), pose({0.05, 0, 0}, 0.0), s.room, 0.0, 1.0);
  moved.dense_cam.reset();  // pose only: the server keeps the cloud it has
  u2.changed_keyframes.push_back(moved);
  server.integrate(u2);
  const core::Trajectory frames = server.robot_trajectory(0);
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_NEAR(frames[1].T_world_body.translation().x(), 0.15, 1e-9);
  const core::PointCloud cloud = server.robot_cloud(0);
  EXPECT_FALSE(cloud.empty());
  // Removing the only keyframe keeps the frames (at its last pose) and drops its cloud.
  slam::AgentUpdate u3 = update(0, 3, 4'000, pose({0.3, 0, 0}, 0.0));
  u3.removed_keyframes.push_back(0);
  server.integrate(u3);
  EXPECT_EQ(server.robot_trajectory(0).size(), 4u);
  EXPECT_TRUE(server.robot_cloud(0).empty());
}

// The frames of a culled keyframe move to its nearest surviving keyframe and follow that one's later
// corrections (a loop closure moving the map), as the agent's own estimate of them does; so do the frames
// that arrive after the cull.
TEST(Server, FramesOfACulledKeyframeFollowItsHeir) {
  const TwoRobots s;
  Server server(ServerConfig{}, core::null_logger());
  server.add_robot({0, "a", Eigen::Isometry3d::Identity(), {}});
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  slam::AgentUpdate u0 = update(0, 0, 1'000, identity);
  u0.new_keyframes.push_back(keyframe(0, 1'000, identity, identity, s.room, 0.0, 1.0));
  server.integrate(u0);
  slam::AgentUpdate u1 = update(0, 1, 2'000, pose({0.2, 0, 0}, 0.0));
  u1.new_keyframes.push_back(keyframe(1, 2'000, identity, pose({0.2, 0, 0}, 0.0), s.room, 0.0, 1.0));
  server.integrate(u1);
  server.integrate(update(0, 2, 3'000, pose({0.3, 0, 0}, 0.0)));  // refers to keyframe 1
  slam::AgentUpdate u3 = update(0, 3, 4'000, pose({0.4, 0, 0}, 0.0));
  u3.removed_keyframes.push_back(1);  // culled: its frames go to keyframe 0
  server.integrate(u3);
  // A correction moves keyframe 0 by 10 cm in y: every frame moves with it.
  slam::AgentUpdate u4 = update(0, 4, 5'000, pose({0.5, 0.1, 0}, 0.0));
  slam::KeyframeSnapshot moved = keyframe(0, 1'000, identity, pose({0.0, 0.1, 0}, 0.0), s.room, 0.0, 1.0);
  moved.dense_cam.reset();
  u4.changed_keyframes.push_back(moved);
  server.integrate(u4);
  const core::Trajectory frames = server.robot_trajectory(0);
  ASSERT_EQ(frames.size(), 5u);
  const double expected_x[] = {0.0, 0.2, 0.3, 0.4, 0.5};
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_NEAR(frames[i].T_world_body.translation().x(), expected_x[i], 1e-9) << i;
    EXPECT_NEAR(frames[i].T_world_body.translation().y(), 0.1, 1e-9) << i;
  }
}

TEST(Server, RobotThatNeverOverlapsKeepsItsPrior) {
  const TwoRobots s;
  Server server(ServerConfig{}, core::null_logger());
  server.add_robot({0, "a", s.T_world_a, {}});
  const Eigen::Isometry3d far = pose({100.0, 0.0, 0.0}, 0.0);
  server.add_robot({1, "far", far, {}});
  s.feed(server);  // robot 1's clouds are placed 100 m away by its prior
  const ServerMergeReport& report = server.merge();
  const RobotFusionReport& r = report.robots[1];
  EXPECT_FALSE(r.registered);
  EXPECT_EQ(r.overlap_points, 0u);
  EXPECT_TRUE(r.T_world_robot.isApprox(far));
  EXPECT_TRUE(r.anchors.empty());
}

// Robot A loses track after its second keyframe; its agent starts component 1 at a dead-reckoned pose
// 12 cm and 4 degrees off. Component 1 overlaps component 0 (x in [1.6, 4]): registration places it, and
// its frames follow. A component 2 far from everything (its dead reckoning gone wrong) stays out of the
// merged map while its frames follow the robot's transform.
TEST(Server, LaterMapComponentsAreRegisteredAsSubmaps) {
  const TwoRobots s;
  Server server(ServerConfig{}, core::null_logger());
  server.add_robot({0, "a", s.T_world_a, {}});
  Eigen::Isometry3d drift = pose({0.08, -0.09, 0.0}, 4.0 * M_PI / 180.0);  // agent frame of component 1 -> true agent frame
  drift = drift.inverse();
  const Eigen::Isometry3d far = pose({40.0, 0.0, 0.0}, 0.0);
  std::int64_t sequence = 0;
  for (int k = 0; k < 6; ++k) {
    const int component = k < 2 ? 0 : k < 5 ? 1 : 2;
    const core::TimeNs t = (k + 1) * 1'000'000'000LL;
    const Eigen::Isometry3d T_world_cam = pose({0.5 + 0.6 * k, 0.5, 1.0}, 0.0);
    // What the agent believes: the true pose in its frame, moved by the component's dead-reckoning error.
    const Eigen::Isometry3d T_agent_world = component == 0 ? s.T_world_a.inverse()
                                            : component == 1 ? drift * s.T_world_a.inverse()
                                                             : far * s.T_world_a.inverse();
    slam::AgentUpdate u = update(0, sequence++, t, T_agent_world * T_world_cam);
    u.component = component;
    slam::KeyframeSnapshot kf = keyframe(k, t, s.T_world_a, T_world_cam, s.room, 0.6 * k, 0.6 * k + 1.6);
    kf.T_world_cam = T_agent_world * T_world_cam;
    kf.component = component;
    u.new_keyframes.push_back(kf);
    EXPECT_EQ(server.integrate(u), IntegrateStatus::kAccepted);
  }
  const ServerMergeReport& report = server.merge();
  ASSERT_EQ(report.robots.size(), 1u);
  const RobotFusionReport& a = report.robots[0];
  EXPECT_EQ(a.component, 0);
  ASSERT_EQ(a.later_components.size(), 2u);
  const ComponentPlacement& c1 = a.later_components[0];
  const ComponentPlacement& c2 = a.later_components[1];
  EXPECT_EQ(c1.component, 1);
  EXPECT_TRUE(c1.placed) << c1.merge_status;
  EXPECT_TRUE(c1.registered) << c1.merge_status;
  const Eigen::Isometry3d truth_c1 = s.T_world_a * drift.inverse();  // component 1's frame in the world
  const double t_err = (c1.T_world_component.translation() - truth_c1.translation()).norm();
  std::printf("component 1: placed to %.4f m / %.3f deg of the truth (dead reckoning off by 0.12 m / 4 deg)\n", t_err,
              rotation_deg(c1.T_world_component, truth_c1));
  EXPECT_LT(t_err, 0.01);
  EXPECT_LT(rotation_deg(c1.T_world_component, truth_c1), 0.5);
  EXPECT_FALSE(c2.placed);
  EXPECT_NE(c2.merge_status.find("left out"), std::string::npos) << c2.merge_status;
  // Not placed, component 2 continues component 1 as this merge placed it (not as its prior had it, the
  // last merge's placement: then the trajectory jumped by this merge's correction where it began).
  EXPECT_TRUE(c2.T_world_component.isApprox(c1.T_world_component));
  EXPECT_FALSE(c2.T_world_component.isApprox(a.T_world_robot, 1e-3));
  // Every frame is in the world trajectory, in time order; component 1's where they truly were.
  const core::Trajectory world = server.world_trajectory(0);
  ASSERT_EQ(world.size(), 6u);
  for (int k = 0; k < 5; ++k) {
    const Eigen::Isometry3d truth = pose({0.5 + 0.6 * k, 0.5, 1.0}, 0.0);
    EXPECT_LT((world[static_cast<std::size_t>(k)].T_world_body.translation() - truth.translation()).norm(), 0.015) << k;
  }
  // The merged map holds components 0 and 1, not component 2 (nothing near x = 40 m).
  std::size_t far_points = 0;
  for (const Eigen::Vector3f& p : report.merge.cloud_world.points) far_points += p.x() > 20.0f ? 1 : 0;
  EXPECT_EQ(far_points, 0u);
  EXPECT_EQ(server.world_cloud(0).size(), server.robot_cloud(0, 0).size() + server.robot_cloud(0, 1).size());
  // The runner places a component's keyframes and live pose with T_world_component.
  EXPECT_TRUE(server.T_world_component(0, 1).isApprox(c1.T_world_component));
  EXPECT_TRUE(server.T_world_component(0, 0).isApprox(a.T_world_robot));
  // Component 2 continues component 1: the next merge's prior for it is component 1's placement too; a
  // component newer than the merge continues the newest one.
  const Eigen::Isometry3d T_world_c1 = c1.T_world_component;
  const ServerMergeReport& again = server.merge();
  ASSERT_EQ(again.robots[0].later_components.size(), 2u);
  EXPECT_FALSE(again.robots[0].later_components[1].placed);
  EXPECT_TRUE(again.robots[0].later_components[1].T_world_component.isApprox(T_world_c1, 1e-6));
  EXPECT_TRUE(server.T_world_component(0, 7).isApprox(T_world_c1, 1e-6));
}

// The two robots of TwoRobots, merged once; then robot B drives on (frames only, 1 s apart, at y = 3.75)
// while robot A's next keyframes also see it: points on B's body (a 0.2 m cylinder from 0.02 to 0.42 m
// above the floor under B's camera) where B is at that time, in a colour no room point has (blue 255),
// and decoys beside and above it that are scene (green 255). One more keyframe, at 6.5 s, sees B between
// two of its frames (no decoys there: they would stand where B is at 6 and 7 s).
struct Sightings {
  static constexpr std::uint8_t kBody = 255;
  RobotBody body_b;
  std::size_t decoys = 0;
  Sightings() {
    body_b.T_cam_body.translation() = Eigen::Vector3d(0, 0, -1.0);  // B's camera 1 m above the floor
    body_b.radius_m = 0.2;
    body_b.z_min_m = 0.02;
    body_b.z_max_m = 0.42;
  }
  // B's body origin: TwoRobots' path until 4 s, then on at y = 3.75.
  static Eigen::Vector3d b_at(double t_s) {
    return t_s <= 4.0 ? Eigen::Vector3d(5.5 - 0.8 * (t_s - 1.0), 3.5, 0.0) : Eigen::Vector3d(3.1 + 0.6 * (t_s - 4.0), 3.75, 0.0);
  }
  core::PointCloud around(const Eigen::Vector3d& b_world, bool with_decoys = true) {
    core::PointCloud cloud;
    for (int a = 0; a < 18; ++a) {
      const double angle = a * M_PI / 9.0;
      const Eigen::Vector3d dir(std::cos(angle), std::sin(angle), 0.0);
      for (int level = 1; level <= 4; ++level) {
        const double z = 0.1 * level;
        cloud.push_back((b_world + 0.2 * dir + Eigen::Vector3d(0, 0, z)).cast<float>(), core::PointCloud::Rgb{0, 0, kBody});
        if (!with_decoys) continue;
        cloud.push_back((b_world + 0.35 * dir + Eigen::Vector3d(0, 0, z)).cast<float>(), core::PointCloud::Rgb{0, 255, 0});
        ++decoys;
      }
      if (!with_decoys) continue;
      cloud.push_back((b_world + 0.1 * dir + Eigen::Vector3d(0, 0, 0.6)).cast<float>(), core::PointCloud::Rgb{0, 255, 0});
      ++decoys;
    }
    return cloud;
  }
  // Phase one, a merge, then phase two.
  void feed(Server& server, const TwoRobots& s) {
    s.feed(server);
    server.merge();
    InProcessLink link;
    std::int64_t sequence_a = 4;
    for (int k = 4; k < 8; ++k) {
      const double t_s = k + 1.0;
      const core::TimeNs t = static_cast<core::TimeNs>(t_s * 1e9);
      const Eigen::Isometry3d T_world_cam_a = pose({0.5 + 0.8 * (k - 4), 0.5, 1.0}, 0.0);
      slam::AgentUpdate ua = update(0, sequence_a++, t, s.T_world_a.inverse() * T_world_cam_a);
      slam::KeyframeSnapshot kf = keyframe(k, t, s.T_world_a, T_world_cam_a, s.room, k - 4.0, k - 3.0);
      kf.dense_cam->append(core::transformed(around(b_at(t_s)), T_world_cam_a.inverse()));
      ua.new_keyframes.push_back(kf);
      link.send(ua);
      if (k == 6) {  // at 6.5 s, between B's frames at 6 and 7 s
        const core::TimeNs t_mid = 6'500'000'000LL;
        slam::AgentUpdate mid = update(0, sequence_a++, t_mid, s.T_world_a.inverse() * T_world_cam_a);
        slam::KeyframeSnapshot seen = keyframe(10, t_mid, s.T_world_a, T_world_cam_a, core::PointCloud{}, 0.0, 0.0);
        seen.dense_cam = core::transformed(around(b_at(6.5), false), T_world_cam_a.inverse());
        mid.new_keyframes.push_back(seen);
        link.send(mid);
      }
      const Eigen::Isometry3d T_world_cam_b = pose(b_at(t_s) + Eigen::Vector3d(0, 0, 1.0), 3.0);
      link.send(update(1, k, t, s.T_world_b.inverse() * T_world_cam_b));
    }
    EXPECT_EQ(server.integrate_all(link), 9u);
  }
};

std::size_t count_colour(const core::PointCloud& cloud, std::uint8_t green, std::uint8_t blue) {
  std::size_t n = 0;
  for (const core::PointCloud::Rgb& c : cloud.colors) n += c[1] == green && c[2] == blue ? 1 : 0;
  return n;
}

// Checks every point of A's keyframes against B's true body where B was then: a masked point lies within
// the body grown by the margin, a point well inside it is masked (give and take 2 cm sideways and 4 cm
// in height for the registration's error: B's frames lie up to 3 m from the overlap, where a tenth of a
// degree of tilt is half a centimetre).
// Returns how many points were masked.
std::size_t check_masks_against_the_truth(const Server& server, const TwoRobots& s, double margin_m, bool expect_mid) {
  std::size_t masked = 0;
  for (const ServerKeyframe* kf_view : server.robot_keyframe_clouds(0)) {
    const ServerKeyframe& kf = *kf_view;
    const bool mid = kf.t_ns == 6'500'000'000LL;
    const Eigen::Vector3d b = Sightings::b_at(core::ns_to_seconds(kf.t_ns));
    const Eigen::Isometry3d T_world_cam = s.T_world_a * kf.T_robot_cam;
    for (std::size_t i = 0; i < kf.dense_cam.size(); ++i) {
      const bool is_masked = !kf.on_teammate.empty() && kf.on_teammate[i];
      const Eigen::Vector3d p = T_world_cam * kf.dense_cam.points[i].cast<double>() - b;
      const double d = p.head<2>().norm();
      if (is_masked) {
        ++masked;
        EXPECT_LE(d, 0.2 + margin_m + 0.02) << "t " << kf.t_ns;
        EXPECT_GE(p.z(), 0.02 - 0.04);
        EXPECT_LE(p.z(), 0.42 + margin_m + 0.04);
      } else if (!mid || expect_mid) {
        EXPECT_FALSE(d < 0.2 + margin_m - 0.02 && p.z() > 0.02 + 0.04 && p.z() < 0.42 + margin_m - 0.04)
            << "a point inside the teammate kept: t " << kf.t_ns << " at " << d << " m, z " << p.z();
      }
    }
  }
  return masked;
}

TEST(Server, PointsOnOtherRobotsAreLeftOutOfTheMaps) {
  const TwoRobots s;
  Sightings seen;
  ServerConfig config;
  config.teammate_max_gap_s = 1.5;  // B's frames are 1 s apart: interpolate between them
  Server server(config, core::null_logger());
  server.add_robot({0, "a", s.T_world_a, {}});
  server.add_robot({1, "b", s.prior_b, seen.body_b});
  seen.feed(server, s);
  const std::size_t body_points = count_colour(server.robot_cloud(0), 0, Sightings::kBody);
  EXPECT_EQ(body_points, 5u * 18u * 4u);
  EXPECT_EQ(server.last_merge()->robots[0].teammate_points, 0u);
  const ServerMergeReport& report = server.merge();
  ASSERT_TRUE(report.robots[1].registered);
  EXPECT_GE(report.robots[0].teammate_points, body_points);
  EXPECT_EQ(report.robots[1].teammate_points, 0u) << "A has no body: nothing of B's cloud is on it";
  EXPECT_EQ(count_colour(server.robot_cloud(0), 0, Sightings::kBody), 0u);
  EXPECT_EQ(count_colour(server.world_cloud(0), 0, Sightings::kBody), 0u);
  EXPECT_EQ(count_colour(server.robot_cloud(0), 255, 0), seen.decoys);
  EXPECT_EQ(check_masks_against_the_truth(server, s, config.teammate_margin_m, true), report.robots[0].teammate_points);
  // The merged map holds no point of B's body either (nothing within 15 cm of its axis, low down; at
  // 6.5 s the decoys of 6 and 7 s stand there).
  for (const Eigen::Vector3f& p : report.merge.cloud_world.points) {
    for (double t_s : {5.0, 6.0, 7.0, 8.0}) {
      const Eigen::Vector3d q = p.cast<double>() - Sightings::b_at(t_s);
      ASSERT_FALSE(q.head<2>().norm() < 0.15 && q.z() > 0.06 && q.z() < 0.42) << "t " << t_s << ": " << p.transpose();
    }
  }
}

TEST(Server, TeammatesAreMaskedOnlyWhereTheyCanBe) {
  const TwoRobots s;
  // Default gap (0.2 s): the keyframe between B's frames is left as it is.
  {
    Sightings seen;
    Server server(ServerConfig{}, core::null_logger());
    server.add_robot({0, "a", s.T_world_a, {}});
    server.add_robot({1, "b", s.prior_b, seen.body_b});
    seen.feed(server, s);
    server.merge();
    EXPECT_EQ(count_colour(server.robot_cloud(0), 0, Sightings::kBody), 18u * 4u);
    check_masks_against_the_truth(server, s, 0.05, false);
  }
  // Switched off; a robot with no body; a robot that never overlaps (placed only by its prior).
  for (int variant = 0; variant < 3; ++variant) {
    Sightings seen;
    ServerConfig config;
    config.mask_teammates = variant != 0;
    RobotBody body = seen.body_b;
    if (variant == 1) body.radius_m = 0.0;
    Server server(config, core::null_logger());
    server.add_robot({0, "a", s.T_world_a, {}});
    server.add_robot({1, "b", variant == 2 ? pose({100.0, 0.0, 0.0}, 0.0) : s.prior_b, body});
    seen.feed(server, s);
    const ServerMergeReport& report = server.merge();
    EXPECT_EQ(report.robots[1].registered, variant != 2);
    EXPECT_EQ(report.robots[0].teammate_points, 0u) << "variant " << variant;
    EXPECT_EQ(count_colour(server.robot_cloud(0), 0, Sightings::kBody), 5u * 18u * 4u) << "variant " << variant;
  }
}

TEST(Server, RejectsABodyItCannotUse) {
  Server server(ServerConfig{}, core::null_logger());
  RobotBody body;
  body.radius_m = -0.1;
  EXPECT_THROW(server.add_robot({0, "negative", Eigen::Isometry3d::Identity(), body}), InputError);
  body.radius_m = NAN;
  EXPECT_THROW(server.add_robot({1, "nan", Eigen::Isometry3d::Identity(), body}), InputError);
  body.radius_m = 0.2;
  body.z_min_m = 0.5;
  body.z_max_m = 0.1;
  EXPECT_THROW(server.add_robot({2, "upside down", Eigen::Isometry3d::Identity(), body}), InputError);
  body.z_min_m = 0.0;
  body.T_cam_body.linear()(0, 1) = 0.5;
  EXPECT_THROW(server.add_robot({3, "sheared", Eigen::Isometry3d::Identity(), body}), InputError);
  body.T_cam_body = Eigen::Isometry3d::Identity();
  EXPECT_NO_THROW(server.add_robot({4, "good", Eigen::Isometry3d::Identity(), body}));
}

// A config set in code is checked as its YAML would be (the limits of its visit), naming the key.
TEST(Server, RejectsAConfigSetInCodeOutsideItsLimits) {
  EXPECT_NO_THROW(Server(ServerConfig{}, core::null_logger()));
  const auto error_of = [](const ServerConfig& config) -> std::string {
    try {
      Server server(config, core::null_logger());
    } catch (const InputError& e) {
      return e.what();
    }
    return "no error";
  };
  ServerConfig config;
  config.anchor_radius_m = 0.0;  // every point would have been "near" through an infinite inverse cell
  EXPECT_EQ(error_of(config).rfind("central.anchor_radius_m: 0.0 is outside", 0), 0u) << error_of(config);
  config = ServerConfig{};
  config.merge.consistency_distance_m = 0.0;
  EXPECT_EQ(error_of(config).rfind("central.merge.consistency_distance_m: 0.0 is outside", 0), 0u) << error_of(config);
  config = ServerConfig{};
  config.anchor_min_overlap_share = NAN;
  EXPECT_EQ(error_of(config).rfind("central.anchor_min_overlap_share: expected a finite number", 0), 0u)
      << error_of(config);
}

TEST(Server, WritesItsOutputs) {
  const TwoRobots s;
  Server server(ServerConfig{}, core::null_logger());
  server.add_robot({0, "a", s.T_world_a, {}});
  server.add_robot({1, "b", s.prior_b, {}});
  s.feed(server);
  const fs::path dir = fs::path(FLEETSLAM_BINARY_DIR) / "test_output" / "central_server";
  fs::remove_all(dir);
  server.write_outputs(dir);
  for (const char* file : {"merged_map.ply", "merge.json", "a/map.ply", "a/trajectory.txt", "b/trajectory_robot.txt"}) {
    EXPECT_TRUE(fs::exists(dir / file)) << file;
  }
  const core::PointCloud merged = core::read_ply((dir / "merged_map.ply").string());
  EXPECT_EQ(merged.size(), server.last_merge()->merge.cloud_world.size());
}

}  // namespace
}  // namespace fleetslam::central
