// OccupancyGrid: cell states from a synthetic cloud, inflation against a brute-force oracle, frontiers,
// rebuilding, conversions and bad input.

#include <algorithm>
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/planners/occupancy_grid.hpp"
#include "synthetic_maps.hpp"

namespace fleetslam::planners {
namespace {

using test::add_box;
using test::add_floor;
using test::grid_config;
using test::room;

CellState state_at(const OccupancyGrid& grid, double x, double y) {
  const auto cell = grid.cell_of({x, y});
  EXPECT_TRUE(cell.has_value()) << x << ", " << y;
  return cell ? grid.state(*cell) : CellState::kUnknown;
}

// A 4 x 4 m room with a 0.5 m box at [1.5, 2] x [1.5, 2], a ceiling above the robot and a low step.
core::PointCloud furnished_room() {
  core::PointCloud cloud = room(4.0, 4.0);
  add_box(cloud, 1.5, 1.5, 2.0, 2.0, 0.0, 0.5);
  add_floor(cloud, 0.0, 0.0, 4.0, 4.0, 0.1, 2.5);  // ceiling: above the robot's band
  add_floor(cloud, 3.0, 3.0, 3.5, 3.5, 0.05, 0.07);  // 7 cm: neither floor nor obstacle
  return cloud;
}

TEST(OccupancyGrid, MarksFloorWallsAndBox) {
  OccupancyGridConfig config = grid_config();
  config.bounds_xy_m = {-1.0, -1.0, 5.0, 5.0};
  OccupancyGrid grid(config);
  grid.update(furnished_room());
  EXPECT_EQ(grid.width(), 120);
  EXPECT_EQ(grid.height(), 120);

  EXPECT_EQ(state_at(grid, 1.75, 1.75), CellState::kOccupied);  // box
  EXPECT_EQ(state_at(grid, 1.52, 1.98), CellState::kOccupied);
  EXPECT_EQ(state_at(grid, -0.03, 2.0), CellState::kOccupied);  // wall
  EXPECT_EQ(state_at(grid, 2.0, 4.03), CellState::kOccupied);
  EXPECT_EQ(state_at(grid, 1.0, 1.0), CellState::kFree);  // under the ceiling
  EXPECT_EQ(state_at(grid, 3.0, 1.0), CellState::kFree);
  EXPECT_EQ(state_at(grid, 1.4, 1.75), CellState::kFree);  // next to the box
  EXPECT_EQ(state_at(grid, 3.25, 3.25), CellState::kFree);  // the low step is not an obstacle
  EXPECT_EQ(state_at(grid, -0.5, 2.0), CellState::kUnknown);  // outside the room
  EXPECT_EQ(state_at(grid, 4.6, 4.6), CellState::kUnknown);

  // Every cell whose centre lies strictly inside the box's footprint is occupied; none inside the room
  // away from the box and walls is.
  std::size_t box_cells = 0;
  for (int y = 0; y < grid.height(); ++y) {
    for (int x = 0; x < grid.width(); ++x) {
      const Eigen::Vector2d c = grid.center_of(CellIndex{x, y});
      const bool in_box = c.x() > 1.5 && c.x() < 2.0 && c.y() > 1.5 && c.y() < 2.0;
      const bool in_room = c.x() > 0.05 && c.x() < 3.95 && c.y() > 0.05 && c.y() < 3.95;
      if (in_box) {
        ++box_cells;
        EXPECT_EQ(grid.state({x, y}), CellState::kOccupied);
      } else if (in_room && (c - Eigen::Vector2d(1.75, 1.75)).cwiseAbs().maxCoeff() > 0.3) {
        EXPECT_EQ(grid.state({x, y}), CellState::kFree) << c.transpose();
      }
    }
  }
  EXPECT_EQ(box_cells, 100u);
  EXPECT_GT(grid.stats().obstacle_points, 0u);
  EXPECT_EQ(grid.stats().free_cells + grid.stats().occupied_cells + grid.stats().unknown_cells, 120u * 120u);
}

TEST(OccupancyGrid, AutomaticBoundsCoverTheCloudWithMargin) {
  OccupancyGrid grid(grid_config());
  grid.update(room(3.0, 2.0));
  const Eigen::Vector2d lo = grid.origin_world();
  const Eigen::Vector2d hi = lo + grid.resolution_m() * Eigen::Vector2d(grid.width(), grid.height());
  EXPECT_LE(lo.x(), -0.05 - 0.5 + 1e-9);
  EXPECT_LE(lo.y(), -0.05 - 0.5 + 1e-9);
  EXPECT_GE(hi.x(), 3.05 + 0.5 - 1e-9);
  EXPECT_GE(hi.y(), 2.05 + 0.5 - 1e-9);
  EXPECT_EQ(state_at(grid, 1.5, 1.0), CellState::kFree);
}

TEST(OccupancyGrid, InflationMatchesBruteForceClearance) {
  OccupancyGridConfig config = grid_config(0.2);
  config.bounds_xy_m = {-1.0, -1.0, 5.0, 5.0};
  OccupancyGrid grid(config);
  grid.update(furnished_room());
  std::vector<Eigen::Vector2d> occupied, blocked;
  for (int y = 0; y < grid.height(); ++y) {
    for (int x = 0; x < grid.width(); ++x) {
      if (grid.state({x, y}) == CellState::kOccupied) occupied.push_back(grid.center_of({x, y}));
      if (grid.state({x, y}) != CellState::kFree) blocked.push_back(grid.center_of({x, y}));
    }
  }
  for (int y = 0; y < grid.height(); y += 7) {
    for (int x = 0; x < grid.width(); x += 3) {
      const Eigen::Vector2d c = grid.center_of(CellIndex{x, y});
      double d_occ = std::numeric_limits<double>::infinity(), d_blk = d_occ;
      for (const auto& o : occupied) d_occ = std::min(d_occ, (o - c).norm());
      for (const auto& o : blocked) d_blk = std::min(d_blk, (o - c).norm());
      EXPECT_NEAR(grid.clearance_m({x, y}, UnknownCells::kFree), d_occ, 1e-5);
      EXPECT_NEAR(grid.clearance_m({x, y}, UnknownCells::kOccupied), d_blk, 1e-5);
    }
  }
  // Near the box's west face (x = 1.5): blocked within the robot radius, clear beyond it.
  EXPECT_FALSE(grid.traversable(Eigen::Vector2d(1.38, 1.76), UnknownCells::kOccupied));
  EXPECT_TRUE(grid.traversable(Eigen::Vector2d(1.22, 1.76), UnknownCells::kOccupied));
  EXPECT_FALSE(grid.traversable(Eigen::Vector2d(1.75, 1.75), UnknownCells::kFree));
  // Along the wall: 0.1 m from it is blocked, 0.4 m is clear.
  EXPECT_FALSE(grid.traversable(Eigen::Vector2d(0.1, 1.0), UnknownCells::kOccupied));
  EXPECT_TRUE(grid.traversable(Eigen::Vector2d(0.4, 1.0), UnknownCells::kOccupied));
  // Unknown cells: blocked when they count as occupied, their neighbourhood too.
  EXPECT_FALSE(grid.traversable(Eigen::Vector2d(-0.6, 2.0), UnknownCells::kOccupied));
  EXPECT_TRUE(grid.traversable(Eigen::Vector2d(-0.6, 2.0), UnknownCells::kFree));
  EXPECT_FALSE(grid.traversable(Eigen::Vector2d(10.0, 2.0), UnknownCells::kFree));  // outside the grid
}

TEST(OccupancyGrid, FrontiersOfAHalfExploredRoom) {
  // A 4 x 3 m room whose west half (x < 2) was seen: floor and walls there; the east half is unknown.
  core::PointCloud cloud;
  add_floor(cloud, 0.0, 0.0, 1.99, 3.0);
  add_box(cloud, -0.05, -0.05, -0.01, 3.05, 0.0, 1.2);  // west wall
  add_box(cloud, -0.05, -0.05, 1.99, -0.01, 0.0, 1.2);  // south wall, west half
  add_box(cloud, -0.05, 3.01, 1.99, 3.05, 0.0, 1.2);    // north wall, west half
  OccupancyGridConfig config = grid_config(0.2);
  config.bounds_xy_m = {-1.0, -1.0, 5.0, 4.0};
  config.max_frontier_cells = 0;  // one piece
  OccupancyGrid grid(config);
  grid.update(cloud);

  const std::vector<Frontier> frontiers = grid.frontiers();
  ASSERT_EQ(frontiers.size(), 1u);
  const Frontier& f = frontiers[0];
  EXPECT_NEAR(f.centroid_world.x(), 1.975, 0.03);
  EXPECT_NEAR(f.centroid_world.y(), 1.5, 0.05);
  EXPECT_GE(f.size(), 59u);  // the 3 m line of cells at x = 1.95..2.0
  EXPECT_LE(f.size(), 62u);
  for (const CellIndex& c : f.cells) {
    EXPECT_EQ(grid.state(c), CellState::kFree);
    EXPECT_NEAR(grid.center_of(c).x(), 1.975, 0.03);
  }
  ASSERT_TRUE(f.has_goal);
  EXPECT_TRUE(grid.traversable(f.goal_world, UnknownCells::kOccupied));
  EXPECT_LT((f.goal_world - f.centroid_world).norm(), 0.3);
  EXPECT_LT(f.goal_world.x(), 1.9);  // the robot's radius away from the unknown half

  // Cut into pieces of at most 25 cells: three even pieces, together the same cells once each, each
  // along its own stretch of the line with a goal of its own.
  config.max_frontier_cells = 25;
  OccupancyGrid cut(config);
  cut.update(cloud);
  const std::vector<Frontier> pieces = cut.frontiers();
  ASSERT_EQ(pieces.size(), 3u);
  std::size_t cells = 0;
  std::vector<std::size_t> seen;
  for (const Frontier& piece : pieces) {
    EXPECT_LE(piece.size(), 25u);
    EXPECT_GE(piece.size(), 19u);
    cells += piece.size();
    for (const CellIndex& c : piece.cells) seen.push_back(cut.index(c));
    EXPECT_NEAR(piece.centroid_world.x(), 1.975, 0.05);
    ASSERT_TRUE(piece.has_goal);
    EXPECT_LT((piece.goal_world - piece.centroid_world).norm(), 0.5);
  }
  EXPECT_EQ(cells, f.size());
  std::sort(seen.begin(), seen.end());
  EXPECT_TRUE(std::adjacent_find(seen.begin(), seen.end()) == seen.end()) << "a cell in two pieces";
  EXPECT_GT(std::abs(pieces[0].centroid_world.y() - pieces[2].centroid_world.y()), 1.0) << "pieces cover different stretches";

  // Seeing the east half too leaves no frontier.
  core::PointCloud full = room(4.0, 3.0);
  grid.update(full);
  EXPECT_TRUE(grid.frontiers().empty());
}

TEST(OccupancyGrid, UpdateRebuildsFromScratch) {
  OccupancyGridConfig config = grid_config();
  config.bounds_xy_m = {-1.0, -1.0, 5.0, 5.0};
  OccupancyGrid grid(config);
  grid.update(furnished_room());
  EXPECT_EQ(state_at(grid, 1.75, 1.75), CellState::kOccupied);
  EXPECT_FALSE(grid.traversable(Eigen::Vector2d(1.38, 1.75), UnknownCells::kOccupied));
  grid.update(room(4.0, 4.0));  // the box was moved away
  EXPECT_EQ(state_at(grid, 1.75, 1.75), CellState::kFree);
  EXPECT_TRUE(grid.traversable(Eigen::Vector2d(1.38, 1.75), UnknownCells::kOccupied));
  grid.update(core::PointCloud{});
  EXPECT_EQ(grid.stats().unknown_cells, static_cast<std::size_t>(grid.width() * grid.height()));
}

TEST(OccupancyGrid, WorldCellConversions) {
  OccupancyGridConfig config = grid_config();
  config.bounds_xy_m = {-2.0, 1.0, 3.0, 4.0};
  OccupancyGrid grid(config);
  grid.update(core::PointCloud{});
  EXPECT_EQ(grid.width(), 100);
  EXPECT_EQ(grid.height(), 60);
  for (int y = 0; y < grid.height(); y += 5) {
    for (int x = 0; x < grid.width(); x += 7) {
      const auto back = grid.cell_of(grid.center_of({x, y}));
      ASSERT_TRUE(back.has_value());
      EXPECT_EQ(*back, (CellIndex{x, y}));
    }
  }
  EXPECT_EQ(*grid.cell_of({-2.0, 1.0}), (CellIndex{0, 0}));
  EXPECT_EQ(*grid.cell_of({-1.951, 1.049}), (CellIndex{0, 0}));
  EXPECT_FALSE(grid.cell_of({-2.001, 1.5}).has_value());
  EXPECT_FALSE(grid.cell_of({3.0, 1.5}).has_value());
  EXPECT_FALSE(grid.cell_of({std::nan(""), 1.5}).has_value());
}

TEST(OccupancyGrid, BlockAndSetCells) {
  OccupancyGrid grid(grid_config(0.1));
  grid.set_cells({0.0, 0.0}, 40, 20, std::vector<CellState>(800, CellState::kFree));
  EXPECT_TRUE(grid.traversable(Eigen::Vector2d(1.0, 0.5), UnknownCells::kOccupied));
  EXPECT_TRUE(grid.traversable(Eigen::Vector2d(1.0, 0.5), UnknownCells::kFree));
  grid.block({Disk{{1.0, 0.5}, 0.2}});
  EXPECT_EQ(state_at(grid, 1.0, 0.5), CellState::kOccupied);
  EXPECT_EQ(state_at(grid, 1.15, 0.5), CellState::kOccupied);
  EXPECT_EQ(state_at(grid, 1.3, 0.5), CellState::kFree);
  EXPECT_FALSE(grid.traversable(Eigen::Vector2d(1.22, 0.5), UnknownCells::kFree));  // inflated
  EXPECT_TRUE(grid.traversable(Eigen::Vector2d(1.5, 0.5), UnknownCells::kFree));
  EXPECT_THROW(grid.set_cells({0.0, 0.0}, 4, 4, std::vector<CellState>(3)), InputError);
}

TEST(OccupancyGrid, MarkFreeClearsOnlyUnknownCells) {
  OccupancyGridConfig config;
  config.resolution_m = 0.05;
  config.robot_radius_m = 0.1;
  OccupancyGrid grid(config);
  std::vector<CellState> cells(40 * 20, CellState::kUnknown);
  cells[10 * 40 + 20] = CellState::kOccupied;  // cell (20, 10): centre (1.025, 0.525)
  grid.set_cells({0.0, 0.0}, 40, 20, cells);
  grid.mark_free({Disk{{1.0, 0.5}, 0.2}, Disk{{std::nan(""), 0.0}, 1.0}});
  std::size_t free = 0;
  for (int y = 0; y < 20; ++y) {
    for (int x = 0; x < 40; ++x) {
      const CellIndex cell{x, y};
      const bool inside = (grid.center_of(cell) - Eigen::Vector2d(1.0, 0.5)).norm() <= 0.2;
      if (x == 20 && y == 10) {
        EXPECT_EQ(grid.state(cell), CellState::kOccupied);
      } else {
        EXPECT_EQ(grid.state(cell), inside ? CellState::kFree : CellState::kUnknown) << x << "," << y;
        free += inside ? 1 : 0;
      }
    }
  }
  EXPECT_EQ(grid.stats().free_cells, free);
  EXPECT_GT(free, 40u);
  // Clearing occupied cells too (a robot drove there).
  grid.mark_free({Disk{{1.0, 0.5}, 0.2}}, true);
  EXPECT_EQ(grid.state(CellIndex{20, 10}), CellState::kFree);
  EXPECT_EQ(grid.stats().free_cells, free + 1);
  EXPECT_EQ(grid.stats().occupied_cells, 0u);
}

TEST(OccupancyGrid, NearestTraversableMatchesBruteForce) {
  OccupancyGridConfig config;
  config.resolution_m = 0.05;
  config.robot_radius_m = 0.12;
  OccupancyGrid grid(config);
  grid.set_cells({0.0, 0.0}, 40, 20, std::vector<CellState>(800, CellState::kFree));
  grid.block({Disk{{1.0, 0.5}, 0.2}});
  // A traversable point is its own answer.
  const Eigen::Vector2d open(0.3, 0.5);
  ASSERT_TRUE(grid.traversable(open, UnknownCells::kOccupied));
  EXPECT_EQ(*nearest_traversable(grid, open, 0.5, UnknownCells::kOccupied), open);
  // Inside the inflated disk: the nearest traversable cell centre, as brute force finds it.
  const Eigen::Vector2d blocked(1.05, 0.52);
  std::optional<Eigen::Vector2d> brute;
  for (int y = 0; y < 20; ++y) {
    for (int x = 0; x < 40; ++x) {
      const Eigen::Vector2d c = grid.center_of(CellIndex{x, y});
      if (!grid.traversable(CellIndex{x, y}, UnknownCells::kOccupied)) continue;
      if (!brute || (c - blocked).norm() < (*brute - blocked).norm()) brute = c;
    }
  }
  const std::optional<Eigen::Vector2d> found = nearest_traversable(grid, blocked, 1.0, UnknownCells::kOccupied);
  ASSERT_TRUE(found && brute);
  EXPECT_NEAR((*found - blocked).norm(), (*brute - blocked).norm(), 1e-9);
  // None within a radius smaller than the distance to the nearest one, nor for a non-finite point.
  EXPECT_FALSE(nearest_traversable(grid, blocked, 0.5 * (*brute - blocked).norm(), UnknownCells::kOccupied));
  EXPECT_FALSE(nearest_traversable(grid, {std::nan(""), 0.0}, 1.0, UnknownCells::kOccupied));
}

TEST(OccupancyGrid, NonFinitePointsAreSkipped) {
  core::PointCloud cloud = room(2.0, 2.0);
  cloud.push_back(Eigen::Vector3f(std::nanf(""), 0.0f, 0.0f));
  cloud.push_back(Eigen::Vector3f(1.0f, std::numeric_limits<float>::infinity(), 0.0f));
  OccupancyGrid grid(grid_config());
  grid.update(cloud);
  EXPECT_EQ(grid.stats().non_finite_points, 2u);
  EXPECT_EQ(state_at(grid, 1.0, 1.0), CellState::kFree);
}

TEST(OccupancyGrid, BadConfigAndHugeBoundsAreInputErrors) {
  OccupancyGridConfig config = grid_config();
  config.bounds_xy_m = {0.0, 0.0, 1.0};
  EXPECT_THROW(OccupancyGrid{config}, InputError);
  config.bounds_xy_m = {0.0, 0.0, -1.0, 1.0};
  EXPECT_THROW(OccupancyGrid{config}, InputError);
  config = grid_config();
  config.obstacle_min_height_m = 0.01;  // below the floor tolerance
  EXPECT_THROW(OccupancyGrid{config}, InputError);

  core::PointCloud far = room(1.0, 1.0);
  far.push_back(Eigen::Vector3f(1e6f, 0.0f, 0.5f));  // an outlier a kilometre away
  OccupancyGrid grid(grid_config());
  EXPECT_THROW(grid.update(far), InputError);

  const auto reader = core::ConfigReader::from_string("resolution_m: 0.1\nrobot_radius: 0.3\n", "grid.yaml");
  EXPECT_THROW(core::load_config<OccupancyGridConfig>(reader), InputError);
  const auto good = core::ConfigReader::from_string("resolution_m: 0.1\nbounds_xy_m: [0, 0, 2, 3]\n", "grid.yaml");
  const auto loaded = core::load_config<OccupancyGridConfig>(good);
  EXPECT_DOUBLE_EQ(loaded.resolution_m, 0.1);
  EXPECT_EQ(loaded.bounds_xy_m.size(), 4u);
}

}  // namespace
}  // namespace fleetslam::planners
