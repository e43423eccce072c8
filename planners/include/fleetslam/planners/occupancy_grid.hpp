#pragma once
// A 2D occupancy grid for ground robots, built from a world-frame point cloud (the fused dense map).
//
// Heights are relative to the floor (floor_height_m, world z). A cell is
//   occupied  when at least min_obstacle_points points fall in it with height in
//             [obstacle_min_height_m, obstacle_max_height_m] (the band the robot's body sweeps),
//   free      when the floor was observed there (a point within floor_tolerance_m of the floor), or a
//             sensor's ray crossed it low enough (see below), and it is not occupied,
//   unknown   otherwise.
// Free-space carving (carve_rays): a point seen from a sensor means nothing stood between them. Each ray
// from a SensorView's origin to its points clears the cells it crosses while it is below the top of the
// obstacle band (obstacle_max_height_m; a ray above it says nothing about what stands lower) and above the
// floor (a ray below floor_height_m - floor_tolerance_m is over a drop whose floor was not seen), up to
// carve_stop_short_m before the point and never the cell the carving ends in. A rising ray stops at the
// first cell holding obstacle points: it passes over what stands lower than it, and a thing taller than
// the sensor hides its top (a bed seen from below is only its near side in the map), so beyond its seen
// side the ray says nothing. What a ray that does not rise passes over is lower than the sensor, which
// sees its top. A forward camera sees the floor only in sparse rows at grazing angles; its rays fill the
// floor between them, as ROS costmaps' ray tracing does. Obstacles win: a cell holding any obstacle point (even fewer than min_obstacle_points)
// is not carved. Stopping short leaves a band of unknown cells in front of every wall, and a frontier
// there: keep carve_stop_short_m below the resolution (the wall's own cell is never carved anyway).
// Inflation: every cell keeps its clearance, the distance between its centre and the centre of the
// nearest occupied cell (exact Euclidean distance transform, Felzenszwalb & Huttenlocher 2012), and a
// second clearance to the nearest occupied-or-unknown cell, cells outside the grid included (they are
// unknown). A cell is traversable for the robot's centre
// when it is free (or unknown, where unknown cells count as free) and its clearance exceeds
// robot_radius_m (centre to centre, as ROS costmaps inflate). A clearance exactly at the limit is
// blocked: compared in cells, with a tolerance far below the gap between two grid distances, not against
// the float clearance (0.2f > 0.2 let 4 cells of 5 cm pass a 0.2 m radius). An obstacle fills its cell,
// whose face is half a cell (a diagonal corner up to 0.71 cells) nearer than its centre: give
// robot_radius_m that margin over the robot's body (the shipped scenarios' 0.28 m over a 0.2 m body).
// Cells outside the grid are never traversable.
//
// Cell (x, y) covers [origin + x * res, origin + (x + 1) * res) along world x (likewise y); cells are
// stored row-major, index = y * width + x. update() rebuilds everything from scratch (the fused map
// changes as a whole when the central unit re-merges).

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/point_cloud.hpp"

namespace fleetslam::planners {

enum class CellState : std::uint8_t { kUnknown = 0, kFree = 1, kOccupied = 2 };

// How a planner or a cost treats unknown cells.
enum class UnknownCells { kFree, kOccupied };

struct CellIndex {
  int x = 0;
  int y = 0;
  bool operator==(const CellIndex& other) const { return x == other.x && y == other.y; }
  bool operator!=(const CellIndex& other) const { return !(*this == other); }
};

// Where a sensor stood and what it saw from there, in the world frame (for free-space carving).
struct SensorView {
  Eigen::Vector3f origin_world = Eigen::Vector3f::Zero();
  std::vector<Eigen::Vector3f> points_world;
};

// A disk in the world's xy plane (blocked regions for deconfliction).
struct Disk {
  Eigen::Vector2d center_world = Eigen::Vector2d::Zero();
  double radius_m = 0.0;
};

// Free cells next to unknown cells (4-neighbourhood), clustered by 8-connectivity.
struct Frontier {
  std::vector<CellIndex> cells;
  Eigen::Vector2d centroid_world = Eigen::Vector2d::Zero();
  // The cell nearest the centroid (within frontier_goal_search_m) that is traversable with unknown cells
  // counted as occupied: a goal a conservative planner can reach. has_goal false when there is none.
  Eigen::Vector2d goal_world = Eigen::Vector2d::Zero();
  bool has_goal = false;
  std::size_t size() const { return cells.size(); }
};

struct OccupancyGridConfig {
  double resolution_m = 0.05;
  double floor_height_m = 0.0;           // world z of the floor
  double floor_tolerance_m = 0.05;       // |z - floor| within this: floor observed
  double obstacle_min_height_m = 0.10;   // above the floor; lower points are neither floor nor obstacle
  double obstacle_max_height_m = 1.0;    // above the floor: the robot's height
  int min_obstacle_points = 1;           // points in the band needed to call a cell occupied
  double robot_radius_m = 0.2;           // inflation radius
  // Bounds {min_x, min_y, max_x, max_y} in metres; empty: the cloud's xy bounds padded by margin_m.
  std::vector<double> bounds_xy_m;
  double margin_m = 0.5;
  std::int64_t max_cells = 16'000'000;   // larger grids are an InputError (far outliers, a wrong unit)
  int min_frontier_cells = 5;            // smaller frontier clusters are dropped
  int max_frontier_cells = 40;           // longer clusters are cut into pieces of about this many cells (0: never)
  double frontier_goal_search_m = 1.0;
  bool carve_rays = true;                // free-space carving along the SensorViews' rays (see above)
  double carve_stop_short_m = 0.0;       // a ray clears cells up to this far before its point

  template <class V>
  void visit(V& v) {
    v("resolution_m", resolution_m, core::Limits<double>{1e-3, 10.0});
    v("floor_height_m", floor_height_m);
    v("floor_tolerance_m", floor_tolerance_m, core::Limits<double>{0.0, 10.0});
    v("obstacle_min_height_m", obstacle_min_height_m, core::Limits<double>{0.0, 100.0});
    v("obstacle_max_height_m", obstacle_max_height_m, core::Limits<double>{0.0, 100.0});
    v("min_obstacle_points", min_obstacle_points, core::Limits<int>{1, 1 << 30});
    v("robot_radius_m", robot_radius_m, core::Limits<double>{0.0, 100.0});
    v("bounds_xy_m", bounds_xy_m);
    v("margin_m", margin_m, core::Limits<double>{0.0, 1000.0});
    v("max_cells", max_cells, core::Limits<std::int64_t>{1, std::int64_t{1} << 40});
    v("min_frontier_cells", min_frontier_cells, core::Limits<int>{1, 1 << 30});
    v("max_frontier_cells", max_frontier_cells, core::Limits<int>{0, 1 << 30});
    v("frontier_goal_search_m", frontier_goal_search_m, core::Limits<double>{0.0, 1000.0});
    v("carve_rays", carve_rays);
    v("carve_stop_short_m", carve_stop_short_m, core::Limits<double>{0.0, 100.0});
  }
};

// What the last update saw.
struct OccupancyGridStats {
  std::size_t points = 0;
  std::size_t non_finite_points = 0;
  std::size_t outside_points = 0;   // outside fixed bounds
  std::size_t floor_points = 0;
  std::size_t obstacle_points = 0;
  std::size_t free_cells = 0;
  std::size_t occupied_cells = 0;
  std::size_t unknown_cells = 0;
  std::size_t rays = 0;             // carving rays cast (finite, from inside the grid's bounds or not)
  std::size_t carved_cells = 0;     // free only because a ray crossed them (no floor point there)
};

class OccupancyGrid {
 public:
  using Config = OccupancyGridConfig;

  // An empty grid (0 x 0 cells). Throws InputError on an inconsistent config (bounds not 4 numbers or
  // empty, obstacle band below the floor tolerance or empty).
  explicit OccupancyGrid(const Config& config);

  // Rebuilds every cell from a world-frame cloud, and carves free space along the views' rays (the
  // views' points are used for nothing else: cloud_world holds the map). Non-finite points are skipped
  // and counted; rays with a non-finite end are skipped.
  void update(const core::PointCloud& cloud_world, const std::vector<SensorView>& views_world = {});

  // Sets the cells directly: width x height cells, row-major, cell (0, 0)'s corner at origin_world.
  // For ground-truth maps and tests. Throws InputError when cells.size() != width * height.
  void set_cells(const Eigen::Vector2d& origin_world, int width, int height, std::vector<CellState> cells);

  // Marks every cell whose centre lies within a disk as occupied and recomputes the clearances.
  void block(const std::vector<Disk>& disks_world);
  // Marks the unknown cells whose centre lies within a disk as free and recomputes the clearances; with
  // clear_occupied, occupied cells too. The floor a robot's body has driven over is free of static
  // obstacles, even where its camera never saw the floor, and even where another robot's camera saw the
  // robot itself standing (a robot in the map is not a wall).
  void mark_free(const std::vector<Disk>& disks_world, bool clear_occupied = false);

  const Config& config() const { return config_; }
  const OccupancyGridStats& stats() const { return stats_; }
  int width() const { return width_; }
  int height() const { return height_; }
  double resolution_m() const { return config_.resolution_m; }
  const Eigen::Vector2d& origin_world() const { return origin_world_; }

  bool contains(const CellIndex& cell) const {
    return cell.x >= 0 && cell.y >= 0 && cell.x < width_ && cell.y < height_;
  }
  // The cell containing a world point, or nullopt outside the grid (or non-finite).
  std::optional<CellIndex> cell_of(const Eigen::Vector2d& p_world) const;
  Eigen::Vector2d center_of(const CellIndex& cell) const;

  // Outside the grid: kUnknown.
  CellState state(const CellIndex& cell) const;
  // Distance (m) between centres to the nearest occupied cell (unknown: kFree) or occupied-or-unknown
  // cell (unknown: kOccupied); infinity when there is none. 0 outside the grid.
  double clearance_m(const CellIndex& cell, UnknownCells unknown) const;
  bool traversable(const CellIndex& cell, UnknownCells unknown) const;
  bool traversable(const Eigen::Vector2d& p_world, UnknownCells unknown) const;

  // Frontier clusters in scan order of their first cell (deterministic); a cluster longer than
  // max_frontier_cells is cut into consecutive pieces (breadth-first order) of at most that many cells.
  std::vector<Frontier> frontiers() const;

  // Path lengths (m) over traversable cells (8-connected, Dijkstra) from the cell of `from_world` to
  // every cell, row-major; infinity where unreachable (everywhere when the start is not traversable).
  std::vector<double> geodesic_distances_m(const Eigen::Vector2d& from_world, UnknownCells unknown) const;

  std::size_t index(const CellIndex& cell) const {
    return static_cast<std::size_t>(cell.y) * static_cast<std::size_t>(width_) + static_cast<std::size_t>(cell.x);
  }

 private:
  void recompute_clearances();
  void carve(const SensorView& view, const std::vector<int>& obstacle_count, std::vector<std::uint8_t>& crossed);
  void place_frontier_goal(Frontier& frontier) const;
  template <class Fn>
  void for_cells_in(const std::vector<Disk>& disks_world, Fn&& fn);

  Config config_;
  OccupancyGridStats stats_;
  Eigen::Vector2d origin_world_ = Eigen::Vector2d::Zero();
  int width_ = 0;
  int height_ = 0;
  std::vector<CellState> cells_;
  std::vector<float> clearance_occupied_m_;  // to occupied cells
  std::vector<float> clearance_blocked_m_;   // to occupied or unknown cells
};

// The centre of the grid cell nearest p_world within radius_m that `accept` takes (first in scan order on
// ties), or nullopt.
std::optional<Eigen::Vector2d> nearest_cell_centre(const OccupancyGrid& grid, const Eigen::Vector2d& p_world, double radius_m,
                                                   const std::function<bool(const Eigen::Vector2d&)>& accept);

// Whether the straight segment from a_world to b_world crosses no occupied cell (unknown and free cells
// let it through; so do points outside the grid): what a sensor at a could see of b. Sampled every
// half cell along the segment, both ends included.
bool line_of_sight(const OccupancyGrid& grid, const Eigen::Vector2d& a_world, const Eigen::Vector2d& b_world);

// The area (m^2) of the unknown cells whose centres lie within radius_m of p_world and are in its line of
// sight (above): what a sensor there could still discover, the gain of an exploration goal. 0 for a
// non-finite point.
double unknown_area_in_sight_m2(const OccupancyGrid& grid, const Eigen::Vector2d& p_world, double radius_m);

// The traversable cell centre nearest p_world within radius_m (p_world itself when it is traversable), or
// nullopt: where a robot whose inflated footprint touches an obstacle can start a plan from.
std::optional<Eigen::Vector2d> nearest_traversable(const OccupancyGrid& grid, const Eigen::Vector2d& p_world,
                                                   double radius_m, UnknownCells unknown);

}  // namespace fleetslam::planners
