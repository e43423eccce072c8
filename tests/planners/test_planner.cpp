// PathPlanner: paths around obstacles for every algorithm and state space, no path through a closed
// wall, invalid start and goal, clearance of the returned path, repeatability with a seed, config.

#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/planners/planner.hpp"
#include "synthetic_maps.hpp"

namespace fleetslam::planners {
namespace {

using test::make_grid;

// A 6 x 4 m room with a wall at x in [2.9, 3.1] from y = 0 up to y = wall_top_m (4: closed).
OccupancyGrid wall_room(double wall_top_m) {
  return make_grid(6.0, 4.0, [wall_top_m](const Eigen::Vector2d& c) {
    return c.x() > 2.9 && c.x() < 3.1 && c.y() < wall_top_m;
  });
}

struct Case {
  PlannerAlgorithm planner;
  StateSpaceKind space;
  std::string name;
};

class PlannerCases : public ::testing::TestWithParam<Case> {
 protected:
  PathPlannerConfig config() const {
    PathPlannerConfig c;
    c.planner = GetParam().planner;
    c.state_space = GetParam().space;
    c.max_iterations = 5000;
    return c;
  }
};

TEST_P(PlannerCases, FindsAPathAroundAWallClearOfInflatedObstacles) {
  const OccupancyGrid grid = wall_room(3.0);  // gap at y in [3, 4] (0.8 m after inflation)
  const PathPlanner planner(config());
  const PlanResult result = planner.plan(grid, Pose2d{1.0, 1.0, 0.0}, Eigen::Vector2d(5.0, 1.0));
  ASSERT_EQ(result.status, PlanStatus::kSolved) << to_string(result.status);
  ASSERT_GE(result.path_world.size(), 2u);
  EXPECT_NEAR(result.path_world.front().x_m, 1.0, 1e-9);
  EXPECT_NEAR(result.path_world.front().y_m, 1.0, 1e-9);
  EXPECT_LE((result.path_world.back().xy() - Eigen::Vector2d(5.0, 1.0)).norm(), 0.1 + 1e-9);
  EXPECT_LE(result.distance_to_goal_m, 0.1 + 1e-9);
  // Over the wall's top: the path goes through the gap, and is much longer than the straight line.
  double max_y = 0.0;
  for (const Pose2d& p : result.path_world) max_y = std::max(max_y, p.y_m);
  EXPECT_GT(max_y, 3.0 + 0.2 - 0.05);
  EXPECT_GT(result.length_m, 5.5);  // about 2 x hypot(1.7, 2.2) over the wall's inflated top
  // Every pose and every point between poses clear of the inflated obstacles; poses evenly spaced.
  EXPECT_EQ(first_blocked_pose(grid, result.path_world, UnknownCells::kOccupied), -1);
  for (std::size_t i = 1; i < result.path_world.size(); ++i) {
    // SE(2): exactly path_step_m or less; curves: the first dense state past path_step_m.
    EXPECT_LE((result.path_world[i].xy() - result.path_world[i - 1].xy()).norm(), 0.065);
  }
}

TEST_P(PlannerCases, NoPathThroughAClosedWall) {
  const OccupancyGrid grid = wall_room(4.0);
  PathPlannerConfig c = config();
  const PlanResult result = PathPlanner(c).plan(grid, Pose2d{1.0, 1.0, 0.0}, Eigen::Vector2d(5.0, 1.0));
  EXPECT_EQ(result.status, PlanStatus::kNoPath);
  EXPECT_TRUE(result.path_world.empty());
  EXPECT_EQ(result.iterations, 0);  // the flood fill answered

  // Without the flood fill the sampler runs out of iterations; whatever it returns stays west of the wall.
  c.check_reachability = false;
  c.max_iterations = 1500;
  const PlanResult sampled = PathPlanner(c).plan(grid, Pose2d{1.0, 1.0, 0.0}, Eigen::Vector2d(5.0, 1.0));
  EXPECT_NE(sampled.status, PlanStatus::kSolved);
  for (const Pose2d& p : sampled.path_world) EXPECT_LT(p.x_m, 2.9);
  if (!sampled.path_world.empty()) {
    EXPECT_NEAR(sampled.path_world.front().x_m, 1.0, 1e-9);
  }
}

INSTANTIATE_TEST_SUITE_P(
    AllPlanners, PlannerCases,
    ::testing::Values(Case{PlannerAlgorithm::kRrtConnect, StateSpaceKind::kSe2, "rrt_connect_se2"},
                      Case{PlannerAlgorithm::kRrtStar, StateSpaceKind::kSe2, "rrt_star_se2"},
                      Case{PlannerAlgorithm::kPrmStar, StateSpaceKind::kSe2, "prm_star_se2"},
                      Case{PlannerAlgorithm::kRrtConnect, StateSpaceKind::kDubins, "rrt_connect_dubins"},
                      Case{PlannerAlgorithm::kRrtConnect, StateSpaceKind::kReedsShepp, "rrt_connect_reeds_shepp"}),
    [](const ::testing::TestParamInfo<Case>& case_info) { return case_info.param.name; });

// A robot facing -x has a yaw of pi (atan2 gives it): any heading, wrapped or not, is a valid start.
TEST(PathPlanner, AnyStartHeadingIsValid) {
  const OccupancyGrid grid = make_grid(6.0, 4.0, [](const Eigen::Vector2d&) { return false; });
  const PathPlanner planner{PathPlannerConfig{}};
  for (const double yaw : {M_PI, -M_PI, 3.0 * M_PI, 2.0 * M_PI, -2.5 * M_PI, 0.5}) {
    const PlanResult result = planner.plan(grid, Pose2d{5.0, 2.0, yaw}, {1.0, 2.0});
    EXPECT_EQ(result.status, PlanStatus::kSolved) << "yaw " << yaw;
  }
}

TEST(PathPlanner, StartAndGoalValidity) {
  const OccupancyGrid grid = make_grid(4.0, 4.0, [](const Eigen::Vector2d& c) {
    return (c - Eigen::Vector2d(2.0, 2.0)).cwiseAbs().maxCoeff() < 0.3;  // a 0.6 m box in the middle
  });
  const PathPlanner planner{PathPlannerConfig{}};
  EXPECT_EQ(planner.plan(grid, Pose2d{2.0, 2.0, 0.0}, {1.0, 1.0}).status, PlanStatus::kStartInvalid);  // in the box
  EXPECT_EQ(planner.plan(grid, Pose2d{2.0, 1.55, 0.0}, {1.0, 1.0}).status, PlanStatus::kStartInvalid);  // inflation
  EXPECT_EQ(planner.plan(grid, Pose2d{9.0, 1.0, 0.0}, {1.0, 1.0}).status, PlanStatus::kStartInvalid);  // outside
  EXPECT_EQ(planner.plan(grid, Pose2d{1.0, 1.0, std::nan("")}, {3.0, 3.0}).status, PlanStatus::kStartInvalid);
  EXPECT_EQ(planner.plan(grid, Pose2d{1.0, 1.0, 0.0}, {2.1, 2.0}).status, PlanStatus::kGoalInvalid);
  EXPECT_EQ(planner.plan(grid, Pose2d{1.0, 1.0, 0.0}, {0.1, 3.0}).status, PlanStatus::kGoalInvalid);  // by a wall
  EXPECT_EQ(planner.plan(grid, Pose2d{1.0, 1.0, 0.0}, {1.0, -3.0}).status, PlanStatus::kGoalInvalid);

  PathPlannerConfig snap;
  snap.goal_snap_radius_m = 0.6;
  const PlanResult snapped = PathPlanner(snap).plan(grid, Pose2d{1.0, 1.0, 0.0}, {2.1, 2.0});
  ASSERT_EQ(snapped.status, PlanStatus::kSolved);
  EXPECT_TRUE(grid.traversable(snapped.goal_world, UnknownCells::kOccupied));
  EXPECT_LE((snapped.goal_world - Eigen::Vector2d(2.1, 2.0)).norm(), 0.6);
  EXPECT_GE((snapped.goal_world - Eigen::Vector2d(2.0, 2.0)).cwiseAbs().maxCoeff(), 0.3 + 0.2 - 0.05);
}

TEST(PathPlanner, BlockedDisksAreAvoided) {
  const OccupancyGrid grid = make_grid(6.0, 3.0, [](const Eigen::Vector2d&) { return false; });
  const std::vector<Disk> blocked{Disk{{3.0, 1.5}, 0.8}};
  const PlanResult result = PathPlanner{PathPlannerConfig{}}.plan(grid, Pose2d{1.0, 1.5, 0.0}, {5.0, 1.5}, blocked);
  ASSERT_EQ(result.status, PlanStatus::kSolved);
  EXPECT_EQ(first_blocked_pose(grid, result.path_world, UnknownCells::kOccupied, blocked), -1);
  for (const Pose2d& p : result.path_world) EXPECT_GE((p.xy() - Eigen::Vector2d(3.0, 1.5)).norm(), 0.8);
  // A disk across the whole room closes it.
  const std::vector<Disk> wall{Disk{{3.0, 1.5}, 2.0}};
  EXPECT_EQ(PathPlanner{PathPlannerConfig{}}.plan(grid, Pose2d{0.6, 1.5, 0.0}, {5.4, 1.5}, wall).status,
            PlanStatus::kNoPath);
  // A path found before the disk appeared is reported blocked where it enters it.
  const PlanResult free_path = PathPlanner{PathPlannerConfig{}}.plan(grid, Pose2d{1.0, 1.5, 0.0}, {5.0, 1.5});
  ASSERT_EQ(free_path.status, PlanStatus::kSolved);
  const int blocked_at = first_blocked_pose(grid, free_path.path_world, UnknownCells::kOccupied, blocked);
  ASSERT_GE(blocked_at, 0);
  EXPECT_NEAR((free_path.path_world[static_cast<std::size_t>(blocked_at)].xy() - Eigen::Vector2d(3.0, 1.5)).norm(),
              0.8, 0.06);
}

TEST(PathPlanner, UnknownCellsByConfig) {
  // The east half is unknown.
  OccupancyGridConfig gc = test::grid_config(0.2);
  OccupancyGrid grid(gc);
  std::vector<CellState> cells(120 * 60, CellState::kFree);
  for (int y = 0; y < 60; ++y) {
    for (int x = 60; x < 120; ++x) cells[static_cast<std::size_t>(y * 120 + x)] = CellState::kUnknown;
  }
  grid.set_cells({0.0, 0.0}, 120, 60, cells);
  PathPlannerConfig c;
  c.unknown_cells = UnknownCells::kOccupied;
  EXPECT_EQ(PathPlanner(c).plan(grid, Pose2d{1.0, 1.5, 0.0}, {5.0, 1.5}).status, PlanStatus::kGoalInvalid);
  c.unknown_cells = UnknownCells::kFree;
  EXPECT_EQ(PathPlanner(c).plan(grid, Pose2d{1.0, 1.5, 0.0}, {5.0, 1.5}).status, PlanStatus::kSolved);
}

TEST(PathPlanner, SameSeedGivesTheSamePath) {
  const OccupancyGrid grid = wall_room(3.0);
  for (PlannerAlgorithm algorithm : {PlannerAlgorithm::kRrtConnect, PlannerAlgorithm::kRrtStar}) {
    PathPlannerConfig c;
    c.planner = algorithm;
    c.max_iterations = 3000;
    c.seed = 42;
    const PathPlanner planner(c);
    const PlanResult a = planner.plan(grid, Pose2d{1.0, 1.0, 0.3}, {5.0, 1.0});
    // Another plan with another seed in between must not disturb the next one.
    PathPlannerConfig other = c;
    other.seed = 7;
    const PlanResult between = PathPlanner(other).plan(grid, Pose2d{1.0, 1.0, 0.3}, {5.0, 1.0});
    const PlanResult b = planner.plan(grid, Pose2d{1.0, 1.0, 0.3}, {5.0, 1.0});
    ASSERT_EQ(a.status, PlanStatus::kSolved);
    ASSERT_EQ(between.status, PlanStatus::kSolved);
    ASSERT_EQ(a.path_world.size(), b.path_world.size());
    for (std::size_t i = 0; i < a.path_world.size(); ++i) {
      EXPECT_EQ(a.path_world[i].x_m, b.path_world[i].x_m);
      EXPECT_EQ(a.path_world[i].y_m, b.path_world[i].y_m);
      EXPECT_EQ(a.path_world[i].yaw_rad, b.path_world[i].yaw_rad);
    }
    EXPECT_EQ(a.length_m, b.length_m);
    EXPECT_EQ(a.iterations, b.iterations);
  }
}

TEST(PathPlanner, SimplificationShortensThePath) {
  const OccupancyGrid grid = wall_room(3.0);
  PathPlannerConfig c;
  c.simplify = false;
  const PlanResult raw = PathPlanner(c).plan(grid, Pose2d{1.0, 1.0, 0.0}, {5.0, 1.0});
  c.simplify = true;
  const PlanResult simplified = PathPlanner(c).plan(grid, Pose2d{1.0, 1.0, 0.0}, {5.0, 1.0});
  ASSERT_EQ(raw.status, PlanStatus::kSolved);
  ASSERT_EQ(simplified.status, PlanStatus::kSolved);
  EXPECT_LE(simplified.length_m, raw.length_m + 1e-9);
  // The shortest way is about 2 + 2.2 (up and over the wall's top at y = 3.2) + 2.2 + 2: < 9.5 m.
  EXPECT_LT(simplified.length_m, 9.5);
}

// A wall at x in [2.9, 3.1] with a 1 m doorway (y in [1.5, 2.5]), start and goal below it: the shortest
// path grazes the lower jamb's inflation; with preferred_clearance_m it crosses near the doorway's middle,
// clear of both jambs, and ends where it did.
TEST(PathPlanner, APreferredClearanceCentresThePathInADoorway) {
  const OccupancyGrid grid = make_grid(6.0, 4.0, [](const Eigen::Vector2d& c) {
    return c.x() > 2.9 && c.x() < 3.1 && (c.y() < 1.5 || c.y() > 2.5);
  });
  const auto crossing_y = [](const PlanResult& r) {
    for (std::size_t i = 1; i < r.path_world.size(); ++i) {
      const Pose2d& a = r.path_world[i - 1];
      const Pose2d& b = r.path_world[i];
      if ((a.x_m - 3.0) * (b.x_m - 3.0) <= 0.0 && a.x_m != b.x_m) return a.y_m + (b.y_m - a.y_m) * (3.0 - a.x_m) / (b.x_m - a.x_m);
    }
    return -1.0;
  };
  PathPlannerConfig c;
  const PlanResult tight = PathPlanner(c).plan(grid, Pose2d{1.0, 0.6, 0.0}, {5.0, 0.6});
  c.preferred_clearance_m = 0.45;
  const PlanResult clear = PathPlanner(c).plan(grid, Pose2d{1.0, 0.6, 0.0}, {5.0, 0.6});
  ASSERT_EQ(tight.status, PlanStatus::kSolved);
  ASSERT_EQ(clear.status, PlanStatus::kSolved);
  EXPECT_LT(crossing_y(tight), 1.8) << "the shortest way hugs the lower jamb's inflation (1.7)";
  EXPECT_NEAR(crossing_y(clear), 2.0, 0.1);
  EXPECT_EQ(first_blocked_pose(grid, clear.path_world, UnknownCells::kOccupied), -1);
  EXPECT_EQ(clear.path_world.front().xy(), tight.path_world.front().xy());
  EXPECT_EQ(clear.path_world.back().xy(), tight.path_world.back().xy());
  // Nowhere closer to an obstacle than the tight path's closest pose, and in the open unchanged in spirit.
  double min_tight = 1e9, min_clear = 1e9;
  for (const Pose2d& p : tight.path_world) min_tight = std::min(min_tight, grid.clearance_m(*grid.cell_of(p.xy()), UnknownCells::kOccupied));
  for (const Pose2d& p : clear.path_world) min_clear = std::min(min_clear, grid.clearance_m(*grid.cell_of(p.xy()), UnknownCells::kOccupied));
  EXPECT_GT(min_clear, min_tight + 0.1);
}

// A Dubins or Reeds-Shepp path stays on its curves (and its reverse segments keep their yaws): the
// preferred clearance leaves it as planned.
TEST(PathPlanner, APreferredClearanceLeavesCurvePathsAsPlanned) {
  const OccupancyGrid grid = make_grid(6.0, 4.0, [](const Eigen::Vector2d& c) {
    return c.x() > 2.9 && c.x() < 3.1 && (c.y() < 1.5 || c.y() > 2.5);
  });
  for (const StateSpaceKind space : {StateSpaceKind::kDubins, StateSpaceKind::kReedsShepp}) {
    PathPlannerConfig c;
    c.state_space = space;
    c.max_iterations = 5000;
    const PlanResult plain = PathPlanner(c).plan(grid, Pose2d{1.0, 0.6, 0.0}, {5.0, 0.6});
    c.preferred_clearance_m = 0.45;
    const PlanResult clear = PathPlanner(c).plan(grid, Pose2d{1.0, 0.6, 0.0}, {5.0, 0.6});
    ASSERT_NE(plain.status, PlanStatus::kNoPath);
    ASSERT_EQ(clear.path_world.size(), plain.path_world.size());
    for (std::size_t i = 0; i < plain.path_world.size(); ++i) {
      EXPECT_EQ(clear.path_world[i].xy(), plain.path_world[i].xy());
      EXPECT_EQ(clear.path_world[i].yaw_rad, plain.path_world[i].yaw_rad);
    }
  }
}

TEST(PathPlanner, ConfigFromYaml) {
  const auto reader = core::ConfigReader::from_string(
      "planner: rrt_star\nstate_space: dubins\nturning_radius_m: 0.5\nunknown_cells: free\nmax_iterations: 100\n",
      "planner.yaml");
  const auto c = core::load_config<PathPlannerConfig>(reader);
  EXPECT_EQ(c.planner, PlannerAlgorithm::kRrtStar);
  EXPECT_EQ(c.state_space, StateSpaceKind::kDubins);
  EXPECT_EQ(c.unknown_cells, UnknownCells::kFree);
  EXPECT_EQ(c.max_iterations, 100);
  EXPECT_THROW(core::load_config<PathPlannerConfig>(core::ConfigReader::from_string("planner: astar\n", "p.yaml")),
               InputError);
  EXPECT_THROW(core::load_config<PathPlannerConfig>(core::ConfigReader::from_string("seed: 0\n", "p.yaml")),
               InputError);
  const std::string yaml = core::config_to_yaml(c);
  EXPECT_NE(yaml.find("rrt_star"), std::string::npos);
}

}  // namespace
}  // namespace fleetslam::planners
