#pragma once
// Path planning for one ground robot on an OccupancyGrid with OMPL (kept out of this header).
//
// State space: SE(2) (x, y, yaw; a differential-drive robot turns in place, so the path's yaw is
// rewritten to the direction of travel and the robot turns at the vertices), or Dubins / Reeds-Shepp
// curves with a minimum turning radius. A state is valid when its cell is traversable in the inflated
// grid (unknown cells free or occupied by config, extra blocked disks count as occupied). Motions are
// checked every half cell. The goal is a disc of goal_tolerance_m around a point in xy; its heading is
// free.
//
// Determinism: termination is a count of planner iterations (calls of the termination condition), never
// wall time unless time_limit_s is set. OMPL's random generators draw their seeds from one process-wide
// generator (ompl::RNG::setSeed is global), so plan() seeds it with config.seed at every call, under a
// process-wide mutex that also serialises plans in different threads; the same grid, query and config
// then give a bit-identical path for rrt_star and rrt_connect. prm_star is NOT repeatable: OMPL's PRM
// looks for solutions in a second thread while the roadmap grows. OMPL's console messages are routed to
// the planner's logger (debug level) during the call.
//
// Before sampling, plan() checks in the grid (8-connected flood fill) that the goal is reachable at all;
// when it is not, the status is kNoPath at once (a closed wall costs no iterations).

#include <cstdint>
#include <limits>
#include <vector>

#include <Eigen/Core>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/planners/occupancy_grid.hpp"

namespace fleetslam::planners {

struct Pose2d {
  double x_m = 0.0;
  double y_m = 0.0;
  double yaw_rad = 0.0;
  Eigen::Vector2d xy() const { return {x_m, y_m}; }
};

enum class PlannerAlgorithm { kRrtStar, kPrmStar, kRrtConnect };
enum class StateSpaceKind { kSe2, kDubins, kReedsShepp };

struct PathPlannerConfig {
  PlannerAlgorithm planner = PlannerAlgorithm::kRrtConnect;
  StateSpaceKind state_space = StateSpaceKind::kSe2;
  double turning_radius_m = 0.3;          // Dubins and Reeds-Shepp only
  int max_iterations = 20000;             // the termination condition: planner iterations
  // rrt_star / prm_star: stop at the first exact solution instead of improving it until max_iterations.
  bool stop_at_first_solution = false;
  double time_limit_s = 0.0;              // > 0: also stop after this wall time (then not repeatable)
  int seed = 1;                           // OMPL's seed for every plan (0 is not allowed by OMPL)
  bool simplify = true;                   // shortcutting and smoothing (OMPL PathSimplifier::simplifyMax)
  UnknownCells unknown_cells = UnknownCells::kOccupied;
  double goal_tolerance_m = 0.1;
  // When the goal's cell is not traversable, use the nearest traversable cell within this radius instead.
  double goal_snap_radius_m = 0.0;
  bool check_reachability = true;         // flood fill before sampling (see the file comment)
  double path_step_m = 0.05;              // spacing of the returned path's poses
  // > 0: the path's interior is moved away from obstacles up to this clearance (from the nearest obstacle
  // cell, as OccupancyGrid::clearance_m) where the space allows; 0: the simplified path as it is. SE(2)
  // only: Dubins and Reeds-Shepp paths stay on their curves.
  double preferred_clearance_m = 0.0;

  template <class V>
  void visit(V& v) {
    v.choice("planner", planner,
             {{"rrt_star", PlannerAlgorithm::kRrtStar}, {"prm_star", PlannerAlgorithm::kPrmStar},
              {"rrt_connect", PlannerAlgorithm::kRrtConnect}});
    v.choice("state_space", state_space,
             {{"se2", StateSpaceKind::kSe2}, {"dubins", StateSpaceKind::kDubins},
              {"reeds_shepp", StateSpaceKind::kReedsShepp}});
    v("turning_radius_m", turning_radius_m, core::Limits<double>{1e-3, 100.0});
    v("max_iterations", max_iterations, core::Limits<int>{1, 1 << 30});
    v("stop_at_first_solution", stop_at_first_solution);
    v("time_limit_s", time_limit_s, core::Limits<double>{0.0, 3600.0});
    v("seed", seed, core::Limits<int>{1, std::numeric_limits<int>::max()});
    v("simplify", simplify);
    v.choice("unknown_cells", unknown_cells, {{"free", UnknownCells::kFree}, {"occupied", UnknownCells::kOccupied}});
    v("goal_tolerance_m", goal_tolerance_m, core::Limits<double>{1e-4, 100.0});
    v("goal_snap_radius_m", goal_snap_radius_m, core::Limits<double>{0.0, 100.0});
    v("check_reachability", check_reachability);
    v("path_step_m", path_step_m, core::Limits<double>{1e-3, 10.0});
    v("preferred_clearance_m", preferred_clearance_m, core::Limits<double>{0.0, 10.0});
  }
};

enum class PlanStatus { kSolved, kApproximate, kNoPath, kStartInvalid, kGoalInvalid };
const char* to_string(PlanStatus status);

struct PlanResult {
  PlanStatus status = PlanStatus::kNoPath;
  // Start to end, path_step_m apart (kSolved and kApproximate; empty otherwise). For kApproximate the end
  // is the state nearest the goal that was reached.
  std::vector<Pose2d> path_world;
  double length_m = 0.0;                         // xy length of path_world
  Eigen::Vector2d goal_world = Eigen::Vector2d::Zero();  // the goal used (after snapping)
  double distance_to_goal_m = 0.0;               // from the path's end to goal_world
  int iterations = 0;                            // termination-condition calls
  bool solved() const { return status == PlanStatus::kSolved; }
};

class PathPlanner {
 public:
  using Config = PathPlannerConfig;

  // Throws InputError for a config OMPL cannot use.
  explicit PathPlanner(const Config& config, core::Logger logger = core::null_logger());

  // Plans from start (x, y, yaw) to goal (x, y) on the grid. `blocked` disks are regions the robot's
  // centre must not enter (not inflated by the robot's radius).
  PlanResult plan(const OccupancyGrid& grid, const Pose2d& start_world, const Eigen::Vector2d& goal_world,
                  const std::vector<Disk>& blocked = {}) const;

  const Config& config() const { return config_; }

 private:
  Config config_;
  core::Logger logger_;
};

// Index of the first pose of `path_world` whose position is not traversable (or inside a blocked
// disk), or -1 when the whole path is clear; positions between poses are checked every half cell.
// For replanning when the map changes or a path is blocked.
int first_blocked_pose(const OccupancyGrid& grid, const std::vector<Pose2d>& path_world, UnknownCells unknown,
                       const std::vector<Disk>& blocked = {});

}  // namespace fleetslam::planners
