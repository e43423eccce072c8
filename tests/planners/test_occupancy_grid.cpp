// OccupancyGrid: cell states from a synthetic cloud, inflation against a brute-force oracle, frontiers,
// rebuilding, conversions and bad input.

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <utility>
#include <vector>

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

// Whether the segment a-b (xy) meets the cell's square (Liang-Barsky clipping), with a tolerance.
bool segment_meets_cell(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& lo, double size) {
  double t0 = 0.0, t1 = 1.0;
  const Eigen::Vector2d d = b - a;
  for (int k = 0; k < 2; ++k) {
    const double lo_k = lo[k] - 1e-9, hi_k = lo[k] + size + 1e-9;
    if (std::abs(d[k]) < 1e-15) {
      if (a[k] < lo_k || a[k] > hi_k) return false;
      continue;
    }
    double ta = (lo_k - a[k]) / d[k], tb = (hi_k - a[k]) / d[k];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return t0 <= t1;
}

// Free-space carving against a brute-force oracle: random rays from a sensor 0.3 m up to points on the
// walls of a room whose floor was never seen, with a low box in it. Every cell the ray passes through
// below the band's top (densely sampled), except the one it stops in, is free (a rising ray: up to the
// first cell holding obstacle points); every free cell meets the carved part of a ray; cells holding
// obstacle points stay occupied.
TEST(OccupancyGrid, RaysCarveTheFreeSpaceTheyCross) {
  OccupancyGridConfig config = grid_config();
  config.bounds_xy_m = {-0.5, -0.5, 4.5, 4.5};
  OccupancyGrid grid(config);
  core::PointCloud walls = room(4.0, 4.0);
  walls.points.erase(std::remove_if(walls.points.begin(), walls.points.end(),
                                    [](const Eigen::Vector3f& p) { return std::abs(p.z()) < 1e-6f && p.x() >= 0.0f &&
                                                                          p.x() <= 4.0f && p.y() >= 0.0f && p.y() <= 4.0f; }),
                     walls.points.end());  // no floor seen
  add_box(walls, 2.5, 2.5, 2.8, 2.8, 0.0, 0.2);  // a low box the rays pass over
  SensorView view;
  view.origin_world = Eigen::Vector3f(1.0f, 1.2f, 0.3f);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> along(0.0f, 4.0f), height(0.0f, 2.5f);
  for (int i = 0; i < 400; ++i) {
    const float a = along(rng), z = height(rng);
    switch (i % 4) {
      case 0: view.points_world.emplace_back(a, -0.01f, z); break;
      case 1: view.points_world.emplace_back(a, 4.01f, z); break;
      case 2: view.points_world.emplace_back(-0.01f, a, z); break;
      default: view.points_world.emplace_back(4.01f, a, z); break;
    }
  }
  view.points_world.emplace_back(std::numeric_limits<float>::quiet_NaN(), 0.0f, 0.0f);  // skipped
  grid.update(walls, {view});
  EXPECT_EQ(grid.stats().rays, 400u);
  EXPECT_GT(grid.stats().carved_cells, 500u);

  const double top = config.obstacle_max_height_m, res = config.resolution_m;
  const Eigen::Vector3d o = view.origin_world.cast<double>();
  std::vector<std::uint8_t> holds_obstacle(static_cast<std::size_t>(grid.width() * grid.height()), 0);
  for (const Eigen::Vector3f& p : walls.points) {
    const auto cell = grid.cell_of(p.head<2>().cast<double>());
    const double z = p.z();
    if (cell && z >= config.obstacle_min_height_m && z <= top) holds_obstacle[grid.index(*cell)] = 1;
  }
  std::vector<std::uint8_t> oracle(static_cast<std::size_t>(grid.width() * grid.height()), 0);
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> carved_parts;
  std::size_t stopped_by_obstacles = 0;
  for (std::size_t i = 0; i < 400; ++i) {
    const Eigen::Vector3d d = view.points_world[i].cast<double>() - o;
    double t_stop = 1.0 - config.carve_stop_short_m / d.norm();
    if (d.z() > 0.0) t_stop = std::min(t_stop, (top - o.z()) / d.z());
    const auto end_cell = grid.cell_of((o + t_stop * d).head<2>());
    double t_carved = t_stop;
    for (int k = 0; k < 20000; ++k) {
      const double t = t_stop * k / 20000.0;
      const auto cell = grid.cell_of((o + t * d).head<2>());
      if (!cell || cell == end_cell) continue;
      if (d.z() > 0.0 && holds_obstacle[grid.index(*cell)]) {  // a rising ray stops there
        t_carved = t;
        ++stopped_by_obstacles;
        break;
      }
      oracle[grid.index(*cell)] = 1;
    }
    carved_parts.emplace_back(o.head<2>(), (o + t_carved * d).head<2>());
  }
  for (int y = 0; y < grid.height(); ++y) {
    for (int x = 0; x < grid.width(); ++x) {
      const CellIndex cell{x, y};
      const Eigen::Vector2d lo = grid.origin_world() + res * Eigen::Vector2d(x, y);
      if (grid.state(cell) == CellState::kOccupied) continue;
      if (oracle[grid.index(cell)]) {
        EXPECT_EQ(grid.state(cell), CellState::kFree) << "crossed: " << x << ", " << y;
      }
      if (grid.state(cell) == CellState::kFree) {
        const bool meets = std::any_of(carved_parts.begin(), carved_parts.end(),
                                       [&](const auto& s) { return segment_meets_cell(s.first, s.second, lo, res); });
        EXPECT_TRUE(meets) << "free but no ray crossed it: " << x << ", " << y;
      }
    }
  }
  EXPECT_GT(stopped_by_obstacles, 0u);  // rays rising over the box
  EXPECT_EQ(state_at(grid, 2.65, 2.65), CellState::kOccupied);  // the box stays
  EXPECT_EQ(state_at(grid, -0.03, 2.0), CellState::kOccupied);   // so do the walls

  // Off: nothing is carved; the floor-only grid knows nothing inside the room.
  config.carve_rays = false;
  OccupancyGrid plain(config);
  plain.update(walls, {view});
  EXPECT_EQ(plain.stats().carved_cells, 0u);
  EXPECT_EQ(state_at(plain, 1.5, 1.5), CellState::kUnknown);
}

// A ray that climbs above the band's top clears only the cells it crosses below it; one from a sensor
// above the band clears from where it enters the band; a rising ray stops at a cell holding an obstacle
// point, a level one does not.
TEST(OccupancyGrid, RaysAboveTheBandOrBeyondAnObstacleTheyRiseOverClearNothing) {
  OccupancyGridConfig config = grid_config();
  config.bounds_xy_m = {0.0, 0.0, 5.0, 1.0};
  config.carve_stop_short_m = 0.0;
  OccupancyGrid grid(config);
  SensorView climbing;
  climbing.origin_world = Eigen::Vector3f(0.01f, 0.525f, 0.5f);
  climbing.points_world = {Eigen::Vector3f(4.01f, 0.525f, 2.5f)};  // reaches z = 1.0 at x = 1.01
  SensorView high;
  high.origin_world = Eigen::Vector3f(0.01f, 0.325f, 3.0f);
  high.points_world = {Eigen::Vector3f(4.01f, 0.325f, 0.0f)};  // enters the band (z = 1) at x = 2.677
  // Over a cell holding one obstacle point (at x 1.5): the rising ray stops there, the level one goes on.
  core::PointCloud cloud;
  cloud.push_back(Eigen::Vector3f(1.525f, 0.825f, 0.2f));
  cloud.push_back(Eigen::Vector3f(1.525f, 0.725f, 0.2f));
  SensorView rising;
  rising.origin_world = Eigen::Vector3f(0.01f, 0.825f, 0.3f);
  rising.points_world = {Eigen::Vector3f(3.01f, 0.825f, 0.5f)};
  SensorView level;
  level.origin_world = Eigen::Vector3f(0.01f, 0.725f, 0.3f);
  level.points_world = {Eigen::Vector3f(3.01f, 0.725f, 0.3f)};
  grid.update(cloud, {climbing, high, rising, level});
  EXPECT_EQ(state_at(grid, 0.5, 0.525), CellState::kFree);
  EXPECT_EQ(state_at(grid, 0.975, 0.525), CellState::kFree);
  EXPECT_EQ(state_at(grid, 1.025, 0.525), CellState::kUnknown);  // the ray is above 1 m across it
  EXPECT_EQ(state_at(grid, 3.0, 0.525), CellState::kUnknown);
  EXPECT_EQ(state_at(grid, 1.475, 0.825), CellState::kFree);
  EXPECT_EQ(state_at(grid, 1.575, 0.825), CellState::kUnknown);  // beyond the obstacle it rose over
  EXPECT_EQ(state_at(grid, 2.5, 0.825), CellState::kUnknown);
  EXPECT_EQ(state_at(grid, 1.475, 0.725), CellState::kFree);
  EXPECT_EQ(state_at(grid, 2.5, 0.725), CellState::kFree);
  EXPECT_EQ(state_at(grid, 2.5, 0.325), CellState::kUnknown);
  EXPECT_EQ(state_at(grid, 2.725, 0.325), CellState::kFree);
  EXPECT_EQ(state_at(grid, 3.9, 0.325), CellState::kFree);
}

// A ray down into a pit (a point below the floor) clears only the cells it crosses above the floor: the
// drop beyond was never seen as floor. A garbage point 1e12 m away, and a sensor far outside the grid,
// walk only the grid's cells (before, the first walked 1e13 cells and never ended).
TEST(OccupancyGrid, RaysClearNothingBelowTheFloorOrOutsideTheGrid) {
  OccupancyGridConfig config = grid_config();
  config.bounds_xy_m = {0.0, 0.0, 5.0, 1.0};
  config.carve_stop_short_m = 0.0;
  OccupancyGrid grid(config);
  SensorView pit;
  pit.origin_world = Eigen::Vector3f(0.01f, 0.525f, 0.3f);
  pit.points_world = {Eigen::Vector3f(4.01f, 0.525f, -0.9f)};  // below the floor (z < -0.05) from x = 1.177
  SensorView far_point;
  far_point.origin_world = Eigen::Vector3f(0.01f, 0.225f, 0.3f);
  far_point.points_world = {Eigen::Vector3f(1e12f, 0.225f, 0.3f)};
  SensorView far_sensor;
  far_sensor.origin_world = Eigen::Vector3f(-1e12f, 0.825f, 0.3f);
  far_sensor.points_world = {Eigen::Vector3f(2.01f, 0.825f, 0.3f)};
  grid.update(core::PointCloud{}, {pit, far_point, far_sensor});
  EXPECT_EQ(state_at(grid, 1.075, 0.525), CellState::kFree);
  EXPECT_EQ(state_at(grid, 1.175, 0.525), CellState::kUnknown);  // the ray is below the floor across it
  EXPECT_EQ(state_at(grid, 3.0, 0.525), CellState::kUnknown);
  EXPECT_EQ(state_at(grid, 0.025, 0.225), CellState::kFree);
  EXPECT_EQ(state_at(grid, 4.975, 0.225), CellState::kFree);  // to the grid's far edge
  EXPECT_EQ(state_at(grid, 0.025, 0.825), CellState::kFree);
  EXPECT_EQ(state_at(grid, 1.975, 0.825), CellState::kFree);
  EXPECT_EQ(state_at(grid, 2.025, 0.825), CellState::kUnknown);  // the cell the carving ends in
}

// A bed 0.5 m tall seen by a camera 0.3 m up: the camera sees its near side, not its top. Rays to the
// wall behind rise over the bed's cells and must not clear them, or the planner routes the robot through a
// gap in the near side onto the bed. Rays down to the floor and the side's lower part clear the floor in
// front of it.
TEST(OccupancyGrid, RaysOverAnObstacleTallerThanTheSensorDoNotClearIt) {
  OccupancyGridConfig config = grid_config();
  config.bounds_xy_m = {0.0, 0.0, 4.2, 2.0};
  OccupancyGrid grid(config);
  core::PointCloud cloud;  // the bed's near side (x = 2.0, y 0.5 .. 1.5, z 0 .. 0.5) and the wall behind
  SensorView view;
  view.origin_world = Eigen::Vector3f(0.2f, 1.0f, 0.3f);
  for (int i = 0; i <= 40; ++i) {
    const float y = 0.5f + 0.025f * static_cast<float>(i);
    for (int k = 0; k <= 10; ++k) {
      const Eigen::Vector3f side(2.0f, y, 0.05f * static_cast<float>(k));
      cloud.push_back(side);
      view.points_world.push_back(side);
    }
    for (int k = 0; k <= 20; ++k) {
      const Eigen::Vector3f wall(4.05f, y, 0.6f + 0.05f * static_cast<float>(k));  // over the bed: rising rays
      cloud.push_back(wall);
      view.points_world.push_back(wall);
    }
  }
  grid.update(cloud, {view});
  for (double x = 2.1; x < 3.0; x += 0.1) {
    for (double y = 0.6; y < 1.45; y += 0.1) {
      EXPECT_NE(state_at(grid, x, y), CellState::kFree) << "on the bed: " << x << ", " << y;
    }
  }
  EXPECT_EQ(state_at(grid, 1.0, 1.0), CellState::kFree);   // in front of it
  EXPECT_EQ(state_at(grid, 1.9, 1.0), CellState::kFree);
  EXPECT_EQ(state_at(grid, 2.0, 1.0), CellState::kOccupied);  // its side
}

// A ray passing a cell that holds an obstacle point too few to call it occupied (min_obstacle_points)
// leaves it unknown, not free: a sparse wall must not get holes. Cells up to the one the ray ends in are
// carved, so no unknown band (and no frontier) is left in front of the wall.
TEST(OccupancyGrid, RaysDoNotClearCellsWithObstaclePoints) {
  OccupancyGridConfig config = grid_config();
  config.bounds_xy_m = {0.0, 0.0, 3.0, 1.0};
  config.min_obstacle_points = 3;
  OccupancyGrid grid(config);
  core::PointCloud cloud;
  cloud.push_back(Eigen::Vector3f(1.525f, 0.525f, 0.5f));  // one point: not occupied
  for (int k = 0; k < 5; ++k) cloud.push_back(Eigen::Vector3f(2.525f, 0.52f + 0.002f * k, 0.3f + 0.1f * k));  // a wall cell
  SensorView view;
  view.origin_world = Eigen::Vector3f(0.025f, 0.525f, 0.3f);
  view.points_world = {Eigen::Vector3f(2.525f, 0.525f, 0.3f)};
  grid.update(cloud, {view});
  EXPECT_EQ(state_at(grid, 1.525, 0.525), CellState::kUnknown);
  EXPECT_EQ(state_at(grid, 1.475, 0.525), CellState::kFree);
  EXPECT_EQ(state_at(grid, 2.475, 0.525), CellState::kFree);  // right up to the wall
  EXPECT_EQ(state_at(grid, 2.525, 0.525), CellState::kOccupied);
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
  // Without a margin the farthest points lie on the far edge: they are in the grid, not dropped.
  OccupancyGridConfig tight = grid_config();
  tight.margin_m = 0.0;
  OccupancyGrid no_margin(tight);
  core::PointCloud wall;
  for (int i = 0; i <= 20; ++i) wall.push_back(Eigen::Vector3f(1.0f, 0.05f * static_cast<float>(i), 0.5f));
  wall.push_back(Eigen::Vector3f(0.0f, 0.0f, 0.5f));
  no_margin.update(wall);
  EXPECT_EQ(no_margin.stats().outside_points, 0u);
  EXPECT_EQ(state_at(no_margin, 1.0, 1.0), CellState::kOccupied);
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
      // Outside the grid is unknown: the nearest outside cell straight across a border.
      const int across = std::min({x + 1, y + 1, grid.width() - x, grid.height() - y});
      d_blk = std::min(d_blk, across * config.resolution_m);
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

// A grid free to its border: with unknown cells as occupied, outside the grid counts as unknown, so a
// robot's body may not reach past the border; with unknown cells as free, the border does not matter.
TEST(OccupancyGrid, OutsideTheGridIsUnknownForTheClearance) {
  OccupancyGrid grid(grid_config(0.2));
  grid.set_cells(Eigen::Vector2d::Zero(), 20, 12, std::vector<CellState>(20 * 12, CellState::kFree));
  EXPECT_NEAR(grid.clearance_m({0, 6}, UnknownCells::kOccupied), 0.05, 1e-6);
  EXPECT_NEAR(grid.clearance_m({19, 6}, UnknownCells::kOccupied), 0.05, 1e-6);
  EXPECT_NEAR(grid.clearance_m({10, 2}, UnknownCells::kOccupied), 0.15, 1e-6);
  EXPECT_NEAR(grid.clearance_m({10, 6}, UnknownCells::kOccupied), 0.30, 1e-6);  // 6 cells to y = 12
  EXPECT_FALSE(grid.traversable(CellIndex{10, 2}, UnknownCells::kOccupied));
  EXPECT_FALSE(grid.traversable(CellIndex{10, 3}, UnknownCells::kOccupied));  // 4 cells: at the radius
  EXPECT_TRUE(grid.traversable(CellIndex{10, 4}, UnknownCells::kOccupied));
  EXPECT_TRUE(grid.traversable(CellIndex{0, 6}, UnknownCells::kFree));
  EXPECT_GT(grid.clearance_m({0, 6}, UnknownCells::kFree), 1e3);  // nothing occupied anywhere
}

// The inflation's edge: traversable when the centre-to-centre clearance exceeds the radius, and a cell
// exactly at the limit is blocked (the float clearance 0.2f exceeded 0.2, so 4 cells at 5 cm passed a
// 0.2 m limit; 3 cells at 10 cm a 0.3 m one).
TEST(OccupancyGrid, InflationBlocksACellExactlyAtTheRadius) {
  for (const double radius_m : {0.15, 0.175, 0.2, 0.25, 0.3}) {
    for (const double resolution_m : {0.05, 0.1}) {
      // A wall filling x < 1 (cells up to [0.95, 1) at 5 cm), free beyond.
      const OccupancyGrid grid = test::make_grid(4.0, 2.0, [](const Eigen::Vector2d& c) { return c.x() < 1.0; },
                                                 radius_m, resolution_m);
      const int y = grid.height() / 2;
      for (int x = 0; x < grid.width() - 1; ++x) {
        const Eigen::Vector2d c = grid.center_of({x, y});
        // The nearest wall cells' centres: half a cell inside the wall's face at x = 1 and the east border
        // cell's at 4 - resolution.
        const double to_wall_m = c.x() - (1.0 - 0.5 * resolution_m);
        const double to_border_m = (4.0 - 0.5 * resolution_m) - c.x();
        const bool expected = to_wall_m > radius_m + 1e-9 && to_border_m > radius_m + 1e-9;
        EXPECT_EQ(grid.traversable(CellIndex{x, y}, UnknownCells::kOccupied), expected)
            << "radius " << radius_m << " resolution " << resolution_m << " cell centre x " << c.x();
      }
    }
  }
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

// line_of_sight against a brute-force oracle: a segment is blocked exactly when some occupied cell's
// square meets it (dense sampling), up to the half-cell sampling at a square's corners.
TEST(OccupancyGrid, LineOfSightIsBlockedOnlyByOccupiedCells) {
  OccupancyGridConfig config = grid_config();
  config.bounds_xy_m = {-1.0, -1.0, 5.0, 5.0};
  OccupancyGrid grid(config);
  grid.update(furnished_room());
  EXPECT_TRUE(line_of_sight(grid, {0.5, 0.5}, {3.5, 0.5}));     // along the free floor
  EXPECT_FALSE(line_of_sight(grid, {1.0, 1.75}, {2.5, 1.75}));  // through the box
  EXPECT_FALSE(line_of_sight(grid, {2.0, 2.0}, {2.0, 4.5}));    // through the north wall
  EXPECT_TRUE(line_of_sight(grid, {-0.5, -0.5}, {-0.5, 4.5}));  // unknown cells outside the room let it through
  EXPECT_TRUE(line_of_sight(grid, {1.0, 1.0}, {1.0, 1.0}));     // a point sees itself
  EXPECT_FALSE(line_of_sight(grid, {1.0, 1.0}, {std::nan(""), 1.0}));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coordinate(-0.5, 4.5);
  int blocked = 0, corners_missed = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const Eigen::Vector2d a(coordinate(rng), coordinate(rng));
    const Eigen::Vector2d b(coordinate(rng), coordinate(rng));
    bool oracle = true;
    const int samples = 4000;
    for (int i = 0; i <= samples && oracle; ++i) {
      const auto cell = grid.cell_of(a + (b - a) * (static_cast<double>(i) / samples));
      oracle = !(cell && grid.state(*cell) == CellState::kOccupied);
    }
    // Sampling every half cell can only miss a corner that the segment clips by a sliver.
    const bool sees = line_of_sight(grid, a, b);
    EXPECT_FALSE(sees == false && oracle) << "a clear segment reported blocked: " << a.transpose() << " -> " << b.transpose();
    corners_missed += sees && !oracle ? 1 : 0;
    blocked += oracle ? 0 : 1;
  }
  EXPECT_GT(blocked, 100);  // the oracle sees both outcomes
  EXPECT_LT(blocked, 300);
  EXPECT_LE(corners_missed, 6);
}

// The unknown floor in sight of a point: the unseen east half of a room shows about half a disk from the
// middle of the boundary; a wall in between hides it; nothing unknown, nothing to gain.
TEST(OccupancyGrid, UnknownAreaInSightCountsWhatASensorCouldStillSee) {
  OccupancyGridConfig config = grid_config();
  config.bounds_xy_m = {-0.5, -0.5, 6.5, 4.5};
  core::PointCloud half;
  add_floor(half, 0.0, 0.0, 3.0, 4.0);
  OccupancyGrid grid(config);
  grid.update(half);
  const double r = 1.0;
  const double half_disk = 0.5 * M_PI * r * r;
  EXPECT_NEAR(unknown_area_in_sight_m2(grid, {2.975, 2.0}, r), half_disk, 0.1 * half_disk);
  EXPECT_NEAR(unknown_area_in_sight_m2(grid, {1.5, 2.0}, r), 0.0, 1e-12);
  add_box(half, 3.0, -0.05, 3.05, 4.05, 0.0, 1.2);  // a wall along the boundary
  grid.update(half);
  EXPECT_LT(unknown_area_in_sight_m2(grid, {2.9, 2.0}, r), 0.05 * half_disk);
  EXPECT_EQ(unknown_area_in_sight_m2(grid, {std::nan(""), 2.0}, r), 0.0);
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
