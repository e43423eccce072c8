// GoalAssigner: distinct goals, nearest first, separation penalty, unreachable goals, determinism.

#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "fleetslam/core/error.hpp"
#include "fleetslam/planners/goal_assignment.hpp"
#include "synthetic_maps.hpp"

namespace fleetslam::planners {
namespace {

TEST(GoalAssigner, DistinctGoalsNearestFirst) {
  GoalAssignmentConfig c;
  c.cost = AssignmentCost::kStraightLine;
  c.separation_penalty_m = 0.0;
  const GoalAssigner assigner(c);
  const std::vector<Eigen::Vector2d> robots{{0.0, 0.0}, {0.5, 0.0}, {10.0, 0.0}};
  const std::vector<Eigen::Vector2d> goals{{1.0, 0.0}, {9.0, 0.0}, {1.2, 0.5}, {20.0, 0.0}};
  const GoalAssignment a = assigner.assign(robots, goals);
  ASSERT_EQ(a.goal_of_robot.size(), 3u);
  EXPECT_EQ(a.goal_of_robot[1], 0);  // 0.5 m: the cheapest pair
  EXPECT_EQ(a.goal_of_robot[2], 1);
  EXPECT_EQ(a.goal_of_robot[0], 2);
  EXPECT_EQ(std::set<int>(a.goal_of_robot.begin(), a.goal_of_robot.end()).size(), 3u);
  // Fewer goals than robots: the rest get none. Same input, same answer.
  const GoalAssignment b = assigner.assign(robots, {{1.0, 0.0}});
  EXPECT_EQ(b.goal_of_robot, (std::vector<int>{-1, 0, -1}));
  EXPECT_EQ(assigner.assign(robots, goals).goal_of_robot, a.goal_of_robot);
}

TEST(GoalAssigner, PenaltySpreadsRobotsOverFrontiers) {
  // Two robots side by side; two goals close together ahead and one farther away on the left.
  const std::vector<Eigen::Vector2d> robots{{0.0, 0.0}, {0.0, 0.4}};
  const std::vector<Eigen::Vector2d> goals{{3.0, 0.0}, {3.0, 0.5}, {0.0, 4.5}};
  GoalAssignmentConfig c;
  c.cost = AssignmentCost::kStraightLine;
  c.separation_penalty_m = 0.0;
  const GoalAssignment near = GoalAssigner(c).assign(robots, goals);
  EXPECT_EQ(near.goal_of_robot, (std::vector<int>{0, 1}));
  c.separation_penalty_m = 5.0;
  c.separation_m = 2.0;
  const GoalAssignment spread = GoalAssigner(c).assign(robots, goals);
  EXPECT_EQ(spread.goal_of_robot, (std::vector<int>{0, 2}));
}

// Two goals at one spot (two frontiers snapped to one cell): never given to two robots, whatever the
// penalty; same_goal_m widens "one spot". A config set in code is checked against its limits.
TEST(GoalAssigner, OneSpotIsNeverGivenToTwoRobots) {
  const std::vector<Eigen::Vector2d> robots{{0.0, 0.0}, {0.0, 0.4}};
  GoalAssignmentConfig c;
  c.cost = AssignmentCost::kStraightLine;
  c.separation_penalty_m = 0.0;
  // Robot 1 takes (3, 0.4); the copy of it would be robot 0's cheapest (3.03 m against 3.16 m).
  EXPECT_EQ(GoalAssigner(c).assign(robots, {{3.0, 0.4}, {3.0, 0.4}, {3.0, -1.0}}).goal_of_robot,
            (std::vector<int>{2, 0}));
  const std::vector<Eigen::Vector2d> close{{3.0, 0.4}, {3.0, 0.3}, {3.0, -1.0}};
  EXPECT_EQ(GoalAssigner(c).assign(robots, close).goal_of_robot, (std::vector<int>{1, 0}));
  c.same_goal_m = 0.15;  // 10 cm apart is one spot now
  EXPECT_EQ(GoalAssigner(c).assign(robots, close).goal_of_robot, (std::vector<int>{2, 0}));
  c.same_goal_m = -1.0;
  EXPECT_THROW(GoalAssigner{c}, InputError);
}

// With a gain weight, a goal that shows more unknown floor is worth its longer trip; without one, or
// without gains, the nearest goal wins. Gains that do not fit the goals are input errors.
TEST(GoalAssigner, GainsWeighAgainstTravel) {
  const std::vector<Eigen::Vector2d> robots{{0.0, 0.0}};
  const std::vector<Eigen::Vector2d> goals{{1.0, 0.0}, {4.0, 0.0}};
  const std::vector<double> gains_m2{0.2, 4.0};
  GoalAssignmentConfig c;
  c.cost = AssignmentCost::kStraightLine;
  EXPECT_EQ(GoalAssigner(c).assign(robots, goals, nullptr, gains_m2).goal_of_robot, (std::vector<int>{0}));
  c.gain_weight_m_per_m2 = 1.0;  // 1 - 0.2 against 4 - 4
  const GoalAssignment a = GoalAssigner(c).assign(robots, goals, nullptr, gains_m2);
  EXPECT_EQ(a.goal_of_robot, (std::vector<int>{1}));
  EXPECT_DOUBLE_EQ(a.cost_m[0], 4.0) << "the reported cost is the travel";
  EXPECT_EQ(GoalAssigner(c).assign(robots, goals).goal_of_robot, (std::vector<int>{0}));
  c.gain_weight_m_per_m2 = 0.5;  // 1 - 0.1 against 4 - 2
  EXPECT_EQ(GoalAssigner(c).assign(robots, goals, nullptr, gains_m2).goal_of_robot, (std::vector<int>{0}));
  EXPECT_THROW(GoalAssigner(c).assign(robots, goals, nullptr, {1.0}), InputError);
  EXPECT_THROW(GoalAssigner(c).assign(robots, goals, nullptr, {1.0, -1.0}), InputError);
  EXPECT_THROW(GoalAssigner(c).assign(robots, goals, nullptr, {1.0, std::nan("")}), InputError);
}

TEST(GoalAssigner, GridPathCostAndFrontierGoals) {
  // A wall between the robot's side and goal 0 (reachable only around it), goal 1 boxed in.
  const OccupancyGrid grid = test::make_grid(6.0, 4.0, [](const Eigen::Vector2d& c) {
    const bool wall = c.x() > 2.9 && c.x() < 3.1 && c.y() < 3.0;
    const bool box = (c - Eigen::Vector2d(5.0, 3.0)).cwiseAbs().maxCoeff() < 0.6 &&
                     (c - Eigen::Vector2d(5.0, 3.0)).cwiseAbs().maxCoeff() > 0.5;
    return wall || box;
  });
  GoalAssignmentConfig c;
  const GoalAssignment a = GoalAssigner(c).assign({{1.0, 1.0}}, {{5.0, 1.0}, {5.0, 3.0}}, &grid);
  EXPECT_EQ(a.goal_of_robot, (std::vector<int>{0}));
  EXPECT_GT(a.cost_m[0], 5.5);  // around the wall, not the 4 m straight line
  const GoalAssignment none = GoalAssigner(c).assign({{1.0, 1.0}}, {{5.0, 3.0}}, &grid);
  EXPECT_EQ(none.goal_of_robot, (std::vector<int>{-1}));
  EXPECT_THROW(GoalAssigner(c).assign({{1.0, 1.0}}, {{5.0, 1.0}}, nullptr), InputError);

  Frontier with_goal;
  with_goal.has_goal = true;
  with_goal.goal_world = {1.0, 2.0};
  EXPECT_EQ(frontier_goals({Frontier{}, with_goal}).size(), 1u);
}

}  // namespace
}  // namespace fleetslam::planners
