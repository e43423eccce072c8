// Deconflicter: two robots swapping ends of a corridor keep their separation over time; timing helpers.

#include <algorithm>
#include <limits>

#include <gtest/gtest.h>

#include "fleetslam/planners/deconfliction.hpp"
#include "synthetic_maps.hpp"

namespace fleetslam::planners {
namespace {

constexpr double kRadius = 0.2;

double min_separation_m(const std::vector<Pose2d>& a, const std::vector<Pose2d>& b, double speed) {
  const double end = std::max(path_duration_s(a, speed), path_duration_s(b, speed));
  double best = std::numeric_limits<double>::infinity();
  for (double t = 0.0; t <= end + 0.01; t += 0.01) {
    best = std::min(best, (position_at(a, speed, t, a.front().xy()) - position_at(b, speed, t, b.front().xy())).norm());
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
  EXPECT_DOUBLE_EQ(path_duration_s(path, 0.5), 6.0);
  EXPECT_TRUE(position_at(path, 0.5, 1.0, {9, 9}).isApprox(Eigen::Vector2d(0.5, 0.0)));
  EXPECT_TRUE(position_at(path, 0.5, 4.0, {9, 9}).isApprox(Eigen::Vector2d(1.0, 1.0)));
  EXPECT_TRUE(position_at(path, 0.5, 100.0, {9, 9}).isApprox(Eigen::Vector2d(1.0, 2.0)));
  EXPECT_TRUE(position_at(path, 0.5, -1.0, {9, 9}).isApprox(Eigen::Vector2d(0.0, 0.0)));
  EXPECT_TRUE(position_at({}, 0.5, 1.0, {9, 9}).isApprox(Eigen::Vector2d(9.0, 9.0)));
}

}  // namespace
}  // namespace fleetslam::planners
