#pragma once
// Assigns different goals (frontier goals or waypoints) to different robots, greedily and
// deterministically: repeatedly the (robot, goal) pair of least cost among unassigned robots and goals is
// taken, where cost = travel cost (straight line, or path length over the grid's traversable cells) plus a
// penalty for goals near goals already given to other robots (separation_penalty_m * (1 - d /
// separation_m) for each such goal closer than separation_m), minus gain_weight_m_per_m2 times the goal's
// gain when gains are given (exploration: the unknown floor a frontier would show, so that a doorway onto
// an unseen room comes before the leftovers of the room a robot is in). Ties go to the lower robot index, then the
// lower goal index. A goal at the spot of one already given (within same_goal_m) is not given again.
// Unreachable goals (grid cost infinite) are never assigned; robots left without a goal
// get -1.

#include <vector>

#include <Eigen/Core>

#include "fleetslam/core/config.hpp"
#include "fleetslam/planners/occupancy_grid.hpp"

namespace fleetslam::planners {

enum class AssignmentCost { kStraightLine, kGridPath };

struct GoalAssignmentConfig {
  AssignmentCost cost = AssignmentCost::kGridPath;
  double separation_m = 2.0;
  double separation_penalty_m = 5.0;
  UnknownCells unknown_cells = UnknownCells::kOccupied;  // for kGridPath
  double gain_weight_m_per_m2 = 0.0;  // metres of travel one square metre of gain is worth (0: gains ignored)
  // A goal within this of one already given is given too: two robots are never sent to one spot (two
  // frontiers snapped to one cell), whatever the separation penalty. 0: identical positions only.
  double same_goal_m = 0.0;

  template <class V>
  void visit(V& v) {
    v.choice("cost", cost, {{"straight_line", AssignmentCost::kStraightLine}, {"grid_path", AssignmentCost::kGridPath}});
    v("separation_m", separation_m, core::Limits<double>{0.0, 1000.0});
    v("separation_penalty_m", separation_penalty_m, core::Limits<double>{0.0, 1e6});
    v.choice("unknown_cells", unknown_cells, {{"free", UnknownCells::kFree}, {"occupied", UnknownCells::kOccupied}});
    v("gain_weight_m_per_m2", gain_weight_m_per_m2, core::Limits<double>{0.0, 1e6});
    v("same_goal_m", same_goal_m, core::Limits<double>{0.0, 1000.0});
  }
};

struct GoalAssignment {
  std::vector<int> goal_of_robot;  // index into the goals, -1: none
  std::vector<double> cost_m;      // travel cost of the assigned goal (infinity when none)
};

class GoalAssigner {
 public:
  using Config = GoalAssignmentConfig;
  explicit GoalAssigner(const Config& config) : config_(config) { core::check_config(config_, "goal_assignment"); }

  // grid is needed for kGridPath (InputError when null). gains_m2: empty, or one per goal (InputError
  // otherwise, or for a gain that is negative or not finite).
  GoalAssignment assign(const std::vector<Eigen::Vector2d>& robots_world, const std::vector<Eigen::Vector2d>& goals_world,
                        const OccupancyGrid* grid = nullptr, const std::vector<double>& gains_m2 = {}) const;

  const Config& config() const { return config_; }

 private:
  Config config_;
};

// The goals of frontiers that have one (Frontier::has_goal), in order.
std::vector<Eigen::Vector2d> frontier_goals(const std::vector<Frontier>& frontiers);

}  // namespace fleetslam::planners
