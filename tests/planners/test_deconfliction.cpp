// Deconflicter: two robots swapping ends of a corridor keep their separation over time; a new path keeps
// clear of one a robot is already following; paths timed with their turns.

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "fleetslam/core/error.hpp"
#include "fleetslam/planners/deconfliction.hpp"
#include "synthetic_maps.hpp"

namespace fleetslam::planners {
namespace {

constexpr double kRadius = 0.2;

// The least distance between two robots driving their paths at `speed` (turns not timed).
double min_separation_m(const std::vector<Pose2d>& a, const std::vector<Pose2d>& b, double speed) {
  DeconflictionConfig c;
  c.speed_m_per_s = speed;
  const PathSchedule sa = schedule_path(a, 0.0, c);
  const PathSchedule sb = schedule_path(b, 0.0, c);
  const double end = std::max(sa.end_s(), sb.end_s());
  double best = std::numeric_limits<double>::infinity();
  for (double t = 0.0; t <= end + 0.01; t += 0.01) {
    best = std::min(best, (position_at(a, sa, t, a.front().xy()) - position_at(b, sb, t, b.front().xy())).norm());
  }
  return best;
}

TEST(Deconflicter, RobotsSwappingThroughACorridorKeepApart) {
  // A corridor 8 m long and 2 m wide; robot 1 starts where robot 2 ends and the other way round.
  const OccupancyGrid grid = test::make_grid(8.0, 2.0, [](const Eigen::Vector2d&) { return false; }, kRadius);
  const std::vector<RobotQuery> queries{{1, Pose2d{1.0, 1.0, 0.0}, {7.0, 1.0}}, {2, Pose2d{7.0, 1.0, 3.14}, {1.0, 1.0}}};
  DeconflictionConfig c;
  c.separation_m = 2.0 * kRadius + 0.1;
  PathPlannerConfig pc;
  pc.seed = 3;

  // Planned alone, the two meet head on.
  const PathPlanner planner(pc);
  const PlanResult alone1 = planner.plan(grid, queries[0].start_world, queries[0].goal_world);
  const PlanResult alone2 = planner.plan(grid, queries[1].start_world, queries[1].goal_world);
  ASSERT_TRUE(alone1.solved() && alone2.solved());
  EXPECT_LT(min_separation_m(alone1.path_world, alone2.path_world, c.speed_m_per_s), 2.0 * kRadius);

  const DeconflictionResult result = Deconflicter(c, pc).plan(grid, queries);
  ASSERT_EQ(result.plans.size(), 2u);
  ASSERT_TRUE(result.plans[0].solved());
  ASSERT_TRUE(result.plans[1].solved());
  EXPECT_TRUE(result.conflict_free());
  EXPECT_EQ(result.replans[0], 0);
  EXPECT_GE(result.replans[1], 1);
  EXPECT_GE(min_separation_m(result.plans[0].path_world, result.plans[1].path_world, c.speed_m_per_s),
            2.0 * kRadius);
  for (const PlanResult& p : result.plans) {
    EXPECT_EQ(first_blocked_pose(grid, p.path_world, UnknownCells::kOccupied), -1);
  }
}

TEST(Deconflicter, ANewPathKeepsClearOfACommittedOne) {
  // An open room 6 m square. Robot 1 is already driving along y = 3 from x = 0.5 to 5.5; robot 2 is
  // planned from (3, 0.5) to (3, 5.5), straight across robot 1's path when robot 1 gets there.
  const OccupancyGrid grid = test::make_grid(6.0, 6.0, [](const Eigen::Vector2d&) { return false; }, kRadius);
  std::vector<Pose2d> driving;
  for (double x = 0.5; x <= 5.5 + 1e-9; x += 0.25) driving.push_back(Pose2d{x, 3.0, 0.0});
  const std::vector<CommittedPath> committed{{1, driving, Eigen::Vector2d(0.5, 3.0)}};
  const std::vector<RobotQuery> queries{{2, Pose2d{3.0, 0.5, 1.57}, {3.0, 5.5}}};
  DeconflictionConfig c;
  c.separation_m = 2.0 * kRadius + 0.1;
  PathPlannerConfig pc;
  pc.seed = 5;

  // Without the committed path the straight crossing meets robot 1.
  const DeconflictionResult blind = Deconflicter(c, pc).plan(grid, queries);
  ASSERT_TRUE(blind.plans[0].solved());
  EXPECT_LT(min_separation_m(driving, blind.plans[0].path_world, c.speed_m_per_s), 2.0 * kRadius);

  const DeconflictionResult result = Deconflicter(c, pc).plan(grid, queries, committed);
  ASSERT_EQ(result.plans.size(), 1u);
  ASSERT_TRUE(result.plans[0].solved());
  EXPECT_TRUE(result.conflict_free());
  EXPECT_GE(result.replans[0], 1);
  EXPECT_GE(min_separation_m(driving, result.plans[0].path_world, c.speed_m_per_s), 2.0 * kRadius);
  EXPECT_EQ(first_blocked_pose(grid, result.plans[0].path_world, UnknownCells::kOccupied), -1);
}

TEST(Deconflicter, AConflictWithACommittedPathNamesItsRobot) {
  // The committed robot drives through the query robot's goal, which it cannot avoid: reported.
  const OccupancyGrid grid = test::make_grid(6.0, 6.0, [](const Eigen::Vector2d&) { return false; }, kRadius);
  std::vector<Pose2d> driving;
  for (double x = 0.5; x <= 5.5 + 1e-9; x += 0.25) driving.push_back(Pose2d{x, 3.0, 0.0});
  // A goal 1.5 m down robot 1's path: reached as robot 1 passes at nominal speed.
  const std::vector<RobotQuery> queries{{7, Pose2d{2.0, 2.5, 0.0}, {2.0, 3.0}}};
  DeconflictionConfig c;
  c.separation_m = 2.0 * kRadius + 0.1;
  c.max_replans = 2;
  PathPlannerConfig pc;
  pc.seed = 5;
  const DeconflictionResult result =
      Deconflicter(c, pc).plan(grid, queries, {{4, driving, Eigen::Vector2d(0.5, 3.0)}});
  ASSERT_EQ(result.conflicts.size(), 1u);
  EXPECT_EQ(result.conflicts[0].robot_a, 4);
  EXPECT_EQ(result.conflicts[0].robot_b, 7);
}

TEST(Deconflicter, UnresolvableConflictIsReported) {
  // A corridor too narrow to pass: the lower-priority robot cannot get by and the conflict is reported.
  const OccupancyGrid grid = test::make_grid(8.0, 0.8, [](const Eigen::Vector2d&) { return false; }, kRadius);
  const std::vector<RobotQuery> queries{{1, Pose2d{1.0, 0.4, 0.0}, {7.0, 0.4}}, {2, Pose2d{7.0, 0.4, 3.14}, {1.0, 0.4}}};
  DeconflictionConfig c;
  c.separation_m = 2.0 * kRadius + 0.1;
  c.max_replans = 2;
  const DeconflictionResult result = Deconflicter(c, PathPlannerConfig{}).plan(grid, queries);
  ASSERT_EQ(result.conflicts.size(), 1u);
  EXPECT_EQ(result.conflicts[0].robot_a, 1);
  EXPECT_EQ(result.conflicts[0].robot_b, 2);
  EXPECT_LT(result.conflicts[0].distance_m, c.separation_m);
}

TEST(Deconflicter, TimingAlongAPath) {
  const std::vector<Pose2d> path{{0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}, {1.0, 2.0, 1.57}};
  DeconflictionConfig c;  // 0.5 m/s, turns not timed
  const PathSchedule s = schedule_path(path, M_PI, c);
  EXPECT_DOUBLE_EQ(s.end_s(), 6.0);
  EXPECT_TRUE(position_at(path, s, 1.0, {9, 9}).isApprox(Eigen::Vector2d(0.5, 0.0)));
  EXPECT_TRUE(position_at(path, s, 4.0, {9, 9}).isApprox(Eigen::Vector2d(1.0, 1.0)));
  EXPECT_TRUE(position_at(path, s, 100.0, {9, 9}).isApprox(Eigen::Vector2d(1.0, 2.0)));
  EXPECT_TRUE(position_at(path, s, -1.0, {9, 9}).isApprox(Eigen::Vector2d(0.0, 0.0)));
  EXPECT_TRUE(position_at({}, schedule_path({}, 0.0, c), 1.0, {9, 9}).isApprox(Eigen::Vector2d(9.0, 9.0)));
  EXPECT_THROW(position_at(path, schedule_path({path[0]}, 0.0, c), 1.0, {9, 9}), InvariantError);
}

// Turns are timed as the controller drives them: beyond turn_on_spot_deg on the spot, at the start and at
// corners; a smaller heading change is driven through, its segment no faster than the yaw rate allows.
TEST(Deconflicter, TurnsAreTimedOnTheSpotOrDrivenThrough) {
  DeconflictionConfig c;
  c.speed_m_per_s = 0.5;
  c.yaw_rate_radps = M_PI / 4.0;  // 90 degrees in 2 s
  c.turn_on_spot_deg = 60.0;
  // East 1 m (a zero-length segment first), then north 2 m: a 90-degree corner at (1, 0).
  const std::vector<Pose2d> corner{{0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}, {1.0, 2.0, 0.0}};
  PathSchedule s = schedule_path(corner, 0.0, c);  // facing along the path
  EXPECT_NEAR(s.depart_s[0], 0.0, 1e-12);
  EXPECT_NEAR(s.arrive_s[2], 2.0, 1e-12);
  EXPECT_NEAR(s.depart_s[2], 4.0, 1e-12);  // turns on the spot at the corner
  EXPECT_NEAR(s.end_s(), 8.0, 1e-12);
  EXPECT_TRUE(position_at(corner, s, 3.0, {9, 9}).isApprox(Eigen::Vector2d(1.0, 0.0)));
  EXPECT_TRUE(position_at(corner, s, 6.0, {9, 9}).isApprox(Eigen::Vector2d(1.0, 1.0)));
  // Facing west: half a turn on the spot first (4 s), angles wrapped (3 pi is pi).
  s = schedule_path(corner, 3.0 * M_PI, c);
  EXPECT_NEAR(s.depart_s[1], 4.0, 1e-12);
  EXPECT_NEAR(s.end_s(), 12.0, 1e-12);
  // A start yaw that is no angle times no start turn.
  EXPECT_NEAR(schedule_path(corner, std::nan(""), c).end_s(), 8.0, 1e-12);
  // With on-the-spot turns only beyond 120 degrees the corner is driven through: the 2 m north take
  // max(2 m / 0.5 m/s, 90 deg / 45 deg/s) = 4 s, and a 30-degree bend is no slower than driving.
  c.turn_on_spot_deg = 120.0;
  s = schedule_path(corner, 0.0, c);
  EXPECT_NEAR(s.depart_s[2], 2.0, 1e-12);
  EXPECT_NEAR(s.end_s(), 6.0, 1e-12);
  const std::vector<Pose2d> sharp{{0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}, {1.0, 0.1, 0.0}};  // 0.1 m after the corner
  EXPECT_NEAR(schedule_path(sharp, 0.0, c).end_s(), 2.0 + 2.0, 1e-12);  // the turn, not the 0.2 s of driving
  // Turns untimed without a yaw rate.
  c.yaw_rate_radps = 0.0;
  EXPECT_NEAR(schedule_path(corner, M_PI, c).end_s(), 6.0, 1e-12);
}

// A robot that must first turn around starts along its path later: the schedule that ignored the turn
// had it pass a crossing long before the committed robot got there, while it really arrives with it.
TEST(Deconflicter, TheStartTurnDelaysTheSchedule) {
  const OccupancyGrid grid = test::make_grid(10.0, 4.0, [](const Eigen::Vector2d&) { return false; }, kRadius);
  // Robot 1 drives west along y = 0.5 from x = 9 to 5 (8 s at 0.5 m/s), then north: untimed turns put it
  // at (5, 2) at t = 11 s; its corner turned on the spot at pi/5 rad/s (2.5 s), at t = 13.5 s.
  std::vector<Pose2d> driving;
  for (double x = 9.0; x > 5.0 + 1e-9; x -= 0.25) driving.push_back(Pose2d{x, 0.5, M_PI});
  for (double y = 0.5; y <= 3.5 + 1e-9; y += 0.25) driving.push_back(Pose2d{5.0, y, M_PI / 2.0});
  const std::vector<CommittedPath> committed{{1, driving, Eigen::Vector2d(9.0, 0.5)}};
  // Robot 2 crosses x = 5 on y = 2 going east, 9 s after it starts along its path; it faces west.
  const std::vector<RobotQuery> queries{{2, Pose2d{0.5, 2.0, M_PI}, {8.0, 2.0}}};
  DeconflictionConfig c;
  c.separation_m = 2.0 * kRadius + 0.1;
  PathPlannerConfig pc;
  pc.seed = 5;
  const DeconflictionResult untimed = Deconflicter(c, pc).plan(grid, queries, committed);
  ASSERT_TRUE(untimed.plans[0].solved());
  EXPECT_TRUE(untimed.conflict_free());
  EXPECT_EQ(untimed.replans[0], 0);
  c.yaw_rate_radps = M_PI / 5.0;  // half a turn in 5 s: at x = 5 at t = 14 s, as robot 1 passes y = 2
  const DeconflictionResult turning = Deconflicter(c, pc).plan(grid, queries, committed);
  EXPECT_GE(turning.replans[0], 1);
  // Facing its path, the robot needs no turn: it crosses at t = 9 s, while robot 1 turns at its corner.
  const DeconflictionResult facing = Deconflicter(c, pc).plan(grid, {{2, Pose2d{0.5, 2.0, 0.0}, {8.0, 2.0}}}, committed);
  EXPECT_EQ(facing.replans[0], 0);
  EXPECT_TRUE(facing.conflict_free());
}

// A config built in code is checked like one read from YAML: a zero speed or time step never ended the
// conflict scan, and a NaN one skipped it.
TEST(Deconflicter, BadConfigIsAnInputErrorNamingTheKey) {
  const auto error_of = [](const DeconflictionConfig& c) -> std::string {
    try {
      Deconflicter d(c, PathPlannerConfig{});
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(error_of(DeconflictionConfig{}), "");
  DeconflictionConfig c;
  c.speed_m_per_s = 0.0;
  EXPECT_NE(error_of(c).find("deconfliction.speed_m_per_s"), std::string::npos);
  c = DeconflictionConfig{};
  c.time_step_s = 0.0;
  EXPECT_NE(error_of(c).find("deconfliction.time_step_s"), std::string::npos);
  c = DeconflictionConfig{};
  c.time_margin_s = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(error_of(c).find("deconfliction.time_margin_s"), std::string::npos);
  c = DeconflictionConfig{};
  c.turn_on_spot_deg = 200.0;
  EXPECT_NE(error_of(c).find("deconfliction.turn_on_spot_deg"), std::string::npos);
  c = DeconflictionConfig{};
  c.max_replans = -1;
  EXPECT_NE(error_of(c).find("deconfliction.max_replans"), std::string::npos);
}

}  // namespace
}  // namespace fleetslam::planners
