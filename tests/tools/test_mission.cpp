// MissionPlanner on synthetic fused maps (no simulator): waypoint missions plan, advance and finish;
// an unreachable goal is given up after max_plan_failures; a lost robot drives back along its trail;
// exploration sends a robot to the unseen half of a room; robots' own footprints clear ghosts of robots.

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "../planners/synthetic_maps.hpp"
#include "fleetslam/runner/mission.hpp"

namespace fleetslam::runner {
namespace {

using planners::Pose2d;
using planners::test::add_box;
using planners::test::add_floor;
using planners::test::room;

PlanningConfig planning(planners::UnknownCells unknown = planners::UnknownCells::kFree) {
  PlanningConfig p;
  p.grid.bounds_xy_m = {-0.5, -0.5, 6.5, 4.5};
  p.path.unknown_cells = unknown;
  p.path.goal_snap_radius_m = 0.3;
  p.assignment.unknown_cells = unknown;
  return p;
}

MissionConfig waypoints_mission() {
  MissionConfig m;
  m.kind = MissionKind::kWaypoints;
  return m;
}

RobotObservation at(double x, double y, double yaw = 0.0, bool path_done = false) {
  RobotObservation o;
  o.tracking = true;
  o.has_pose = true;
  o.pose_world = Pose2d{x, y, yaw};
  o.path_done = path_done;
  o.footprint_world = {{x, y}};
  return o;
}

const PathCommand* command_for(const std::vector<PathCommand>& commands, std::size_t robot) {
  for (const PathCommand& c : commands) {
    if (c.robot == robot) return &c;
  }
  return nullptr;
}

// A 3 x 4 m west room seen whole, walled, with a 1 m doorway (y in [1.5, 2.5]) in its east wall at x = 3;
// the room beyond is unseen.
core::PointCloud west_room_with_doorway() {
  core::PointCloud seen;
  add_floor(seen, 0.0, 0.0, 2.97, 4.0);
  add_box(seen, -0.05, -0.05, 2.97, -0.01, 0.0, 1.2);
  add_box(seen, -0.05, 4.01, 2.97, 4.05, 0.0, 1.2);
  add_box(seen, -0.05, -0.05, -0.01, 4.05, 0.0, 1.2);
  add_box(seen, 2.97, -0.05, 3.03, 1.5, 0.0, 1.2);  // the wall between the rooms, with its doorway
  add_box(seen, 2.97, 2.5, 3.03, 4.05, 0.0, 1.2);
  return seen;
}

// The same, with what a camera in the west room sees through the doorway: the floor just beyond it and a
// narrow strip of the east room's floor up to its east wall.
core::PointCloud doorway_and_strip() {
  core::PointCloud seen = west_room_with_doorway();
  add_floor(seen, 2.97, 1.5, 3.4, 2.5);
  add_floor(seen, 3.4, 1.9, 5.5, 2.1);
  add_box(seen, 5.5, 1.85, 5.55, 2.15, 0.0, 1.2);
  return seen;
}

TEST(MissionPlanner, WaypointMissionPlansAdvancesAndFinishes) {
  const core::PointCloud map = room(6.0, 4.0);
  MissionPlanner mission(waypoints_mission(), planning(),
                         {MissionRobot{"a", true, {{4.0, 1.0}, {4.0, 3.0}}}, MissionRobot{"b", true, {{1.0, 3.0}}}});
  // First update: both robots get a path from where they are to their first waypoint.
  std::vector<PathCommand> commands = mission.update(0.5, map, {at(1.0, 1.0), at(5.0, 3.0, M_PI)});
  ASSERT_EQ(commands.size(), 2u);
  for (std::size_t r = 0; r < 2; ++r) {
    const PathCommand* c = command_for(commands, r);
    ASSERT_NE(c, nullptr);
    ASSERT_GE(c->path_world.size(), 2u) << mission.reports()[r].status;
  }
  EXPECT_LT((command_for(commands, 0)->path_world.front() - Eigen::Vector2d(1.0, 1.0)).norm(), 0.1);
  EXPECT_LT((command_for(commands, 0)->path_world.back() - Eigen::Vector2d(4.0, 1.0)).norm(), 0.15);
  EXPECT_LT((command_for(commands, 1)->path_world.back() - Eigen::Vector2d(1.0, 3.0)).norm(), 0.15);
  EXPECT_EQ(mission.reports()[0].goals_total, 2);
  // Still on the way, paths clear: nothing new.
  commands = mission.update(1.0, map, {at(2.0, 1.0), at(4.0, 3.0, M_PI)});
  EXPECT_TRUE(commands.empty());
  // a reached its first waypoint: a path to the next one; b is still on its way and keeps its path.
  commands = mission.update(2.0, map, {at(3.9, 1.05, 0.0, true), at(3.0, 3.0, M_PI)});
  ASSERT_NE(command_for(commands, 0), nullptr);
  EXPECT_EQ(command_for(commands, 1), nullptr);
  EXPECT_LT((command_for(commands, 0)->path_world.back() - Eigen::Vector2d(4.0, 3.0)).norm(), 0.15);
  EXPECT_EQ(mission.reports()[0].goals_reached, 1);
  ASSERT_TRUE(mission.goal_of(0).has_value());
  EXPECT_TRUE(mission.goal_of(0)->isApprox(Eigen::Vector2d(4.0, 3.0)));
  // Both done.
  commands = mission.update(3.0, map, {at(4.0, 2.9, M_PI / 2, true), at(1.1, 3.0, M_PI, true)});
  EXPECT_EQ(mission.reports()[0].goals_reached, 2);
  EXPECT_EQ(mission.reports()[1].goals_reached, 1);
  // Each reach by proximity records the spot it was accepted at: here the waypoints themselves.
  ASSERT_EQ(mission.reports()[0].reached_at_world.size(), 2u);
  EXPECT_TRUE(mission.reports()[0].reached_at_world[0].isApprox(Eigen::Vector2d(4.0, 1.0)));
  EXPECT_TRUE(mission.reports()[0].reached_at_world[1].isApprox(Eigen::Vector2d(4.0, 3.0)));
  EXPECT_EQ(mission.reports()[1].reached_at_world.size(), 1u);
  EXPECT_EQ(mission.reports()[0].status, "all goals reached");
  EXPECT_FALSE(mission.wants_plan(0));
  EXPECT_FALSE(mission.wants_plan(1));
  EXPECT_EQ(mission.reports()[0].events.size(), 2u);
}

TEST(MissionPlanner, UnreachableGoalIsGivenUpThenTheNextOneIsPlanned) {
  const core::PointCloud map = room(6.0, 4.0);
  MissionConfig m = waypoints_mission();
  m.max_plan_failures = 3;
  MissionPlanner mission(m, planning(), {MissionRobot{"a", true, {{9.0, 1.0}, {3.0, 1.0}}}});  // outside the bounds
  std::vector<PathCommand> commands;
  for (int i = 0; i < 3; ++i) {
    commands = mission.update(0.5 + i, map, {at(1.0, 1.0, 0.0, true)});
    EXPECT_EQ(mission.reports()[0].plan_failures, i + 1);
  }
  EXPECT_EQ(mission.reports()[0].goals_given_up, 1);
  ASSERT_FALSE(mission.reports()[0].events.empty());
  EXPECT_NE(mission.reports()[0].events.back().find("(9.00, 1.00) given up: no path (goal_invalid)"), std::string::npos)
      << mission.reports()[0].events.back();
  // The next update plans to the reachable waypoint.
  commands = mission.update(4.0, map, {at(1.0, 1.0, 0.0, true)});
  ASSERT_NE(command_for(commands, 0), nullptr);
  EXPECT_LT((command_for(commands, 0)->path_world.back() - Eigen::Vector2d(3.0, 1.0)).norm(), 0.15);
}

// A waypoint inside a carton: the planner moves the goal to the nearest free spot, farther from it than
// goal_reached_m; a robot that gets there has reached its goal (it used to be sent there again and again).
TEST(MissionPlanner, AGoalMovedOffAnObstacleIsReachedAtTheSpotItWasMovedTo) {
  core::PointCloud map = room(6.0, 4.0);
  add_box(map, 3.9, 0.9, 4.1, 1.1, 0.0, 0.5);
  PlanningConfig p = planning();
  p.path.goal_snap_radius_m = 0.5;
  MissionPlanner mission(waypoints_mission(), p, {MissionRobot{"a", true, {{4.0, 1.0}, {4.0, 3.0}}}});
  std::vector<PathCommand> commands = mission.update(0.5, map, {at(1.0, 1.0)});
  const PathCommand* c = command_for(commands, 0);
  ASSERT_NE(c, nullptr);
  ASSERT_FALSE(c->path_world.empty()) << mission.reports()[0].status;
  const Eigen::Vector2d end = c->path_world.back();
  ASSERT_GT((end - Eigen::Vector2d(4.0, 1.0)).norm(), mission.mission().goal_reached_m);
  commands = mission.update(1.5, map, {at(end.x(), end.y(), 0.0, true)});
  EXPECT_EQ(mission.reports()[0].goals_reached, 1);
  ASSERT_FALSE(mission.reports()[0].events.empty());
  EXPECT_NE(mission.reports()[0].events.back().find("reached at the free spot"), std::string::npos)
      << mission.reports()[0].events.back();
  // Accepted at the free spot, not at the waypoint inside the carton (the truth is measured from there).
  ASSERT_EQ(mission.reports()[0].reached_at_world.size(), 1u);
  EXPECT_LT((mission.reports()[0].reached_at_world[0] - end).norm(), 0.15);
  EXPECT_GT((mission.reports()[0].reached_at_world[0] - Eigen::Vector2d(4.0, 1.0)).norm(), mission.mission().goal_reached_m);
  c = command_for(commands, 0);
  ASSERT_NE(c, nullptr);
  EXPECT_LT((c->path_world.back() - Eigen::Vector2d(4.0, 3.0)).norm(), 0.15) << "on to the next waypoint";
}

// Paths driven to their end with the estimate 0.5 m off (the controller steers on the true pose): sent
// again while the merge may still correct the estimate, and given up short_of_goal_patience_s after the
// first such end instead of being driven to for ever.
TEST(MissionPlanner, AGoalWhosePathsEndShortOfItIsGivenUpAfterThePatience) {
  const core::PointCloud map = room(6.0, 4.0);
  MissionConfig m = waypoints_mission();
  m.short_of_goal_patience_s = 5.0;
  MissionPlanner mission(m, planning(), {MissionRobot{"a", true, {{4.0, 1.0}, {4.0, 3.0}}}});
  ASSERT_NE(command_for(mission.update(0.5, map, {at(1.0, 1.0)}), 0), nullptr);
  for (double t = 1.5; t < 6.5; t += 1.0) {
    const std::vector<PathCommand> commands = mission.update(t, map, {at(4.0, 1.5, 0.0, true)});
    ASSERT_NE(command_for(commands, 0), nullptr) << "sent again at " << t << " s";
    EXPECT_TRUE(mission.goal_of(0)->isApprox(Eigen::Vector2d(4.0, 1.0))) << "patience left at " << t << " s";
  }
  mission.update(6.5, map, {at(4.0, 1.5, 0.0, true)});  // 5 s after the first short end
  EXPECT_EQ(mission.reports()[0].goals_reached, 0);
  EXPECT_EQ(mission.reports()[0].goals_given_up, 1);
  bool short_event = false;
  for (const std::string& e : mission.reports()[0].events) short_event = short_event || e.find("short of its goal") != std::string::npos;
  EXPECT_TRUE(short_event);
  ASSERT_TRUE(mission.goal_of(0).has_value());
  EXPECT_TRUE(mission.goal_of(0)->isApprox(Eigen::Vector2d(4.0, 3.0)));
}

// Two robots swapping ends of a corridor too narrow to pass: b's conflict with a cannot be resolved, so b is
// held where it stands (no path), and a is planned around b's place (here: no path to its goal, which b
// stands on). No robot is sent along a path that comes within the separation of another.
TEST(MissionPlanner, ARobotWhoseConflictIsUnresolvedIsHeldAndTheOthersKeepClearOfIt) {
  const core::PointCloud map = room(6.0, 0.9);
  PlanningConfig p = planning();
  MissionPlanner mission(waypoints_mission(), p,
                         {MissionRobot{"a", true, {{5.5, 0.45}}}, MissionRobot{"b", true, {{0.5, 0.45}}}});
  const std::vector<RobotObservation> seen = {at(0.5, 0.45), at(5.5, 0.45, M_PI)};
  const std::vector<PathCommand> commands = mission.update(0.5, map, seen);
  const PathCommand* b = command_for(commands, 1);
  ASSERT_NE(b, nullptr);
  EXPECT_TRUE(b->path_world.empty()) << "b is held";
  EXPECT_NE(mission.reports()[1].status.find("held"), std::string::npos) << mission.reports()[1].status;
  const PathCommand* a = command_for(commands, 0);
  ASSERT_NE(a, nullptr);
  for (const Eigen::Vector2d& q : a->path_world) {
    EXPECT_GE((q - Eigen::Vector2d(5.5, 0.45)).norm(), p.deconfliction.separation_m - 1e-9) << q.transpose();
  }
}

TEST(MissionPlanner, LostRobotDrivesBackAlongItsTrailOnce) {
  const core::PointCloud map = room(6.0, 4.0);
  MissionPlanner mission(waypoints_mission(), planning(), {MissionRobot{"a", true, {{5.0, 1.0}}}});
  mission.update(0.5, map, {at(1.0, 1.0)});
  RobotObservation lost = at(3.0, 1.0);
  lost.tracking = false;
  lost.footprint_world = {{1.0, 1.0}, {1.5, 1.0}, {2.0, 1.0}, {2.5, 1.0}, {3.0, 1.0}};
  std::vector<PathCommand> commands = mission.update(1.0, map, {lost});
  const PathCommand* back = command_for(commands, 0);
  ASSERT_NE(back, nullptr);
  ASSERT_EQ(back->path_world.size(), 1u);
  EXPECT_TRUE(back->path_world[0].isApprox(Eigen::Vector2d(2.0, 1.0)));  // the first trail point >= 0.6 m back
  EXPECT_EQ(mission.reports()[0].status, "tracking lost: waiting to relocalise");
  EXPECT_TRUE(mission.update(1.5, map, {lost}).empty()) << "the drive back is commanded once";
  // Tracking again: it plans to its goal.
  commands = mission.update(2.0, map, {at(2.0, 1.0, M_PI, true)});
  ASSERT_NE(command_for(commands, 0), nullptr);
  EXPECT_LT((command_for(commands, 0)->path_world.back() - Eigen::Vector2d(5.0, 1.0)).norm(), 0.15);
}

TEST(MissionPlanner, ExplorationSendsARobotTowardsTheUnseenHalf) {
  // The west half of a 6 x 4 m room was seen; the east half is unknown.
  core::PointCloud map;
  add_floor(map, 0.0, 0.0, 2.99, 4.0);
  add_box(map, -0.05, -0.05, -0.01, 4.05, 0.0, 1.2);
  add_box(map, -0.05, -0.05, 2.99, -0.01, 0.0, 1.2);
  add_box(map, -0.05, 4.01, 2.99, 4.05, 0.0, 1.2);
  MissionConfig m;
  m.kind = MissionKind::kExplore;
  MissionPlanner mission(m, planning(planners::UnknownCells::kOccupied), {MissionRobot{"a", true, {}}});
  const std::vector<PathCommand> commands = mission.update(0.5, map, {at(1.0, 2.0)});
  ASSERT_NE(command_for(commands, 0), nullptr);
  ASSERT_TRUE(mission.goal_of(0).has_value());
  EXPECT_GT(mission.goal_of(0)->x(), 2.3) << "a goal at the frontier between the halves";
  EXPECT_LT(mission.goal_of(0)->x(), 3.0);
  EXPECT_EQ(mission.reports()[0].goals_total, 1);
  // Free rigs are never planned.
  MissionPlanner rig(m, planning(), {MissionRobot{"r", false, {}}});
  EXPECT_TRUE(rig.update(0.5, map, {at(1.0, 2.0)}).empty());
  EXPECT_FALSE(rig.wants_plan(0));
}

// Two patches of floor the map never sees (as the top of a bed is never seen from a camera below it)
// stay frontiers after a robot has stood beside them; once it reached both, neither is worth another trip
// (explore_revisit_radius_m), and without the rule it is sent back to the first.
TEST(MissionPlanner, AFrontierStillThereWhenItsGoalWasReachedIsNotVisitedAgain) {
  core::PointCloud map;
  add_floor(map, 0.0, 0.0, 6.0, 4.0);
  core::PointCloud with_holes;
  for (const Eigen::Vector3f& p : map.points) {
    const bool hole_a = p.x() > 1.2f && p.x() < 1.8f && p.y() > 1.7f && p.y() < 2.3f;
    const bool hole_b = p.x() > 4.2f && p.x() < 4.8f && p.y() > 1.7f && p.y() < 2.3f;
    if (!hole_a && !hole_b) with_holes.push_back(p);
  }
  add_box(with_holes, -0.05, -0.05, 6.05, -0.01, 0.0, 1.2);
  add_box(with_holes, -0.05, 4.01, 6.05, 4.05, 0.0, 1.2);
  add_box(with_holes, -0.05, -0.05, -0.01, 4.05, 0.0, 1.2);
  add_box(with_holes, 6.01, -0.05, 6.05, 4.05, 0.0, 1.2);
  const auto run = [&](double revisit_radius_m) {
    MissionConfig m;
    m.kind = MissionKind::kExplore;
    m.explore_revisit_radius_m = revisit_radius_m;
    MissionPlanner mission(m, planning(), {MissionRobot{"a", true, {}}});
    std::vector<Eigen::Vector2d> goals;
    Eigen::Vector2d position(3.0, 0.8);
    double t_s = 0.5;
    for (int trip = 0; trip < 3; ++trip) {
      mission.update(t_s, with_holes, {at(position.x(), position.y())});
      if (!mission.goal_of(0)) break;
      goals.push_back(*mission.goal_of(0));
      position = goals.back();
      t_s += 5.0;
      mission.update(t_s, with_holes, {at(position.x(), position.y(), 0.0, true)});  // there: reached
      t_s += 5.0;
    }
    return std::make_pair(goals, mission.reports()[0]);
  };
  const auto [goals, report] = run(0.6);
  ASSERT_EQ(goals.size(), 2u) << "one trip to each patch";
  EXPECT_GT((goals[0] - goals[1]).norm(), 2.0);
  EXPECT_EQ(report.goals_reached, 2);
  EXPECT_EQ(report.status, "no reachable frontier left");

  const auto [again, unruled] = run(0.0);
  ASSERT_EQ(again.size(), 3u);
  EXPECT_LT((again[2] - again[0]).norm(), 0.3) << "back to the first patch";
}

// Through a 1 m doorway a camera sees the next room's floor as a narrow strip between its rays: too narrow
// for the robot, too close to the jambs for a goal with the clearance asked for. Without viewpoints that
// frontier has no goal; with explore_view_search_m the robot is sent to a cell in front of the doorway
// that sees it, keeps that goal while the strip's frontier remains, and drops it once the room is seen.
TEST(MissionPlanner, AFrontierBeyondADoorwayGetsAViewpointInFrontOfIt) {
  const core::PointCloud seen = doorway_and_strip();
  const auto explore = [](double view_search_m) {
    MissionConfig m;
    m.kind = MissionKind::kExplore;
    m.explore_goal_clearance_m = 0.7;
    m.explore_view_search_m = view_search_m;
    return MissionPlanner(m, planning(planners::UnknownCells::kOccupied), {MissionRobot{"a", true, {}}});
  };
  MissionPlanner without = explore(0.0);
  without.update(0.5, seen, {at(1.0, 2.0)});
  EXPECT_FALSE(without.goal_of(0).has_value()) << without.goal_of(0)->transpose();
  EXPECT_EQ(without.reports()[0].status, "no reachable frontier left");

  MissionPlanner mission = explore(2.5);
  std::vector<PathCommand> commands = mission.update(0.5, seen, {at(1.0, 2.0)});
  ASSERT_TRUE(mission.goal_of(0).has_value());
  const Eigen::Vector2d goal = *mission.goal_of(0);
  EXPECT_LT(goal.x(), 2.97 - 0.4) << "in the west room, clear of the jambs: " << goal.transpose();
  EXPECT_GT(goal.x(), 1.5) << "in front of the doorway: " << goal.transpose();
  EXPECT_NEAR(goal.y(), 2.0, 0.5) << goal.transpose();
  const PathCommand* command = command_for(commands, 0);
  ASSERT_NE(command, nullptr);
  EXPECT_FALSE(command->path_world.empty());
  ASSERT_FALSE(mission.reports()[0].events.empty());
  EXPECT_NE(mission.reports()[0].events.back().find("viewpoint"), std::string::npos) << mission.reports()[0].events.back();
  // On its way (the strip's frontier still there, though far from the goal): the goal stays.
  mission.update(2.5, seen, {at(1.6, 2.0)});
  ASSERT_TRUE(mission.goal_of(0).has_value());
  EXPECT_TRUE(mission.goal_of(0)->isApprox(goal));
  // From there it sees the east room: the frontier is explored, and nothing is left to see.
  core::PointCloud both = seen;
  add_floor(both, 3.03, 0.0, 6.0, 4.0);
  add_box(both, 3.03, -0.05, 6.05, -0.01, 0.0, 1.2);
  add_box(both, 3.03, 4.01, 6.05, 4.05, 0.0, 1.2);
  add_box(both, 6.01, -0.05, 6.05, 4.05, 0.0, 1.2);
  mission.update(4.5, both, {at(2.0, 2.0)});
  EXPECT_NE(mission.reports()[0].events[1].find("its frontier has been explored"), std::string::npos)
      << mission.reports()[0].events[1];
  EXPECT_TRUE(mission.reports()[0].reached_at_world.empty()) << "reached by being seen, not at a spot";

  // A robot already standing at the viewpoint, facing away from the doorway, turns towards it (a short
  // step east), takes no goal while it turns, and does not turn to the same frontier again.
  MissionPlanner looker = explore(2.5);
  commands = looker.update(0.5, seen, {at(2.3, 2.0, M_PI)});
  ASSERT_NE(command_for(commands, 0), nullptr);
  ASSERT_EQ(command_for(commands, 0)->path_world.size(), 1u);
  EXPECT_NEAR(command_for(commands, 0)->path_world[0].x(), 2.3 + 0.25, 0.05);
  EXPECT_FALSE(looker.goal_of(0).has_value());
  ASSERT_FALSE(looker.reports()[0].events.empty());
  EXPECT_NE(looker.reports()[0].events.back().find("turns to look at the frontier"), std::string::npos)
      << looker.reports()[0].events.back();
  EXPECT_EQ(command_for(looker.update(1.5, seen, {at(2.3, 2.0, M_PI / 2.0, false)}), 0), nullptr) << "still turning";
  // Turned away again: not to the same frontier (another piece of the strip, farther east, if any).
  const std::string first = looker.reports()[0].events[0];
  looker.update(3.0, seen, {at(2.3, 2.0, M_PI, true)});
  for (std::size_t e = 1; e < looker.reports()[0].events.size(); ++e) {
    const std::string& event = looker.reports()[0].events[e];
    EXPECT_EQ(event.find(first.substr(first.find("frontier at"))), std::string::npos) << event;
  }
  // Facing the doorway, with every viewpoint within reach: nothing to turn to, no goal.
  looker.update(5.0, seen, {at(2.3, 2.0, 0.0, true)});
  EXPECT_FALSE(looker.goal_of(0).has_value());
  EXPECT_EQ(looker.reports()[0].status, "no reachable frontier left");
}

// With viewpoints on, a robot that reaches its goal facing away from the frontier (it drove there
// backwards round an obstacle, say) turns to the frontier before it takes another goal.
TEST(MissionPlanner, ARobotThatReachesItsGoalFacingAwayTurnsToItsFrontier) {
  const core::PointCloud seen = doorway_and_strip();
  MissionConfig m;
  m.kind = MissionKind::kExplore;
  m.explore_goal_clearance_m = 0.7;
  m.explore_view_search_m = 2.5;
  MissionPlanner mission(m, planning(planners::UnknownCells::kOccupied), {MissionRobot{"a", true, {}}});
  mission.update(0.5, seen, {at(1.0, 2.0)});
  ASSERT_TRUE(mission.goal_of(0).has_value());
  const Eigen::Vector2d goal = *mission.goal_of(0);
  const std::vector<PathCommand> commands = mission.update(4.0, seen, {at(goal.x(), goal.y(), M_PI, true)});
  EXPECT_FALSE(mission.goal_of(0).has_value());
  const std::vector<std::string>& events = mission.reports()[0].events;
  ASSERT_EQ(events.size(), 3u) << events.back();
  EXPECT_NE(events[1].find("reached"), std::string::npos) << events[1];
  EXPECT_NE(events[2].find("turns to look at the frontier"), std::string::npos) << events[2];
  const PathCommand* turn = command_for(commands, 0);
  ASSERT_NE(turn, nullptr);
  ASSERT_EQ(turn->path_world.size(), 1u) << "the turn, not a plan to another goal";
  EXPECT_GT(turn->path_world[0].x(), goal.x());
  // Busy while it turns: no goal, no command.
  EXPECT_EQ(command_for(mission.update(5.0, seen, {at(goal.x(), goal.y(), M_PI / 2.0, false)}), 0), nullptr);
  EXPECT_FALSE(mission.goal_of(0).has_value());
}

// Beyond the doorway the camera saw a wide patch of floor, cut off from the robot by unseen floor: goals
// on it cannot be reached. With viewpoints on, a frontier goal must be reachable, so the patch's frontier
// gets a viewpoint instead, where the robot already stands in front of the doorway: facing away, it
// turns to look. Without viewpoints nothing is left for it.
TEST(MissionPlanner, WithViewpointsAFrontierCutOffFromTheRobotIsLookedAt) {
  core::PointCloud seen = west_room_with_doorway();
  add_floor(seen, 4.3, 0.8, 5.9, 3.2);  // the patch: room to stand, nothing leading there
  MissionConfig m;
  m.kind = MissionKind::kExplore;
  m.explore_goal_clearance_m = 0.7;
  for (const double view_search_m : {0.0, 2.5}) {
    m.explore_view_search_m = view_search_m;
    MissionPlanner mission(m, planning(planners::UnknownCells::kOccupied), {MissionRobot{"a", true, {}}});
    const std::vector<PathCommand> commands = mission.update(0.5, seen, {at(2.3, 2.0, M_PI)});
    EXPECT_FALSE(mission.goal_of(0).has_value());
    ASSERT_FALSE(mission.reports()[0].events.empty());
    const std::string& event = mission.reports()[0].events.back();
    if (view_search_m == 0.0) {
      EXPECT_NE(event.find("no reachable frontier left"), std::string::npos) << event;
      continue;
    }
    const std::string prefix = "turns to look at the frontier at (";
    ASSERT_NE(event.find(prefix), std::string::npos) << event;
    EXPECT_GT(std::stod(event.substr(event.find(prefix) + prefix.size())), 4.2) << "a frontier of the patch: " << event;
    const PathCommand* step = command_for(commands, 0);
    ASSERT_NE(step, nullptr);
    EXPECT_GT(step->path_world.at(0).x(), 2.3) << "a step east, towards the patch";
  }
}

TEST(MissionPlanner, FloorARobotDroveOverIsFreeEvenWhereTheMapHasAnObstacle) {
  // Another robot's camera saw robot a standing at (1, 2): a box in the map there.
  core::PointCloud map = room(6.0, 4.0);
  add_box(map, 0.85, 1.85, 1.15, 2.15, 0.0, 0.4);
  MissionConfig m = waypoints_mission();
  MissionPlanner mission(m, planning(), {MissionRobot{"a", true, {{4.0, 2.0}}}});
  mission.update(0.5, map, {at(1.0, 2.0)});
  EXPECT_EQ(mission.grid().state(*mission.grid().cell_of({1.0, 2.0})), planners::CellState::kFree);
  // Without footprints the box stays.
  m.footprint_free_radius_m = 0.0;
  MissionPlanner no_footprint(m, planning(), {MissionRobot{"a", true, {{4.0, 2.0}}}});
  no_footprint.update(0.5, map, {at(1.0, 2.0)});
  EXPECT_EQ(no_footprint.grid().state(*no_footprint.grid().cell_of({1.0, 2.0})), planners::CellState::kOccupied);
}

// A free rig flies over things: its track does not clear the box under it, and where it hovers blocks
// no ground robot.
TEST(MissionPlanner, AFreeRigNeitherClearsFloorNorBlocksIt) {
  core::PointCloud map = room(6.0, 4.0);
  add_box(map, 0.85, 1.85, 1.15, 2.15, 0.0, 0.4);
  MissionPlanner mission(waypoints_mission(), planning(), {MissionRobot{"a", true, {{5.0, 1.0}}}, MissionRobot{"rig", false, {}}});
  const std::vector<PathCommand> commands = mission.update(0.5, map, {at(3.0, 1.0), at(1.0, 2.0)});
  EXPECT_EQ(mission.grid().state(*mission.grid().cell_of({1.0, 2.0})), planners::CellState::kOccupied);
  // The rig hovers at (4, 1), on a's straight way: a drives straight on.
  MissionPlanner hovering(waypoints_mission(), planning(), {MissionRobot{"a", true, {{5.0, 1.0}}}, MissionRobot{"rig", false, {}}});
  const std::vector<PathCommand> straight = hovering.update(0.5, map, {at(3.0, 1.0), at(4.0, 1.0)});
  const PathCommand* c = command_for(straight, 0);
  ASSERT_NE(c, nullptr);
  for (const Eigen::Vector2d& p : c->path_world) EXPECT_NEAR(p.y(), 1.0, 0.1);
}

// A robot whose map has not started has no pose: it is not a standing obstacle at the world origin.
TEST(MissionPlanner, ARobotWithoutAPoseIsNowhere) {
  const core::PointCloud map = core::transformed(room(6.0, 4.0), Eigen::Isometry3d(Eigen::Translation3d(-3.0, -2.0, 0.0)));
  PlanningConfig p = planning();
  p.grid.bounds_xy_m = {-3.5, -2.5, 3.5, 2.5};
  MissionPlanner mission(waypoints_mission(), p, {MissionRobot{"a", true, {{2.0, 0.0}}}, MissionRobot{"b", true, {{1.0, 1.0}}}});
  RobotObservation nowhere;  // no pose, not tracking, pose_world (0, 0, 0) by default
  const std::vector<PathCommand> commands = mission.update(0.5, map, {at(-2.0, 0.0), nowhere});
  const PathCommand* c = command_for(commands, 0);
  ASSERT_NE(c, nullptr);
  for (const Eigen::Vector2d& q : c->path_world) EXPECT_NEAR(q.y(), 0.0, 0.1);
  if (const PathCommand* b = command_for(commands, 1)) {
    EXPECT_TRUE(b->path_world.empty()) << "b has nowhere to start from";
  }
}

// Grids sized from the map never throw during a run: a point 1 km away would need more than max_cells
// (the last grid is kept), and one robot on an empty map with no margin is one cell, not empty bounds.
TEST(MissionPlanner, AGridSizedFromTheMapNeverThrows) {
  PlanningConfig p = planning();
  p.grid.bounds_xy_m.clear();
  MissionPlanner mission(waypoints_mission(), p, {MissionRobot{"a", true, {{4.0, 2.0}}}});
  const core::PointCloud map = room(6.0, 4.0);
  ASSERT_NO_THROW(mission.update(0.5, map, {at(1.0, 2.0)}));
  const int width = mission.grid().width();
  core::PointCloud far = map;
  far.points.push_back(Eigen::Vector3f(1000.0f, 1000.0f, 0.5f));
  ASSERT_NO_THROW(mission.update(1.0, far, {at(1.0, 2.0)}));
  EXPECT_EQ(mission.grid().width(), width) << "the last grid stays";
  p.grid.margin_m = 0.0;
  MissionPlanner bare(waypoints_mission(), p, {MissionRobot{"a", true, {}}});
  EXPECT_NO_THROW(bare.update(0.5, core::PointCloud{}, {at(1.0, 2.0)}));
}

TEST(MissionPlanner, BoxedInRobotIsReportedAndItsGoalGivenUp) {
  // Cartons all round robot a, 0.15 m from its centre (its radius is 0.2): no free cell for its centre
  // within reach. b carries on.
  core::PointCloud map = room(6.0, 4.0);
  add_box(map, 0.8, 0.8, 1.2, 0.85, 0.0, 0.5);
  add_box(map, 0.8, 1.15, 1.2, 1.2, 0.0, 0.5);
  add_box(map, 0.8, 0.8, 0.85, 1.2, 0.0, 0.5);
  add_box(map, 1.15, 0.8, 1.2, 1.2, 0.0, 0.5);
  MissionConfig m = waypoints_mission();
  m.footprint_free_radius_m = 0.0;
  m.start_snap_radius_m = 0.2;
  MissionPlanner mission(m, planning(), {MissionRobot{"a", true, {{4.0, 1.0}}}, MissionRobot{"b", true, {{4.0, 3.0}}}});
  for (int i = 0; i < m.max_plan_failures; ++i) {
    const std::vector<PathCommand> commands = mission.update(0.5 + i, map, {at(1.0, 1.0, 0.0, true), at(2.0, 3.0)});
    if (i == 0) {
      const PathCommand* b = command_for(commands, 1);
      ASSERT_NE(b, nullptr);
      EXPECT_FALSE(b->path_world.empty()) << "b plans as usual";
    }
  }
  EXPECT_EQ(mission.reports()[0].goals_given_up, 1);
  EXPECT_EQ(mission.reports()[0].plan_log.front().status, "start_invalid");
  EXPECT_NE(mission.reports()[0].events.back().find("given up: the robot is boxed in"), std::string::npos)
      << mission.reports()[0].events.back();
  EXPECT_EQ(mission.reports()[1].goals_given_up, 0);
}

}  // namespace
}  // namespace fleetslam::runner
